"""Fixtures of the LN 2.9 behaviour tests: the same LN 2.9-style C++
programs (programs/), compiled against LN 2.9 and against ln_core, each run
against its own system's manager; the tests compare what they observe.

Environment:
  LN_CORE_LN29_VENV   the LN 2.9 reference venv (default ~/.cache/ln_core/venv-ln29)
  LN_CORE_BUILD_DIR   ln_core's cmake build directory (ln_manager, ln_generate,
                      libln.so); unset: an installed ln_core found on PATH, as
                      after `. launchless_scripts/env.sh`
  CI                  when set, a missing system FAILS the tests instead of
                      skipping them

Run:  . launchless_scripts/env.sh && python -m pytest tests/ln29_behaviour -q
      (or LN_CORE_BUILD_DIR=/path/to/build python -m pytest tests/ln29_behaviour -q)
"""

from __future__ import annotations

import atexit
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import lnbt_support as support


@pytest.fixture(scope="session")
def lnbt(tmp_path_factory) -> support.Session:
    """Both systems built, each with its manager running (stopped at the end)."""
    reference = support.require(support.find_reference(), "LN 2.9 reference")
    ours = support.require(support.find_ours(), "ln_core")
    work = tmp_path_factory.mktemp("ln29_behaviour")
    (work / "home").mkdir()
    (work / "tmp").mkdir()
    env = support.base_environment(work / "home", work / "tmp")

    import concurrent.futures

    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        built = list(pool.map(lambda s: support.build(s, work / "build" / s.label, env), (reference, ours)))
    for result in built:
        if isinstance(result, support.MissingPrerequisite):
            pytest.fail(str(result), pytrace=False)  # both systems exist, so this is a real failure

    managers = {}

    def cleanup():
        for manager in managers.values():
            support.stop_manager(manager)
        managers.clear()
        support.sweep_dev_shm()

    atexit.register(cleanup)
    for system in (reference, ours):
        manager = support.start_manager(system, work / "manager" / system.label, env)
        if isinstance(manager, support.MissingPrerequisite):
            cleanup()
            pytest.fail(str(manager), pytrace=False)
        managers[system.label] = manager
    session = support.Session(work, env, managers)
    yield session
    cleanup()


def pytest_terminal_summary(terminalreporter):
    if support.DIFFERENCES:
        terminalreporter.section("LN 2.9 vs ln_core: documented differences observed")
        for line in sorted(set(support.DIFFERENCES)):
            terminalreporter.write_line(line)
