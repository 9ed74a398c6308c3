#!/usr/bin/env bash
# ln_generate --depfile: the depfile names the output as its target and, as
# absolute paths, every definition file read -- the requested ones, those they
# `define` (also through another definition, relative to the importing file
# or found on the search path), and the md.conf of a search directory -- and
# nothing else. Without -o (stdout) --depfile is refused.
#
# usage: ln_generate_depfile_test.sh <ln_generate>
# Exit status: 0 pass, 1 failure.
set -u -o pipefail

generate=$1
work=$(cd "$(mktemp -d "${TMPDIR:-/tmp}/ln_generate_depfile.XXXXXX")" && pwd -P)
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }

md="$work/md dir"  # a space, which the depfile must escape
other="$work/other"
mkdir -p "$md/demo" "$other/shared"
cat >"$md/demo/top" <<'EOF'
define point_t as "point"
define stamp_t as "shared/stamp"
point_t where
stamp_t when
EOF
cat >"$md/demo/point" <<'EOF'
define scalar_t as "scalar"
scalar_t x
scalar_t y
EOF
echo "double value" >"$md/demo/scalar"
echo "uint64_t ns" >"$other/shared/stamp"
echo "int32_t never" >"$md/demo/unused"
echo "$other" >"$md/md.conf"

depfile="$work/out/messages.h.d"
if ! env -u LN_MESSAGE_DEFINITION_DIRS HOME="$work" \
    "$generate" -f --md-dir "$md" -o "$work/out/messages.h" --depfile "$depfile" demo/top \
    >"$work/log" 2>&1; then
  cat "$work/log"
  fail "ln_generate --depfile exited with an error"
fi
[ -s "$work/out/messages.h" ] && pass "header written" || fail "no header"
[ -s "$depfile" ] || { fail "no depfile at $depfile"; exit 1; }
cat "$depfile"

# Undo Make's escaping and line continuations: target, then one file a line.
parsed=$(sed -e 's/ \\$//' -e 's/^  //' -e 's/\\ / /g' "$depfile")
target=$(head -n1 <<<"$parsed")
[ "$target" = "$work/out/messages.h:" ] && pass "target is the output" || fail "target line '$target'"
listed=$(tail -n +2 <<<"$parsed" | sort)
expected=$(printf '%s\n' "$md/demo/top" "$md/demo/point" "$md/demo/scalar" "$other/shared/stamp" \
  "$md/md.conf" | sort)
if [ "$listed" = "$expected" ]; then
  pass "depfile lists exactly the definitions read (direct, nested, via md.conf) and md.conf"
else
  fail "depfile lists
$listed
expected
$expected"
fi
grep -q "md\\\\ dir" "$depfile" && pass "spaces escaped" || fail "space in a path not escaped"

if "$generate" -f --md-dir "$md" -o - --depfile "$work/x.d" demo/top >/dev/null 2>"$work/err"; then
  fail "--depfile with -o - accepted"
elif grep -q "depfile" "$work/err" && [ ! -e "$work/x.d" ]; then
  pass "--depfile with stdout output refused: $(head -n1 "$work/err")"
else
  fail "unclear refusal: $(cat "$work/err")"
fi

[ $failures = 0 ] && echo "ln_generate depfile: all passed" && exit 0
echo "ln_generate depfile: $failures failed"
exit 1
