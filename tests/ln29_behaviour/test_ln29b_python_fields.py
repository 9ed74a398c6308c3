"""Python packet fields: programs/lnbt_fields.py run with LN 2.9's Python
against LN 2.9's manager and with ln_core's against ln_core's. It assigns
every field kind (scalars of each type, char arrays, numeric arrays,
sub-types and arrays of them; in services also dynamic arrays, char* and
lists of sub-types) in every form a program may use, sends it and prints
what the other side reads, or which exception classes the rejection has.

The transcripts must agree line by line, except that
* ln_core may accept a form LN 2.9 rejects (listed at the end of the run);
* a rejection must be catchable by the `except` clause LN 2.9's rejection
  needs (its most specific builtin class is among ours);
* the cases in DELIBERATE differ on purpose: LN 2.9 corrupts data silently
  there (README, "Python packets: where ln_core differs from LN 2.9").
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import lnbt_support as support
import pytest

SCRIPT = support.PROGRAMS_DIR / "lnbt_fields.py"
LINE = re.compile(r"^(topic|request|response) (\S+) (\S+): (.*)$")
SCRIPT_TIMEOUT = 120

INTEGER_ARRAYS = r"(i8a|u8a|i16a|u16a|i32a|u32a|i64a|u64a|bv|iv)"

#: "where field form" patterns -> why ln_core differs from LN 2.9 there: in
#: each LN 2.9 corrupts data silently (README, "Python packets").
DELIBERATE = [
    (
        r"(topic|request) (i8|sa\[1\]\.n|c) int_(min|below_min).*|topic (i8|c) (np\.int64_-1|int_-5)",
        "LN 2.9 reads a negative int8_t of a topic as unsigned (-128 arrives as 128); ln_core reads it signed",
    ),
    (
        rf"\S+ {INTEGER_ARRAYS} (list_of_floats|ndarray_float64|ndarray_int64_above_max)",
        "LN 2.9 truncates fractions and wraps out-of-range values into integer arrays; ln_core refuses them",
    ),
    (
        r"(request|response) (i32|u8) .*",
        "LN 2.9's services write integer scalars unchecked (wrapped, or -1 after a failed conversion); "
        "ln_core refuses what does not fit",
    ),
    (
        r"\S+ (label|s\.tag|c) (str_too_long|bytes_too_long|str_utf8|str_AB)",
        "text longer than its char field: LN 2.9 overwrites the next field (topics) or cuts it (services); "
        "ln_core refuses it",
    ),
    (
        r"topic (label|s\.tag) list_of_ints_negative",
        "a char array that is not UTF-8: LN 2.9's read fails, ln_core's returns the str with surrogate escapes",
    ),
    (r"topic label str_after_longer_str", "LN 2.9 keeps the tail of a longer text when a shorter one is assigned"),
    (r"topic sa list_short", "a shorter list for a sub-type array: LN 2.9 sends the items it had before"),
    (r"(request|response) text bytearray", "a bytearray for char*: LN 2.9 sends its repr, ln_core its bytes"),
    (
        r"response \* received",
        "LN 2.9 keeps the part assigned to a sub-type field (later changes to it show); ln_core copies it",
    ),
    (
        r"topic \* (initial|received)",
        "initial values: LN 2.9 starts with int 0 for every scalar and a list of "
        "zeros for a char array; ln_core with the field's own type",
    ),
    (r"request \* initial", "LN 2.9 fills a new request's char fields with blanks; ln_core with NULs"),
]


def python_for(system: support.System, lnbt) -> tuple[list[str], dict[str, str]]:
    """(argv prefix, extra environment) running Python with the system's package."""
    if system.is_reference:
        return [str(system.ln_manager.parent / "python")], {}  # the reference venv's bin/
    spec = importlib.util.find_spec("links_and_nodes")
    package = support.require(
        spec and spec.origin and Path(spec.origin).parent,
        "ln_core's Python package links_and_nodes (. launchless_scripts/env.sh)",
    )
    return [sys.executable], {"PYTHONPATH": str(package.parent)}


def transcript(lnbt, system) -> dict[tuple[str, str, str], str]:
    argv, extra = python_for(system, lnbt)
    program = support.run([*argv, SCRIPT], lnbt.client_env(system, **extra), timeout=SCRIPT_TIMEOUT)
    assert program.returncode == 0 and program.lines and program.lines[-1] == "done", (
        f"{system}: the script failed\n{program.describe()}"
    )
    cases = {}
    for line in program.lines:
        m = LINE.match(line)
        if m:
            cases[m.group(1), m.group(2), m.group(3)] = m.group(4)
    return cases


#: cases ln_core accepts and LN 2.9 rejects (reported at the end of the run)
ACCEPTED_MORE: list[str] = []


def deliberate(key) -> str | None:
    text = " ".join(key)
    return next((why for pattern, why in DELIBERATE if re.fullmatch(pattern, text)), None)


def verdict(key, ln: str, ours: str) -> str | None:
    """None when ours is acceptable next to LN's result, else the problem."""
    if ln == ours:
        return None
    if ln.startswith("rejected") and ours.startswith("ok"):
        ACCEPTED_MORE.append(" ".join(key))
        return None
    if ln.startswith("rejected") and ours.startswith("rejected"):
        ln_classes, our_classes = ln.split()[1].split(","), ours.split()[1].split(",")
        if ln_classes[0] == "Exception" or ln_classes[0] in our_classes:
            return None
        return f"rejected as {our_classes}, which `except {ln_classes[0]}` (LN 2.9's) does not catch"
    why = deliberate(key)
    if why:
        support.DIFFERENCES.append(f"python fields: {why}")
        return None
    return "differs"


def test_python_field_forms_match_ln29(lnbt):
    results = {system.label: transcript(lnbt, system) for system in lnbt.systems()}
    ln, ours = results["ln29"], results["ln_core"]
    assert len(ln) > 700, f"LN 2.9 ran only {len(ln)} cases"
    problems = [
        f"  {' '.join(key)}\n    LN 2.9:  {ln[key]}\n    ln_core: {ours.get(key, '<missing>')}"
        + ("" if key not in ours else f"\n    ({verdict(key, ln[key], ours[key])})")
        for key in ln
        if key not in ours or verdict(key, ln[key], ours[key])
    ]
    if ACCEPTED_MORE:
        support.DIFFERENCES.append(
            f"python fields: ln_core accepts {len(ACCEPTED_MORE)} forms LN 2.9 rejects, "
            f"e.g. {', '.join(ACCEPTED_MORE[:4])}"
        )
    extra = sorted(set(ours) - set(ln))
    assert not extra, f"ln_core printed cases LN 2.9 did not: {extra[:10]}"
    assert not problems, f"{len(problems)} of {len(ln)} cases differ:\n" + "\n".join(problems)


@pytest.mark.parametrize("rate", [-2, -3])
def test_on_request_rates(lnbt, rate):
    """RATE_ON_REQUEST_LAST and _NEXT from Python: LN 2.9 serves both the
    same way (a non-blocking read returns the newest packet, also again)."""
    script = (
        "import links_and_nodes as ln, sys\n"
        "c = ln.client('lnbt_rate')\n"
        f"pub = c.publish('lnbt.rate{-rate}', 'lnbt/counter')\n"
        f"sub = c.subscribe('lnbt.rate{-rate}', 'lnbt/counter', rate={rate})\n"
        "import time\n"
        "deadline = time.monotonic() + 10\n"
        "while not sub.has_publisher() and time.monotonic() < deadline: time.sleep(0.01)\n"
        "for value in (1, 2, 3):\n"
        "    pub.packet.counter = value; pub.write()\n"
        "    seen = []\n"
        "    while time.monotonic() < deadline:\n"
        "        p = sub.read(False)\n"
        "        if p is not None and p.counter == value: break\n"
        "        time.sleep(0.01)\n"
        "    again = sub.read(False)\n"
        "    print('read', value, 'again', None if again is None else again.counter)\n"
    )
    lines = {}
    for system in lnbt.systems():
        argv, extra = python_for(system, lnbt)
        program = support.run([*argv, "-c", script], lnbt.client_env(system, **extra))
        assert program.returncode == 0, program.describe()
        lines[system.label] = program.lines
    assert lines["ln_core"] == lines["ln29"] == [f"read {v} again {v}" for v in (1, 2, 3)], lines
