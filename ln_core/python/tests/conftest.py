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
import glob
import os
import shutil
import subprocess
import sys
import time
import uuid

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
MSGDEFS = os.path.join(HERE, "msgdefs")
LN_CORE = os.path.dirname(os.path.dirname(HERE))
BUILTIN_MSGDEFS = os.path.join(LN_CORE, "share", "message_definitions")


def _find(env, patterns):
    value = os.environ.get(env)
    if value:
        return value
    for pattern in patterns:
        hits = sorted(glob.glob(pattern), key=os.path.getmtime, reverse=True)
        if hits:
            return hits[0]
    return None


def manager_binary():
    found = _find("LN_CORE_MANAGER", ["/tmp/build-py/ln_core/ln_manager", os.path.join(LN_CORE, "..", "build*", "**", "ln_manager"),
                                      os.path.join(LN_CORE, "..", "install", "bin", "ln_manager")])
    if not found:
        pytest.skip("ln_core's ln_manager not found (set LN_CORE_MANAGER)")
    return found


class Manager:
    """A running ln_core manager; `address` is HOST:PORT."""

    def __init__(self, tmp_path, md_dirs=(MSGDEFS,), extra_config=""):
        """`extra_config`: more .lnc text (processes, states, groups)."""
        self.home = str(tmp_path)
        config = os.path.join(self.home, "test.lnc")
        with open(config, "w") as f:
            f.write("instance\nname: pytest_%s\nmanager: 127.0.0.1:0\n" % uuid.uuid4().hex[:8])
            for d in md_dirs:
                f.write("add_message_definition_dir: %s\n" % d)
            f.write(extra_config)
        env = dict(os.environ, HOME=self.home)
        self.log_path = os.path.join(self.home, "manager.log")
        self.log = open(self.log_path, "w+")
        self.process = subprocess.Popen([manager_binary(), "-c", config, "-p", "0", "--without-gui"],
                                        stdout=subprocess.PIPE, stderr=self.log, env=env, text=True)
        deadline = time.time() + 10
        self.address = None
        while time.time() < deadline:
            line = self.process.stdout.readline()
            if not line:
                break
            if "listening on" in line:
                self.address = line.strip().rsplit(" ", 1)[-1]
                break
        if self.address is None:
            self.stop()
            raise RuntimeError("ln_manager did not start: %s" % open(self.log_path).read())

    def env(self, **extra):
        """Environment for a client process of this manager."""
        env = dict(os.environ, LN_MANAGER=self.address, HOME=self.home)
        env.update(extra)
        return env

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()


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
    return subprocess.run([sys.executable, script, *args], env=manager.env(**env), capture_output=True,
                          text=True, timeout=timeout)


def which_compiler():
    return shutil.which("g++") or shutil.which("c++")


@pytest.fixture
def nyi():
    """Context manager: skips the test where libln reports a feature as not
    implemented yet (parts of the C API are still being filled in)."""
    import contextlib

    import links_and_nodes as ln

    @contextlib.contextmanager
    def guard():
        try:
            yield
        except ln.LNError as error:
            if error.code == ln.LNE_NOT_YET_IMPLEMENTED:
                pytest.skip("libln: %s" % error)
            raise
    return guard
