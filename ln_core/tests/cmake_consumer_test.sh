#!/usr/bin/env bash
# Installs ln_core from a build directory into a temporary prefix and builds
# the user project tests/cmake_consumer against it, once per package name
# (find_package(ln), find_package(liblinks_and_nodes)) and once with the
# fallback dependency scan. Checks that the generated headers exist, that the
# consumer compiles and runs, that an unchanged build does not run
# ln_generate again, and that touching a message definition regenerates
# exactly the headers that depend on it (ln_generate's depfile). Also checks the argument errors of
# generate_ln_message_headers() and the package's variables, version files
# and relocatability.
#
# usage: cmake_consumer_test.sh <ln_core build dir> [<work dir>]
# Exit status: 0 pass, 1 failure, 77 skipped (no ninja). The work directory
# (default: a new temporary one) is deleted afterwards unless KEEP_WORK=1.
set -u -o pipefail

if [ $# -lt 1 ] || [ ! -f "$1/CMakeCache.txt" ]; then
  echo "usage: $0 <ln_core build dir> [<work dir>]" >&2
  exit 1
fi
build_dir=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
consumer_src="$here/cmake_consumer"
step_timeout=${STEP_TIMEOUT:-300}

command -v cmake >/dev/null || { echo "SKIP: cmake not found"; exit 77; }
command -v ninja >/dev/null || { echo "SKIP: ninja not found"; exit 77; }

if [ $# -ge 2 ]; then
  work=$2
  rm -rf "$work" && mkdir -p "$work"
else
  work=$(mktemp -d "${TMPDIR:-/tmp}/ln_cmake_consumer.XXXXXX")
fi
work=$(cd "$work" && pwd)
if [ "${KEEP_WORK:-0}" != 1 ]; then
  trap 'rm -rf "$work"' EXIT
fi

# A clean environment for the consumer: no definition dirs from the caller.
unset LN_MESSAGE_DEFINITION_DIRS

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok:   $*"; }
run() { timeout "$step_timeout" "$@"; }
mtime() { stat -c '%y' "$1" 2>/dev/null || echo missing; }

# --- install -----------------------------------------------------------------
prefix="$work/prefix"
if ! run cmake --install "$build_dir" --prefix "$prefix" >"$work/install.log" 2>&1; then
  cat "$work/install.log"
  echo "FAIL: cmake --install $build_dir"
  exit 1
fi
pass "installed $build_dir into $prefix"
have_cppwrapper=0
[ -f "$prefix/include/ln/cppwrapper.h" ] && have_cppwrapper=1

# --- consumer builds -----------------------------------------------------------
# build <variant dir> <log name>: runs ninja, leaves its output in $log.
build() {
  log="$1/$2.log"
  run ninja -C "$1/build" >"$log" 2>&1
}

# check_variant <name> <package> <precise|glob> [cmake args]: precise =
# ln_generate's depfile names each header's definitions; glob = a generator
# without --depfile, so every definition in the directory is a dependency of
# every header and touching one regenerates all of them.
# next_build_has_no_work DIR BUILD: after a regeneration, building again does nothing.
next_build_has_no_work() {
  build "$1" "$2"
  grep -q "no work to do" "$log" && pass "$variant: ...and the next build has no work" ||
    { cat "$log"; fail "$variant: build after regeneration still had work"; }
}

check_variant() {
  local variant=$1 package=$2 scan=$3
  shift 3
  local dir="$work/$variant"
  echo "--- $variant: find_package($package) $*"
  mkdir -p "$dir"
  cp -R "$consumer_src" "$dir/src"
  local topics="$dir/build/consumer_topics/consumer_topics.h"
  local services="$dir/build/consumer_services/consumer_services.h"
  local cpp_services="$dir/build/consumer_cpp_services/consumer_services.h"
  local headers=("$topics" "$services")
  [ $have_cppwrapper = 1 ] && headers+=("$cpp_services")

  if ! run cmake -G Ninja -S "$dir/src" -B "$dir/build" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCONSUMER_PACKAGE="$package" "$@" \
      >"$dir/configure.log" 2>&1; then
    cat "$dir/configure.log"
    fail "$variant: configure"
    return
  fi
  local found_dir
  found_dir=$(sed -n "s/^${package}_DIR:PATH=//p" "$dir/build/CMakeCache.txt")
  if [ "$found_dir" = "$prefix/lib/cmake/$package" ] || [ "$found_dir" = "$prefix/lib64/cmake/$package" ]; then
    pass "$variant: found $package in the test prefix"
  else
    fail "$variant: ${package}_DIR is '$found_dir', not below $prefix"
  fi

  if ! build "$dir" build1; then
    cat "$log"
    fail "$variant: first build"
    return
  fi
  local h missing=0
  for h in "${headers[@]}"; do
    [ -s "$h" ] || { fail "$variant: generated header $h missing"; missing=1; }
  done
  [ $missing = 0 ] && pass "$variant: generated ${#headers[@]} headers"
  if [ "$scan" = precise ] && grep -Eq "msgdefs/consumer/pose( \\\\)?$" "$topics.d" 2>/dev/null; then
    pass "$variant: ln_generate wrote the depfile $topics.d"
  elif [ "$scan" = glob ] && [ ! -e "$topics.d" ]; then
    pass "$variant: no depfile (the generator has no --depfile)"
  else
    fail "$variant: depfile $topics.d: $(cat "$topics.d" 2>&1)"
  fi
  if out=$("$dir/build/consumer_cpp" 2>&1) && grep -q "consumer/pose_stamped|" <<<"$out" &&
     out_c=$("$dir/build/consumer_c" 2>&1) && grep -q "request=36 bytes" <<<"$out_c"; then
    pass "$variant: consumer_cpp and consumer_c compiled and ran"
    sed 's/^/        /' <<<"$out
$out_c"
  else
    fail "$variant: consumer programs: $out ${out_c:-}"
  fi

  # Unchanged: nothing to do, headers untouched.
  local before_topics before_services before_cpp
  before_topics=$(mtime "$topics"); before_services=$(mtime "$services"); before_cpp=$(mtime "$cpp_services")
  build "$dir" build2
  if grep -q "no work to do" "$log" && [ "$(mtime "$topics")" = "$before_topics" ] &&
     [ "$(mtime "$services")" = "$before_services" ]; then
    pass "$variant: unchanged rebuild does not run ln_generate"
  else
    cat "$log"
    fail "$variant: unchanged rebuild did work"
  fi

  # Touch the definition every header imports: all are regenerated.
  sleep 1  # a newer file time than the headers', on file systems with 1 s resolution
  touch "$dir/src/msgdefs/consumer/pose"
  if ! build "$dir" build3; then cat "$log"; fail "$variant: build after touching pose"; return; fi
  if grep -q "Generating LN message header consumer_topics/consumer_topics.h" "$log" &&
     grep -q "Generating LN message header consumer_services/consumer_services.h" "$log" &&
     [ "$(mtime "$topics")" != "$before_topics" ] && [ "$(mtime "$services")" != "$before_services" ] &&
     { [ $have_cppwrapper = 0 ] || [ "$(mtime "$cpp_services")" != "$before_cpp" ]; }; then
    pass "$variant: touching the imported definition consumer/pose regenerated all headers"
  else
    cat "$log"
    fail "$variant: touching consumer/pose did not regenerate every header"
  fi
  next_build_has_no_work "$dir" build4

  # Touch the service definition only: the topic header stays as it is.
  before_topics=$(mtime "$topics"); before_services=$(mtime "$services")
  sleep 1  # a newer file time than the headers', on file systems with 1 s resolution
  touch "$dir/src/msgdefs/consumer/set_pose"
  if ! build "$dir" build5; then cat "$log"; fail "$variant: build after touching set_pose"; return; fi
  if [ "$scan" = glob ]; then
    if grep -q "Generating LN message header consumer_services/consumer_services.h" "$log" &&
       [ "$(mtime "$services")" != "$before_services" ]; then
      pass "$variant: touching consumer/set_pose regenerated the headers (all: glob scan)"
    else
      cat "$log"
      fail "$variant: touching consumer/set_pose did not regenerate the service header"
    fi
  elif grep -q "Generating LN message header consumer_services/consumer_services.h" "$log" &&
     ! grep -q "consumer_topics.h" "$log" && [ "$(mtime "$topics")" = "$before_topics" ] &&
     [ "$(mtime "$services")" != "$before_services" ]; then
    pass "$variant: touching consumer/set_pose regenerated only the service headers"
  else
    cat "$log"
    fail "$variant: touching consumer/set_pose regenerated the wrong headers"
  fi
  next_build_has_no_work "$dir" build6
}

check_variant ln ln precise
check_variant liblinks_and_nodes liblinks_and_nodes precise
# A generator that writes no depfile (as LN 2.9's): its --help does not name
# --depfile, so the function falls back to the glob.
no_depfile_generator="$work/ln_generate_without_depfile"
printf '#!/bin/sh\n[ "$1" = --help ] && exit 0\nexec "%s" "$@"\n' "$prefix/bin/ln_generate" >"$no_depfile_generator"
chmod +x "$no_depfile_generator"
check_variant ln_glob_scan ln glob -Dliblinks_and_nodes_LN_GENERATE_EXECUTABLE="$no_depfile_generator"

# --- argument errors and package variables -------------------------------------
# probe <name> <expected regex> [cmake -D args]: configures a small C
# project that runs probe.cmake's CASE and greps its output.
probe_dir="$work/probe"
mkdir -p "$probe_dir/src/md/probe"
printf 'int32_t value\n' >"$probe_dir/src/md/probe/value"
cat >"$probe_dir/src/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.16)
project(ln_probe C)
if(CASE STREQUAL "variables")
  find_package(liblinks_and_nodes 2.9 REQUIRED)
  find_package(ln ${EXPECTED_LN_VERSION} REQUIRED COMPONENTS ln_md)
  foreach(var liblinks_and_nodes_FOUND ln_FOUND LIBLINKS_AND_NODES_PREFIX
          LIBLINKS_AND_NODES_INCLUDE_DIR liblinks_and_nodes_INCLUDE_DIRS ln_INCLUDE_DIRS
          LN_GENERATE_EXECUTABLE LN_MD_INFO_EXECUTABLE LN_BUILTIN_MESSAGE_DEFINITION_DIR
          LN_LIBRARY_VERSION LIBLINKS_AND_NODES_LIBRARY liblinks_and_nodes_LIBRARIES ln_LIBRARIES)
    message(STATUS "probe ${var}=${${var}}")
  endforeach()
  foreach(target ln::ln_md ln::ln_generate ln::ln_md_info)
    if(NOT TARGET ${target})
      message(FATAL_ERROR "probe: missing target ${target}")
    endif()
  endforeach()
  if(TARGET ln::ln AND NOT TARGET liblinks_and_nodes::liblinks_and_nodes)
    message(FATAL_ERROR "probe: ln::ln without liblinks_and_nodes::liblinks_and_nodes")
  endif()
  message(STATUS "probe targets ok")
  return()
endif()
if(CASE STREQUAL "component_ln")
  find_package(ln REQUIRED COMPONENTS ln)
  message(STATUS "probe component ln found")
  return()
endif()
find_package(ln REQUIRED)
set(md ${CMAKE_CURRENT_SOURCE_DIR}/md)
if(CASE STREQUAL "no_output")
  generate_ln_message_headers(t MESSAGES probe/value DIRECTORIES ${md})
elseif(CASE STREQUAL "no_messages")
  generate_ln_message_headers(t OUTPUT x.h DIRECTORIES ${md})
elseif(CASE STREQUAL "empty_messages")
  generate_ln_message_headers(t OUTPUT x.h MESSAGES DIRECTORIES ${md})
elseif(CASE STREQUAL "no_target")
  generate_ln_message_headers(OUTPUT x.h MESSAGES probe/value DIRECTORIES ${md})
elseif(CASE STREQUAL "unknown_md")
  generate_ln_message_headers(t OUTPUT x.h MESSAGES probe/nonexistent DIRECTORIES ${md})
elseif(CASE STREQUAL "bad_map")
  generate_ln_message_headers(t OUTPUT x.h MESSAGES probe/value MAP_SERVICE_BASE probe/value)
elseif(CASE STREQUAL "env_dirs")
  # No DIRECTORIES: LN_MESSAGE_DEFINITION_DIRS from the environment is used.
  generate_ln_message_headers(t OUTPUT x.h MESSAGES probe/value)
  message(STATUS "probe env_dirs ok")
endif()
EOF

# With PROBE_BUILD_TARGET set, the probe also builds that target after
# configuring (for errors that only the build can know).
probe() {
  local name=$1 expect=$2 want_rc=$3
  shift 3
  local out rc
  rm -rf "$probe_dir/build-$name"
  out=$(run cmake -G Ninja -S "$probe_dir/src" -B "$probe_dir/build-$name" -DCMAKE_PREFIX_PATH="$prefix" \
        -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCASE="$name" "$@" 2>&1)
  rc=$?
  if [ $rc = 0 ] && [ -n "${PROBE_BUILD_TARGET:-}" ]; then
    out=$(run ninja -C "$probe_dir/build-$name" "$PROBE_BUILD_TARGET" 2>&1)
    rc=$?
  fi
  probe_out=$out
  if { [ "$want_rc" = 0 ] && [ $rc = 0 ]; } || { [ "$want_rc" != 0 ] && [ $rc != 0 ]; }; then
    # CMake wraps long messages; match on the output as one line.
    if tr '\n' ' ' <<<"$out" | tr -s ' ' | grep -Eq "$expect"; then
      pass "probe $name: ${expect}"
      return 0
    fi
  fi
  echo "$out"
  fail "probe $name (exit $rc): expected /$expect/"
  return 1
}

echo "--- package probes"
ln_version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$build_dir/CMakeCache.txt")
probe variables "probe targets ok" 0 -DEXPECTED_LN_VERSION="$ln_version" &&
  grep "probe " <<<"$probe_out" | sed 's/^/        /'
probe no_output "OUTPUT <header file> is required" 1
probe no_messages "MESSAGES .* is required" 1
probe empty_messages "MESSAGES .* is required" 1
probe no_target "first argument must be the target name" 1
# An unknown definition is ln_generate's error when the header is built (nothing is
# scanned at configure time).
PROBE_BUILD_TARGET=t probe unknown_md "ln_generate: error: message definition 'probe/nonexistent' not found" 1
probe bad_map "MAP_SERVICE_BASE entries have the form" 1
if ls "$prefix"/lib*/libln.so >/dev/null 2>&1; then
  probe component_ln "probe component ln found" 0
else
  probe component_ln "required component ln .* is not part" 1
fi
LN_MESSAGE_DEFINITION_DIRS="$probe_dir/src/md" probe env_dirs "probe env_dirs ok" 0
grep -q -- "--md-dir $probe_dir/src/md" "$probe_dir/build-env_dirs/build.ninja" &&
  pass "probe env_dirs: ln_generate gets --md-dir from LN_MESSAGE_DEFINITION_DIRS" ||
  fail "probe env_dirs: LN_MESSAGE_DEFINITION_DIRS not passed to ln_generate"

# Relocatable: a copy of the prefix describes itself, not the original.
cp -R "$prefix" "$work/moved"
prefix_saved=$prefix
prefix="$work/moved"
if probe variables "probe LN_GENERATE_EXECUTABLE=$work/moved/bin/ln_generate" 0 \
    -DEXPECTED_LN_VERSION="$ln_version"; then
  pass "relocated prefix: paths follow the copy"
fi
prefix=$prefix_saved

echo
if [ $failures = 0 ]; then
  echo "cmake_consumer_test: PASS"
  exit 0
fi
echo "cmake_consumer_test: $failures failure(s)"
exit 1
