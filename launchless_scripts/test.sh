#!/usr/bin/env bash
# THE test command (README; CI runs it through .ci/run):
#   1. setup.sh: Debian packages, venvs, colcon build of the workspace
#   2. colcon test + colcon test-result --verbose
#   3. ln_core again with -DLN_SANITIZE=ON (ASan+UBSan) in build-asan/, and its ctest suite
#   4. pytest over tests/ and the benchmark runner's smoke test
# Ends with the line "N passed, M failed" (ctest + pytest tests; a step that breaks counts as one
# failure) and exits non-zero on any failure. Every step is bounded by timeout.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(dirname "$HERE")
ASAN_DIR=$ROOT/build-asan
PASSED=0 FAILED=0 SKIPPED=0
FAILED_NAMES=()  # repeated at the end, so that the last lines of a CI log name every failure
start=$SECONDS

step() { printf '\n== test.sh: %s\n' "$*"; }
fail_step() { echo "test.sh: FAILED: $*" >&2; FAILED=$((FAILED + 1)); FAILED_NAMES+=("step: $*"); }
finish() {
  [ "$FAILED" -eq 0 ] || failure_details
  step "done in $((SECONDS - start)) s ($SKIPPED skipped)"
  local name
  for name in "${FAILED_NAMES[@]}"; do echo "test.sh: failed: $name"; done
  echo "$PASSED passed, $FAILED failed"
  [ "$FAILED" -eq 0 ] && exit 0 || exit 1
}

# count_junit FILE: prints "passed failed skipped" for the test cases of a JUnit XML file (ctest,
# pytest), then one line per failed case: "failed CLASS::NAME"
count_junit() {
  python3 - "$1" <<'EOF'
import sys, xml.etree.ElementTree as ET
n = {"passed": 0, "failed": 0, "skipped": 0}
failed = []
for case in ET.parse(sys.argv[1]).iter("testcase"):
    tags = {child.tag for child in case}
    outcome = "failed" if tags & {"failure", "error"} else "skipped" if "skipped" in tags else "passed"
    n[outcome] += 1
    if outcome == "failed":
        failed.append("failed %s::%s" % (case.get("classname", ""), case.get("name", "")))
print(n["passed"], n["failed"], n["skipped"])
print("\n".join(failed))
EOF
}

# failure_details: the end of each failed case's report from every JUnit file of this run, so that
# the tail of a CI log says why a test failed, not only which one
failure_details() {
  step "why tests failed (the end of each report)"
  python3 - "$ROOT" "$ASAN_DIR" <<'EOF' || true
import glob, os, sys, xml.etree.ElementTree as ET
root, asan = sys.argv[1:]
files = glob.glob(os.path.join(root, "build", "*", "pytest.xml"))
files += glob.glob(os.path.join(root, "build", "*", "test_results", "**", "*.xml"), recursive=True)
files += [os.path.join(asan, "ctest-junit.xml"), os.path.join(root, "log", "pytest-junit.xml")]
shown = 0
for path in files:
    try:
        cases = list(ET.parse(path).iter("testcase"))
    except (OSError, ET.ParseError):
        continue
    for case in cases:
        for problem in (child for child in case if child.tag in ("failure", "error")):
            if shown == 12:
                print("(more failures: see the full log)")
                sys.exit(0)
            shown += 1
            text = "\n".join(filter(None, [problem.get("message", ""), problem.text or ""]))
            lines = text.strip().splitlines()
            print("--- %s::%s (%s)" % (case.get("classname", ""), case.get("name", ""), os.path.relpath(path, root)))
            print("\n".join(line[:300] for line in lines[-25:]))
EOF
}

# add_results NAME RC JUNIT_FILE: adds the file's counts; a non-zero RC without a failed test is a broken step
add_results() {
  local name=$1 rc=$2 file=$3 p f s counts line
  if [ ! -f "$file" ] || ! counts=$(count_junit "$file") || ! read -r p f s <<< "$counts"; then
    fail_step "$name: exit $rc and no readable results in $file"; return
  fi
  while read -r line; do
    [ -n "$line" ] && FAILED_NAMES+=("$name: ${line#failed }")
  done < <(printf '%s\n' "$counts" | tail -n +2)
  echo "test.sh: $name: $p passed, $f failed, $s skipped"
  PASSED=$((PASSED + p)) FAILED=$((FAILED + f)) SKIPPED=$((SKIPPED + s))
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then fail_step "$name: exit $rc"; fi
}

# For the sanitizer build: drop the colcon install/ from the search paths, so its tests load
# build-asan's own libraries and not the uninstrumented ones (LD_LIBRARY_PATH beats RUNPATH).
without_install_paths() {
  local var
  for var in PATH LD_LIBRARY_PATH PYTHONPATH CMAKE_PREFIX_PATH AMENT_PREFIX_PATH; do
    export "$var=$(printf '%s' "${!var:-}" | tr ':' '\n' | grep -v "^$ROOT/install/" | paste -sd: -)"
  done
}

step "set-up and build (setup.sh)"
timeout 4000 bash "$HERE/setup.sh" || { fail_step "setup.sh (exit $?; see above)"; finish; }
. "$HERE/env.sh" || { fail_step "sourcing env.sh"; finish; }
cd "$ROOT"

step "format and lint (format.sh --check)"
timeout 600 bash "$HERE/format.sh" --check || fail_step "format and lint: run launchless_scripts/format.sh"

step "colcon test"
colcon test-result --delete-yes > /dev/null 2>&1 || true
rc=0; timeout 1800 colcon test --event-handlers desktop_notification- --ctest-args --timeout 300 || rc=$?
[ "$rc" -eq 0 ] || fail_step "colcon test (exit $rc)"
out=$(timeout 300 colcon test-result --verbose 2>&1) || true
printf '%s\n' "$out"
# "Summary: 12 tests, 0 errors, 1 failure, 2 skipped"
read -r t e f s < <(printf '%s\n' "$out" | sed -n 's/^Summary: \([0-9]*\) tests\{0,1\}, \([0-9]*\) errors\{0,1\}, \([0-9]*\) failures\{0,1\}, \([0-9]*\) skipped$/\1 \2 \3 \4/p') \
  || { t=0 e=0 f=0 s=0; echo "test.sh: no colcon test results"; }
PASSED=$((PASSED + t - e - f - s)) FAILED=$((FAILED + e + f)) SKIPPED=$((SKIPPED + s))
# colcon test-result --verbose names each failed case on a line "- NAME" after its results file
while read -r line; do FAILED_NAMES+=("colcon test: $line"); done < <(printf '%s\n' "$out" | awk '
  /^[^ -].*: [0-9]+ tests?, / { file = $1 }
  /^- / { sub(/^- /, ""); print file " " $0 }')

step "ln_core with ASan+UBSan in build-asan/"
mkdir -p "$ASAN_DIR" && touch "$ASAN_DIR/COLCON_IGNORE"
if ( without_install_paths
     timeout 600 cmake -S "$ROOT/ln_core" -B "$ASAN_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
       -DLN_SANITIZE=ON -DLN_WERROR=ON -DBUILD_TESTING=ON > "$ASAN_DIR/configure.log" 2>&1 \
       || { cat "$ASAN_DIR/configure.log"; exit 1; }
     timeout 2700 cmake --build "$ASAN_DIR" ); then
  rm -f "$ASAN_DIR/ctest-junit.xml"
  rc=0
  ( without_install_paths
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
    timeout 1800 ctest --test-dir "$ASAN_DIR" --output-on-failure --timeout 300 --output-junit "$ASAN_DIR/ctest-junit.xml" ) || rc=$?
  add_results "ctest (ASan+UBSan)" "$rc" "$ASAN_DIR/ctest-junit.xml"
else
  fail_step "ASan+UBSan build of ln_core"
fi

step "pytest tests/ bench/"
if [ -d tests ]; then
  has_files=$(find tests bench -name 'test_*.py' -o -name '*_test.py' | head -n 1)
  junit=$ROOT/log/pytest-junit.xml
  mkdir -p "$ROOT/log" && rm -f "$junit"
  rc=0; timeout 1800 python -m pytest tests bench/test_bench_runner.py -p no:cacheprovider -q --junitxml="$junit" || rc=$?
  if [ "$rc" -eq 5 ] && [ -z "$has_files" ]; then
    echo "test.sh: no Python tests in tests/"
  elif [ "$rc" -eq 5 ]; then
    fail_step "pytest collected no tests although tests/ has test files"
  else
    add_results pytest "$rc" "$junit"
  fi
else
  echo "test.sh: no tests/ directory"
fi

finish
