#!/usr/bin/env bash
# The LN <-> ROS 2 bridge demo (ln_ros2_bridge), no launch system:
#   an LN manager, the LN elevator (simulator + controller, Python or C++), ln_ros2_bridge,
#   and a ROS 2 listener that shows the LN sensor data and commands the elevator to a floor
#   through a ROS 2 service call (reached_floor == requested).
# Everything runs inside netns-run (a private network namespace with only loopback) and is
# stopped by PID at the end. Usage (from anywhere; after setup.sh):
#   bash launchless_scripts/demo_bridge.sh [--ln ln29|ln_core] [--lang py|cpp|mixed] [--floor N]
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ELEVATOR=$(cd "$HERE/../ln_core/examples/elevator" && pwd)
ROOT=$(dirname "$HERE")
LN=ln29 LANGS=py FLOOR=3
while [ $# -gt 0 ]; do
  case $1 in
    --ln) LN=$2; shift 2 ;;
    --lang) LANGS=$2; shift 2 ;;
    --floor) FLOOR=$2; shift 2 ;;
    *) echo "demo_bridge.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
case $LANGS in
  py) SIM=py CONTROL=py ;;
  cpp) SIM=cpp CONTROL=cpp ;;
  mixed) SIM=cpp CONTROL=py ;;
  *) echo "demo_bridge.sh: --lang py|cpp|mixed" >&2; exit 2 ;;
esac
if [ -z "${VIRTUAL_ENV:-}" ] || ! python -c "import rclpy, msg_mapping" 2>/dev/null; then
  . "$HERE/env.sh"
fi
CPP_ARGS=()
if [ "$SIM" = cpp ] || [ "$CONTROL" = cpp ]; then
  CPP_DIR=${LN_CORE_CACHE:-$HOME/.cache/ln_core}/elevator-$LN
  bash "$ELEVATOR/build.sh" "$LN" "$CPP_DIR"
  CPP_ARGS=(--cpp-dir "$CPP_DIR")
fi
NETNS=${LN_NETNS_RUN:-/work/shared/tools/netns-run}
[ -x "$NETNS" ] || NETNS=$(command -v netns-run || true)
if [ -n "$NETNS" ] && "$NETNS" true 2>/dev/null; then
  exec timeout 600 "$NETNS" python "$ELEVATOR/demo.py" --ln "$LN" --sim "$SIM" --control "$CONTROL" \
    --floor "$FLOOR" "${CPP_ARGS[@]}"
fi
echo "demo_bridge.sh: no network namespace possible here; DDS kept on loopback by settings instead" >&2
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
exec timeout 600 python "$ELEVATOR/demo.py" --ln "$LN" --sim "$SIM" --control "$CONTROL" \
  --floor "$FLOOR" "${CPP_ARGS[@]}"
