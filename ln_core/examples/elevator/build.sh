#!/usr/bin/env bash
# Builds the C++ elevator programs against one LN system:
#   build.sh ln29|ln_core OUT_DIR
# ln29: LN 2.9's ln_generate, headers and libln.so from $LN_CORE_LN29_VENV;
# ln_core: ln_core's ln_generate, headers and libln.so (colcon install, or LN_CORE_PREFIX=<dir
# with bin/ include/ lib/>). The header comes from msgdefs/ beside this script.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
KIND=${1:?usage: build.sh ln29|ln_core OUT_DIR}
OUT=${2:?usage: build.sh ln29|ln_core OUT_DIR}
MSGDEFS=$HERE/msgdefs
MESSAGES="elevator/sensors/floor_count elevator/actors/motor_control elevator/request/elevator_call"
mkdir -p "$OUT"
case $KIND in
  ln29)
    VENV=${LN_CORE_LN29_VENV:-$HOME/.cache/ln_core/venv-ln29}
    SITE=$(echo "$VENV"/lib/python3*/site-packages)
    [ -x "$VENV/bin/ln_generate" ] || { echo "build.sh: no LN 2.9 venv at $VENV" >&2; exit 1; }
    GENERATE=("$VENV/bin/ln_generate")
    INC=$SITE/liblinks_and_nodes/include
    LIB=$SITE/liblinks_and_nodes/lib
    mkdir -p "$OUT/home"; export HOME=$OUT/home   # LN 2.9's ln_generate may write into $HOME
    ;;
  ln_core)
    PREFIX=${LN_CORE_PREFIX:-$ROOT/install/ln_core}
    GENERATE=("$PREFIX/bin/ln_generate")
    INC=$PREFIX/include
    LIB=$PREFIX/lib
    [ -x "${GENERATE[0]}" ] || { echo "build.sh: no ln_core ln_generate in $PREFIX/bin (LN_CORE_PREFIX)" >&2; exit 1; }
    [ -e "$LIB/libln.so" ] || { echo "build.sh: no ln_core libln.so in $LIB (LN_CORE_PREFIX)" >&2; exit 1; }
    ;;
  *) echo "build.sh: unknown LN system '$KIND' (ln29 or ln_core)" >&2; exit 2 ;;
esac
timeout 120 "${GENERATE[@]}" --md-dir "$MSGDEFS" -f -o "$OUT/ln_messages.h" $MESSAGES
for program in elevator_sim elevator_control; do
  timeout 300 g++ -O2 -std=c++17 -Wall -Wextra -Wno-address-of-packed-member -I"$OUT" -I"$INC" "$HERE/$program.cpp" -o "$OUT/$program" \
    -L"$LIB" -Wl,-rpath,"$LIB" -lln -lpthread
done
echo "build.sh: $OUT/elevator_sim $OUT/elevator_control ($KIND)"
