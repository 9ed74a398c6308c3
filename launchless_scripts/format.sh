#!/usr/bin/env bash
# Formats the tree, or with --check only reports what is not formatted or not lint-clean:
#   C and C++: clang-format (.clang-format), every tracked *.c *.h *.cc *.cpp *.hpp;
#   Python:    ruff format and ruff check (ruff.toml).
# Needs clang-format and ruff (setup.sh installs both; ruff lives in the project venv).
# Exit status 1 when --check finds something, with the files named.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

check=0
case "${1:-}" in
  --check) check=1 ;;
  "") ;;
  *) echo "usage: format.sh [--check]" >&2; exit 2 ;;
esac
command -v clang-format > /dev/null || { echo "format.sh: clang-format missing (bash launchless_scripts/setup.sh)" >&2; exit 2; }
command -v ruff > /dev/null || { echo "format.sh: ruff missing (. launchless_scripts/env.sh)" >&2; exit 2; }

mapfile -t sources < <(git ls-files -- '*.c' '*.h' '*.cc' '*.cpp' '*.hpp')
status=0
if [ "$check" -eq 1 ]; then
  clang-format --dry-run -Werror "${sources[@]}" || { echo "format.sh: C/C++ not formatted (run launchless_scripts/format.sh)" >&2; status=1; }
  ruff format --check . || { echo "format.sh: Python not formatted (run launchless_scripts/format.sh)" >&2; status=1; }
  ruff check --no-fix . || status=1
else
  clang-format -i "${sources[@]}"
  ruff format .
  ruff check --fix . || status=1
fi
exit $status
