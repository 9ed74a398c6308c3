# Source me from bash, from any directory:  . launchless_scripts/env.sh
# Activates the project venv (ROS 2 Jazzy from PyPI, colcon, pytest, ...) and the colcon workspace
# (install/), and puts the project's tools, libraries, Python packages and CMake packages on the paths.
# Exports LN_CORE_ROOT, LN_CORE_LN29_VENV (the LN 2.9 reference venv, for differential tests) and
# ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST unless already set. Safe to source twice; never exits your shell.
# Run launchless_scripts/setup.sh first (it creates the venvs and builds install/).

if ! (return 0 2>/dev/null); then
  echo "env.sh must be sourced: . ${BASH_SOURCE[0]}" >&2
  exit 1
fi

# _ln_core_prepend VAR DIR: put DIR first in the ':'-list VAR, removing other copies of it.
_ln_core_prepend() {
  local var=$1 dir=$2 cur
  [ -d "$dir" ] || return 0
  cur=":${!var:-}:"
  while [[ $cur == *":$dir:"* ]]; do cur=${cur//":$dir:"/:}; done
  cur=${cur#:}; cur=${cur%:}
  printf -v "$var" '%s' "$dir${cur:+:$cur}"
  export "$var"
}

_ln_core_env() {
  local - here root cache venv prefix pyver
  set +eu
  here=$(CDPATH='' cd "$(dirname "${BASH_SOURCE[0]}")" && pwd) || return 1
  root=$(dirname "$here")
  cache=${LN_CORE_CACHE:-$HOME/.cache/ln_core}
  venv=$cache/venv-ros
  if [ ! -f "$venv/bin/activate" ] || [ ! -f "$venv/.ln_core_stamp" ]; then
    echo "env.sh: no project venv at $venv; run: bash $here/setup.sh" >&2
    return 1
  fi
  # activate first deactivates an earlier activation, which restores PATH: no growth when sourced twice
  . "$venv/bin/activate" || return 1
  # site-packages of the venv's Python (python3.X), where colcon installs Python packages
  pyver=$("$venv/bin/python" -c 'import sys; print("python%d.%d" % sys.version_info[:2])') || return 1
  _ln_core_prepend AMENT_PREFIX_PATH "$venv"
  _ln_core_prepend CMAKE_PREFIX_PATH "$venv"
  if [ -f "$root/install/setup.bash" ]; then
    . "$root/install/setup.bash" || { echo "env.sh: sourcing $root/install/setup.bash failed" >&2; return 1; }
    # what colcon's hooks may leave out for plain CMake packages, e.g. find_package(ln) from any CMake project
    for prefix in "$root"/install/*/; do
      prefix=${prefix%/}
      _ln_core_prepend CMAKE_PREFIX_PATH "$prefix"
      _ln_core_prepend PATH "$prefix/bin"
      _ln_core_prepend PATH "$prefix/lib/${prefix##*/}"   # ament_python commands (ros2 run's lib/<package>/)
      _ln_core_prepend LD_LIBRARY_PATH "$prefix/lib"
      _ln_core_prepend PYTHONPATH "$prefix/lib/$pyver/site-packages"
    done
  else
    echo "env.sh: $root/install/ not built yet (bash $here/setup.sh); only the venv is active" >&2
  fi
  export LN_CORE_ROOT=$root
  export LN_CORE_LN29_VENV=$cache/venv-ln29
  export LN_BENCH_PYTHON=$venv/bin/python
  export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
  return 0
}

_ln_core_env
_ln_core_rc=$?
unset -f _ln_core_env _ln_core_prepend
eval "unset _ln_core_rc; return $_ln_core_rc"
