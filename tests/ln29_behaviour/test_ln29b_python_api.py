"""The Python API around packets: programs/lnbt_python_api.py (client names
and arguments, return values and their types, what failing calls raise and
the LNE_ name in their text) run with LN 2.9's package against LN 2.9's
manager and with ln_core's against ln_core's; the probes must agree except
for the documented differences below."""

from __future__ import annotations

import lnbt_support as support
from test_ln29b_python_fields import python_for

SCRIPT = support.PROGRAMS_DIR / "lnbt_python_api.py"

#: probe -> (LN 2.9's result, ln_core's result, why)
DOCUMENTED = {
    "unknown request field": (
        "raises Exception LNE_USER_DEFINED_ERROR",
        "raises AttributeError -",
        "LN 2.9 ignores a keyword that names no request field (here the call ran with the previous "
        "request's fail=5); ln_core raises AttributeError naming the fields",
    ),
    "unknown service": (
        "raises Exception LNE_REQUEST_FAILED",
        "raises Exception LNE_NO_PROVIDER_FOUND",
        "calling a service nobody provides (README: LNE_NO_PROVIDER_FOUND)",
    ),
    "unknown service without interface": (
        "raises Exception LNE_REQUEST_FAILED",
        "raises Exception LNE_NO_PROVIDER_FOUND",
        "calling a service nobody provides (README: LNE_NO_PROVIDER_FOUND)",
    ),
}


def probes(lnbt, system) -> dict[str, str]:
    argv, extra = python_for(system, lnbt)
    program = support.run([*argv, SCRIPT], lnbt.client_env(system, **extra), timeout=60)
    assert program.returncode == 0 and program.lines[-1:] == ["done"], f"{system}:\n{program.describe()}"
    return dict(line[len("probe ") :].split(": ", 1) for line in program.lines if line.startswith("probe "))


def test_python_api_matches_ln29(lnbt):
    results = {system.label: probes(lnbt, system) for system in lnbt.systems()}
    ln, ours = results["ln29"], results["ln_core"]
    assert len(ln) >= 25 and set(ours) == set(ln), (sorted(ln), sorted(ours))
    problems = []
    for label, expected in ln.items():
        if label in DOCUMENTED and (expected, ours[label]) == DOCUMENTED[label][:2]:
            support.DIFFERENCES.append(f"python api {label}: {DOCUMENTED[label][2]}")
        elif ours[label] != expected:
            problems.append(f"  {label}\n    LN 2.9:  {expected}\n    ln_core: {ours[label]}")
    assert not problems, "probes differ:\n" + "\n".join(problems)
