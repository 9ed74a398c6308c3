"""Fixtures: an ln_core manager on a free port per test module, with the
test message definitions (tests/msgdefs) on its search path.

Environment (set by ctest, see python.cmake; otherwise searched):
  LN_CORE_MANAGER      the ln_manager binary of ln_core
  LN_CORE_GENERATE     ln_generate (for the C++ programs of test_mixed.py)
  LN_CORE_INCLUDE_DIR  ln_core/include
  LN_CORE_LIB          libln.so
links_and_nodes itself must be importable (PYTHONPATH=<build>/python).
"""

import contextlib
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import time
import uuid

import links_and_nodes as ln
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
MSGDEFS = os.path.join(HERE, "msgdefs")
LN_CORE = os.path.dirname(os.path.dirname(HERE))
BUILTIN_MSGDEFS = os.path.join(LN_CORE, "share", "message_definitions")

sys.path.insert(0, os.path.join(os.path.dirname(LN_CORE), "tests", "support"))
import ln_testing  # noqa: E402


def manager_binary():
    try:
        return ln_testing.ln_core_manager()
    except ln_testing.Unavailable as error:
        ln_testing.skip(str(error))


class Manager(ln_testing.LnCore):
    """A running ln_core manager in `tmp_path` (also its clients' HOME); `address` is HOST:PORT."""

    def __init__(self, tmp_path, md_dirs=(MSGDEFS,), extra_config=""):
        """`extra_config`: more .lnc text (processes, states, groups)."""
        spec = importlib.util.find_spec("links_and_nodes")
        package_dir = os.path.dirname(os.path.dirname(spec.origin)) if spec and spec.origin else None
        super().__init__(tmp_path, home=tmp_path, manager_exe=manager_binary(), package_dir=package_dir)
        self.start(md_dirs, extra_config=extra_config)


@contextlib.contextmanager
def running_manager(tmp_path, md_dirs=(MSGDEFS,)):
    """A Manager, with LN_MANAGER pointing at it, for the duration of the block."""
    m = Manager(tmp_path, md_dirs)
    saved = os.environ.get("LN_MANAGER")
    os.environ["LN_MANAGER"] = m.address
    try:
        yield m
    finally:
        if saved is None:
            os.environ.pop("LN_MANAGER", None)
        else:
            os.environ["LN_MANAGER"] = saved
        m.stop()


@pytest.fixture(scope="module")
def manager(tmp_path_factory):
    with running_manager(tmp_path_factory.mktemp("manager")) as m:
        yield m


@pytest.fixture(scope="module")
def builtins_manager(tmp_path_factory):
    """A manager that also searches the source tree's built-in definitions
    (ln/parameters/*, ...), not only the installed ones."""
    with running_manager(tmp_path_factory.mktemp("manager"), (MSGDEFS, BUILTIN_MSGDEFS)) as m:
        yield m


@pytest.fixture
def clnt(manager):
    import links_and_nodes as ln

    c = ln.client("pytest")
    yield c
    c.close()


@pytest.fixture
def unique():
    """A fresh name fragment for topics and services."""
    return uuid.uuid4().hex[:8]


def handshake(pub, sub, timeout=5.0):
    """Writes until the subscriber sees a packet (subscriptions attach
    asynchronously; LN delivers nothing written before)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        pub.write()
        if sub.read(0.05) is not None:
            while sub.read(False) is not None:
                pass
            return
    raise AssertionError("subscriber never received a packet")


def run_python(manager, script, *args, timeout=30, **env):
    """Runs a Python script in a client process; returns CompletedProcess."""
    return subprocess.run(
        [sys.executable, script, *args], env=manager.env(**env), capture_output=True, text=True, timeout=timeout
    )


class AreaProvider(ln.service_provider):
    """LN quickstart's area services through the wrapped API: PREFIX.compute_circle_area
    (error_code 1, "negative radius" for a radius below 0) and PREFIX.triangle, served
    by a method of another name (method=) that always raises "no triangles today"."""

    print_ready = False

    def __init__(self, clnt, prefix):
        ln.service_provider.__init__(self, clnt, prefix)
        self.wrap_service_provider("compute_circle_area", "area_service/circle_area")
        self.wrap_service_provider("triangle", "area_service/triangle_area", method=self.tri)

    def compute_circle_area(self, radius):
        if radius < 0:
            return {"area": math.nan, "error_code": 1, "error_message": "negative radius"}
        return {"area": math.pi * radius**2, "error_code": 0, "error_message": ""}

    def tri(self, base, height):
        raise ValueError("no triangles today")


class AreaCalls(ln.services_wrapper):
    """The caller's side of AreaProvider (triangle's height defaults to 2)."""

    def __init__(self, clnt, prefix):
        ln.services_wrapper.__init__(self, clnt, prefix)
        self.wrap_service("compute_circle_area", "area_service/circle_area")
        self.wrap_service("triangle", "area_service/triangle_area", default_arguments={"height": 2.0})


def which_compiler():
    return shutil.which("g++") or shutil.which("c++")


def build_cpp_programs(compiler, lib, include_dirs, names, out):
    """Compiles tests/cpp/<name>.cpp for each of `names` into `out`, linked to libln at `lib`;
    {name: executable}."""
    built = {}
    for name in names:
        exe = str(out / name)
        command = [compiler, "-std=c++17", "-O1"]
        for directory in include_dirs:
            command += ["-I", str(directory)]
        command += [os.path.join(HERE, "cpp", name + ".cpp"), "-o", exe, lib]
        command += ["-Wl,-rpath," + os.path.dirname(os.path.realpath(lib)), "-lpthread"]
        result = subprocess.run(command, capture_output=True, text=True)
        assert result.returncode == 0, "building %s failed:\n%s" % (name, result.stderr)
        built[name] = exe
    return built
