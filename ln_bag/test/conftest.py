"""Fixtures of the ln_bag tests.

The LN manager comes from ln_core's Python test fixtures (ln_core/python/tests/
conftest.py: Manager), the `ln` runner and publisher threads from its CLI test
helpers (cli_helpers.py); this file only points them at ln_bag's definitions
(msgdefs/) and makes ln_bag importable in the `ln` processes the tests start.

Environment (ctest sets it, see CMakeLists.txt; after `. launchless_scripts/env.sh`
the installed ln_bag is used):
  LN_BAG_PYTHONPATH   the build tree's python/ directory (holds ln_bag)
"""

import importlib.util
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
MSGDEFS = os.path.join(HERE, "msgdefs")
LN_CORE_TESTS = os.path.join(HERE, "..", "..", "ln_core", "python", "tests")

if os.environ.get("LN_BAG_PYTHONPATH"):
    sys.path.insert(0, os.environ["LN_BAG_PYTHONPATH"])
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (os.environ["LN_BAG_PYTHONPATH"], os.environ.get("PYTHONPATH")) if p
    )
sys.path.insert(0, os.path.join(LN_CORE_TESTS, "cli"))
sys.path.insert(0, HERE)

_spec = importlib.util.spec_from_file_location("ln_core_test_fixtures", os.path.join(LN_CORE_TESTS, "conftest.py"))
ln_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ln_fixtures)


@pytest.fixture(scope="module")
def manager(tmp_path_factory):
    """An ln_core manager with msgdefs/ on its search path; LN_MANAGER points at it."""
    with ln_fixtures.running_manager(tmp_path_factory.mktemp("manager"), md_dirs=(MSGDEFS,)) as m:
        yield m


@pytest.fixture
def unique():
    import uuid

    return "u" + uuid.uuid4().hex[:8]  # a ROS name token must not start with a digit
