#!/usr/bin/env bash
# The demo, run by demo.sh inside the project environment (env.sh sourced).
# What it shows today: ln_core's ln_generate turning the elevator example's
# message definitions into the LN 2.9 header API, used from C and from C++.
# Then the elevator example on ln_core, bridged to ROS 2 by ln_ros2_bridge
# inside a private network namespace (demo_bridge.sh).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
MSGDEFS=$ROOT/ln_core/examples/elevator/msgdefs
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
NAMES=(elevator/sensors/floor_count elevator/actors/motor_control elevator/request/elevator_call)

echo "== ln_generate for the elevator definitions"
ln_generate --md-dir "$MSGDEFS" -o "$WORK/ln_messages.h" "${NAMES[@]}"
grep -E '_MD_NAME "|_SIGNATURE "' "$WORK/ln_messages.h"

echo; echo "== the definitions as the model sees them (ln_md_info)"
ln_md_info --md-dir "$MSGDEFS" elevator/request/elevator_call | python -c '
import json, sys
d = json.loads(sys.stdin.readline())
print(d["name"], d["kind"], "hash", d["hash"][:16] + "...")
print("signature:", d["signature"])
for s in d["structs"]:
    print(" ", s["section"], s["size"], "bytes:", ", ".join("%s@%d" % (f["name"], f["offset"]) for f in s["fields"]))' 

echo; echo "== the generated structs from C and C++ (-Wall -Werror)"
INCLUDE=$(dirname "$(command -v ln_generate)")/../include
cat > "$WORK/sizes.c" <<'C'
#include <stdio.h>
#include "ln_messages.h"
int main(void) {
  elevator_sensors_floor_count_t sensors = {0};
  sensors.floor = 3;
  printf("C:   sizeof(elevator_sensors_floor_count_t) = %zu, floor = %d\n", sizeof sensors, (int)sensors.floor);
  printf("C:   sizeof(elevator_request_elevator_call_t) = %zu\n", sizeof(elevator_request_elevator_call_t));
  return 0;
}
C
cat > "$WORK/provider.cpp" <<'CPP'
#include <cstdio>
#include "ln_messages.h"
// An LN 2.9-style provider class: derives from the generated base class.
class ElevatorServer : public elevator::request::elevator_call_base {
 public:
  int on_elevator_call(ln::service_request& req, elevator::request::elevator_call_t& data) override {
    data.resp.reached_floor = data.req.target_floor;
    return req.respond();
  }
};
int main() {
  std::printf("C++: elevator::request::elevator_call_t has req (%zu bytes) and resp (%zu bytes)\n",
              sizeof(elevator::request::elevator_call_t::request_t),
              sizeof(elevator::request::elevator_call_t::response_t));
  return 0;
}
CPP
gcc -std=c11 -Wall -Wextra -Werror -I"$WORK" -I"$INCLUDE" -o "$WORK/sizes" "$WORK/sizes.c"
"$WORK/sizes"
g++ -std=c++17 -Wall -Wextra -Werror -I"$WORK" -I"$INCLUDE" -c -o "$WORK/provider.o" "$WORK/provider.cpp"
echo "C++: an LN 2.9-style provider class compiles against the generated header"

echo; echo "== the elevator on ln_core, bridged to ROS 2 (LN publisher -> bridge -> ROS 2 subscriber, plus a ROS 2 service call)"
bash "$(dirname "${BASH_SOURCE[0]}")/demo_bridge.sh" --ln ln_core
