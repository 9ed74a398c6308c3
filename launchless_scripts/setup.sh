#!/usr/bin/env bash
# One-command set-up for ln_core, on Debian 12:
#   1. Debian packages (apt-get update only when one is missing),
#   2. two venvs in a cache dir outside the repo, rebuilt only when their recipe changed:
#        venv-ros   the project venv: ROS 2 Jazzy from PyPI + colcon + test/bench tools (requirements.txt)
#        venv-ln29  the released LN 2.9.0 (ln_manager, ln_generate), for differential tests (requirements-ln29.txt)
#   3. colcon build of the workspace at the repo root into build/ install/ log/ (options in colcon.meta).
# A re-run with nothing changed takes seconds. Usage: bash launchless_scripts/setup.sh [--no-build]
# Environment: LN_CORE_CACHE (default ~/.cache/ln_core), LN_CORE_PYTHON (a CPython 3.11 with headers).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(dirname "$HERE")
CACHE=${LN_CORE_CACHE:-$HOME/.cache/ln_core}
ROS_VENV=$CACHE/venv-ros
LN29_VENV=$CACHE/venv-ln29
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1 DEBIAN_FRONTEND=noninteractive

APT_PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git   # toolchain (ccache is used by ln_core's CMakeLists)
  libgtest-dev libgmock-dev                                 # C++ unit tests
  iproute2 util-linux procps                                # ip/unshare (shared/tools/netns-run), taskset, flock, ps
  python3-dev python3-venv                                  # Python headers and venv for the fallback interpreter
  libgirepository1.0-dev libcairo2-dev gir1.2-glib-2.0 gir1.2-gtk-3.0  # LN 2.9 reference: builds PyGObject; Gtk typelib
  libmatio-dev libssl-dev libeigen3-dev                     # logger files in MATLAB format; DSA signatures (libcrypto EVP); ln/parameters_eigen.h
  clang-format                                              # the C/C++ format check (.ci/run)
)

log() { printf '[setup %s] %s\n' "$(date +%H:%M:%S)" "$*"; }
die() { printf 'setup.sh: error: %s\n' "$*" >&2; exit 1; }

install_apt_packages() {
  local installed p missing=()
  installed=" $( (dpkg-query -W -f='${Package}=${db:Status-Abbrev}\n' "${APT_PACKAGES[@]}" 2>/dev/null || true) \
                  | sed -n 's/=ii *$//p' | tr '\n' ' ') "
  for p in "${APT_PACKAGES[@]}"; do
    [[ $installed == *" $p "* ]] || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then log "apt: all ${#APT_PACKAGES[@]} packages present"; return; fi
  local sudo=()
  if [ "$(id -u)" != 0 ]; then
    command -v sudo >/dev/null || die "not root and no sudo; install these Debian packages first: ${missing[*]}"
    sudo=(sudo -n)
  fi
  log "apt: installing ${missing[*]} (output: $CACHE/apt.log)"
  { timeout 900 "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=300 update \
    && timeout 1800 "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=300 install -y --no-install-recommends "${missing[@]}"
  } > "$CACHE/apt.log" 2>&1 || { tail -n 30 "$CACHE/apt.log" >&2; die "apt-get failed for: ${missing[*]}"; }
}

# Prints the path of a CPython 3.11 that has Python.h and ensurepip (the ROS wheels are cp311): the
# real interpreter, also when a virtual environment (ours, say) is active.
find_python() {
  local c
  for c in "${LN_CORE_PYTHON:-}" python3.11 python3 /usr/bin/python3.11; do
    [ -n "$c" ] && command -v "$c" >/dev/null 2>&1 || continue
    timeout 30 "$c" - 2>/dev/null <<'EOF' && return 0
import ensurepip, os, sys, sysconfig
assert sys.version_info[:2] == (3, 11)
assert os.path.isfile(os.path.join(sysconfig.get_paths()["include"], "Python.h"))
print(os.path.realpath(sys.executable))
EOF
  done
  return 1
}

# ros2_from_pypi.md Q1: fix build-machine paths baked into the wheels' exported CMake files.
fix_ros_venv() {
  local v=$1 py=$1/bin/python pyinc npinc tx files
  pyinc=$(timeout 60 "$py" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
  npinc=$(timeout 60 "$py" -c "import numpy; print(numpy.get_include())")
  [ -f "$pyinc/Python.h" ] || die "no Python.h in $pyinc"
  files=$(grep -l /opt/python/cp311-cp311/ "$v"/share/*/cmake/*.cmake || true)
  [ -n "$files" ] && sed -i "s#/opt/python/cp311-cp311/include/python3.11#$pyinc#g; s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$npinc#g" $files
  tx=$(ls "$v"/lib/python3.11/site-packages/ros_fastrtps.libs/libtinyxml2-*.so* | head -n 1)
  [ -f "$tx" ] || die "vendored libtinyxml2 not found in $v"
  sed -i "s#/usr/lib64/libtinyxml2.so#$tx#g" "$v/share/fastrtps/cmake/fastrtps-shared-targets.cmake"
  if grep -rlq -e /opt/python/cp311-cp311/ -e /usr/lib64/libtinyxml2.so "$v/share" "$v/lib/cmake"; then
    die "build-machine paths are left in $v/share (the wheels changed?): grep -rl /opt/python/cp311-cp311/ $v/share"
  fi
  timeout 120 "$py" -c "import rclpy, rosidl_adapter, ament_package, colcon_core, numpy, yaml, pytest, matplotlib, cyclonedds, nanobind" \
    || die "the project venv does not import its packages"
}

check_ln29_venv() {
  timeout 120 "$1/bin/ln_manager" -h >/dev/null 2>&1 || die "'$1/bin/ln_manager -h' fails (PyGObject or the Gtk typelib missing?)"
  local header
  header=$(timeout 120 "$1/bin/ln_generate" -o - ln/string 2>&1) || true
  [[ $header == *LN_STRING_MD_NAME* ]] || die "'$1/bin/ln_generate -o - ln/string' does not generate a header: $header"
}

# ensure_venv DIR REQUIREMENTS CHECK_FUNCTION: (re)creates DIR when the requirements, the check/fix
# function or the interpreter changed. The stamp is written last, so an interrupted run starts over.
ensure_venv() {
  local dir=$1 req=$2 fn=$3 key
  key=$({ cat "$req"; declare -f "$fn"; echo "$PY"; } | sha256sum | cut -c1-16)
  if [ "$(cat "$dir/.ln_core_stamp" 2>/dev/null)" = "$key" ]; then
    log "$(basename "$dir"): up to date"; return
  fi
  log "$(basename "$dir"): creating from $(basename "$req") with $PY"
  rm -rf "$dir"
  timeout 300 "$PY" -m venv "$dir" || die "python -m venv $dir failed"
  timeout 1800 "$dir/bin/pip" install -q -r "$req" || die "pip install -r $req into $dir failed"
  "$fn" "$dir"
  echo "$key" > "$dir/.ln_core_stamp"
  log "$(basename "$dir"): ready ($(du -sh "$dir" | cut -f1))"
}

colcon_build() {
  cd "$ROOT"
  set +u; . "$ROS_VENV/bin/activate"; set -u
  # Build against the venv only (not against whatever workspace the calling shell had sourced).
  export AMENT_PREFIX_PATH=$ROS_VENV CMAKE_PREFIX_PATH=$ROS_VENV ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
  unset COLCON_PREFIX_PATH
  log "colcon build in $ROOT"
  # Build trees of the benchmarks and the sanitizer run are not packages.
  for d in build-bench build-asan; do mkdir -p "$ROOT/$d" && touch "$ROOT/$d/COLCON_IGNORE"; done
  timeout 2700 colcon build --event-handlers desktop_notification- console_cohesion+ \
    --cmake-args -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    || die "colcon build failed (logs: $ROOT/log/latest_build/)"
}

[ "${1:-}" = "" ] || [ "${1:-}" = "--no-build" ] || die "usage: setup.sh [--no-build]"
start=$SECONDS
mkdir -p "$CACHE"
exec 9>"$CACHE/.setup.lock"
flock -w 3600 9 || die "another setup.sh holds $CACHE/.setup.lock"

install_apt_packages
PY=$(find_python) || die "no CPython 3.11 with headers found (set LN_CORE_PYTHON=/path/to/python3.11)"
ensure_venv "$ROS_VENV" "$HERE/requirements.txt" fix_ros_venv
ensure_venv "$LN29_VENV" "$HERE/requirements-ln29.txt" check_ln29_venv
[ "${1:-}" = "--no-build" ] || colcon_build
log "done in $((SECONDS - start)) s; use it with: . $HERE/env.sh"
