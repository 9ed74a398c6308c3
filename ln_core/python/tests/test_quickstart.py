"""LN's quickstart programs (tests/quickstart), unmodified, on ln_core and on
the real LN 2.9 (its venv's python and ln_manager): same output expected.

LN 2.9's manager runs through tests/support/ln_testing.py (--isolated-test, a
private HOME). Skipped when the LN 2.9 venv is missing.
"""

import os
import signal
import subprocess
import sys

import ln_testing  # tests/support, on sys.path through conftest.py
import pytest
from conftest import MSGDEFS, Manager

QUICKSTART = os.path.join(os.path.dirname(os.path.abspath(__file__)), "quickstart")


def start(env, *command):
    """A quickstart program started in QUICKSTART, its output piped."""
    return subprocess.Popen(
        list(command), cwd=QUICKSTART, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def run(env, *command):
    """A quickstart program run to its end (at most 60 s), its output captured."""
    return subprocess.run(list(command), cwd=QUICKSTART, env=env, capture_output=True, text=True, timeout=60)


def run_counter(python, env):
    sub = start(env, python, "counter_subscriber.py", "5")
    pub = run(env, python, "counter_publisher.py", "5")
    sub_out, sub_err = sub.communicate(timeout=60)
    assert pub.returncode == 0 and sub.returncode == 0, pub.stderr + sub_err
    return pub.stdout + sub_out


def run_area(python, env):
    provider = start(env, python, "-u", "area_provider_wrapped.py")
    try:
        first = provider.stdout.readline().strip()
        if first != "ready":
            provider.wait(10)
            error = provider.stderr.read()
            raise AssertionError("provider failed: %s" % error)
        # "ready": its services are registered (in its constructor), the client may call
        client = run(env, python, "area_client_wrapped.py")
    finally:
        provider.send_signal(signal.SIGINT)
        try:
            provider_out, _ = provider.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            provider.kill()
            provider_out, _ = provider.communicate()
    assert client.returncode == 0, client.stderr
    return client.stdout, provider_out


EXPECTED_COUNTER = """published 5 counts
count: 1 (sent just now)
count: 2 (sent just now)
count: 3 (sent just now)
count: 4 (sent just now)
count: 5 (sent just now)
"""


@pytest.fixture(scope="module")
def ln_core_env(tmp_path_factory):
    m = Manager(tmp_path_factory.mktemp("qs_core"))
    yield m.env()
    m.stop()


@pytest.fixture(scope="module")
def ln29_env(tmp_path_factory):
    try:
        m = ln_testing.Ln29(tmp_path_factory.mktemp("qs_ln29")).start([MSGDEFS])
    except ln_testing.Unavailable as error:
        pytest.skip(str(error))
    # the LN 2.9 venv's python and tools, its links_and_nodes package only
    yield m.env(PATH=str(m.venv / "bin") + os.pathsep + os.environ["PATH"], PYTHONPATH="")
    m.stop()


@pytest.fixture(scope="module")
def ln29_python(ln29_env):
    return os.path.join(ln29_env["PATH"].split(os.pathsep)[0], "python")


def test_counter_quickstart_on_ln_core(ln_core_env):
    assert run_counter(sys.executable, ln_core_env) == EXPECTED_COUNTER


def test_counter_quickstart_same_on_ln29(ln29_env, ln29_python):
    assert run_counter(ln29_python, ln29_env) == EXPECTED_COUNTER


def test_area_quickstart_same_on_both(ln_core_env, ln29_env, ln29_python):
    reference = run_area(ln29_python, ln29_env)
    assert "circle r=2.0: area 12.566, error code 0" in reference[0]
    assert run_area(sys.executable, ln_core_env) == reference
