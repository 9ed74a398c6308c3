"""Fixtures of the differential tests (ln_core's ln_generate/ln_md_info
against LN 2.9's ln_generate).

Environment:
  LN_CORE_BIN_DIR     directory holding ln_core's ln_generate and ln_md_info
  LN_CORE_BUILD_DIR   ln_core's cmake build directory (used when the above is unset)
                      (neither set: both tools are looked up on PATH, as after
                      `. launchless_scripts/env.sh`)
  LN_CORE_LN29_VENV   the LN 2.9 reference venv; default /tmp/ref/ln29 if that exists
  CI                  when set, a missing tool or reference FAILS the tests instead of
                      skipping them
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import ln_diff_support as support

REPORT = support.REPORT


@pytest.fixture(scope="session")
def reference() -> support.Reference:
    """The LN 2.9 installation (fails in CI / skips locally when absent)."""
    return support.require(support.find_reference(), "LN 2.9 reference")


@pytest.fixture(scope="session")
def our_tools() -> support.OurTools:
    """ln_core's ln_generate and ln_md_info."""
    return support.require(support.find_our_tools(), "ln_core tools")


@pytest.fixture(scope="session")
def c_compiler() -> str:
    return support.require(support.find_compiler("gcc") or support.find_compiler("cc"), "no C compiler (gcc)")


@pytest.fixture(scope="session")
def cxx_compiler() -> str:
    return support.require(support.find_compiler("g++") or support.find_compiler("c++"), "no C++ compiler (g++)")


@pytest.fixture(scope="session")
def session_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("ln_differential")


@pytest.fixture(scope="session")
def tool_env(session_dir) -> dict[str, str]:
    """Environment for both generators: HOME without ln_message_definitions
    or .ln_config, no LN_MESSAGE_DEFINITION_DIRS."""
    home = session_dir / "home"
    home.mkdir(exist_ok=True)
    return support.tool_environment(home)


@pytest.fixture
def work_dir(tmp_path) -> Path:
    """A fresh temporary directory per test."""
    return tmp_path


def pytest_terminal_summary(terminalreporter):
    if not REPORT:
        return
    terminalreporter.section("ln_generate differential")
    for key, value in REPORT.items():
        terminalreporter.write_line(f"{key}: {value}")
