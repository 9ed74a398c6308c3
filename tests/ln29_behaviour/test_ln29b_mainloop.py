"""mainloop= integration: programs/lnbt_mainloop.py (a provider, calls of it,
the wrapped API and a MainloopMultiWaiter in one thread, on a GLib main
loop) run with LN 2.9's package against LN 2.9's manager and with ln_core's
against ln_core's; the transcripts must be equal.

GLib needs PyGObject, which only the LN 2.9 venv has: ln_core's package runs
there too (same CPython), with nothing of LN 2.9 on its path.
"""

from __future__ import annotations

import lnbt_support as support
from test_ln29b_python_fields import python_for

SCRIPT = support.PROGRAMS_DIR / "lnbt_mainloop.py"


def test_glib_mainloop_programs_match_ln29(lnbt):
    transcripts = {}
    reference_python = next(s for s in lnbt.systems() if s.is_reference).ln_manager.parent / "python"
    for system in lnbt.systems():
        _, extra = python_for(system, lnbt)
        if not system.is_reference:  # ours, not LN 2.9's package of that venv
            which = support.run(
                [reference_python, "-c", "import links_and_nodes; print(links_and_nodes.__file__)"],
                lnbt.client_env(system, **extra),
            )
            assert which.lines and which.lines[0].startswith(extra["PYTHONPATH"]), which.describe()
        program = support.run([reference_python, SCRIPT], lnbt.client_env(system, **extra), timeout=60)
        assert program.returncode == 0, f"{system}:\n{program.describe()}"
        transcripts[system.label] = program.lines
    assert transcripts["ln29"][-1] == "done", transcripts["ln29"]
    assert transcripts["ln_core"] == transcripts["ln29"]
