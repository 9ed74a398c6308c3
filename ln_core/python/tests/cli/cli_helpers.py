"""Running `ln` against the test manager, and the live system it inspects:
publishers, a subscriber and service providers in threads of the test
process (each with its own client, as separate programs would have).

The `manager` fixture comes from tests/conftest.py (one manager per module).
"""

import json
import os
import subprocess
import sys
import threading
import time

import links_and_nodes as ln
import pytest

#: Upper bound of every `ln` run; commands that stream get --count/--duration too.
RUN_TIMEOUT = 30


def run_ln(manager, *args, timeout=RUN_TIMEOUT, env=None, **extra_env):
    """`ln ARGS...` as a user runs it (python -m links_and_nodes.cli); CompletedProcess."""
    environment = manager.env(**extra_env) if manager is not None else dict(os.environ, **extra_env)
    environment.pop("LN_CLI_DEBUG", None)
    if env is not None:
        environment = env
    return subprocess.run(
        [sys.executable, "-m", "links_and_nodes.cli", *args],
        env=environment,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def ok(result):
    """stdout of a run that must have succeeded."""
    assert result.returncode == 0, "exit %d\nstdout: %s\nstderr: %s" % (result.returncode, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    return result.stdout


def ok_json(result):
    return json.loads(ok(result))


def json_lines(result):
    return [json.loads(line) for line in ok(result).splitlines() if line.strip()]


def one_line_error(result, *words):
    """The error line of a failed run: exit != 0, one line on stderr that
    starts with 'ln: error:' (or argparse's 'ln ...: error:'), no traceback."""
    assert result.returncode != 0, "expected a failure, got exit 0: %s" % result.stdout
    assert "Traceback" not in result.stderr + result.stdout
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, "expected one error line, got: %r" % result.stderr
    assert lines[0].startswith("ln") and ": error: " in lines[0], lines[0]
    for word in words:
        assert word in lines[0], "%r not in %r" % (word, lines[0])
    return lines[0]


def table(text):
    """Rows of an aligned table (header first) split at runs of 2+ spaces."""
    import re

    return [re.split(r"\s{2,}", line.strip()) for line in text.strip().splitlines()]


def wait_until(condition, timeout=10.0, interval=0.05, what="condition"):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(interval)
    raise AssertionError("timed out waiting for %s" % what)


class Publisher:
    """A publisher thread writing `fill(packet, i)` at `rate` Hz until stopped."""

    def __init__(self, name, topic, md, rate, fill):
        self.client = ln.client(name)
        self.port = self.client.publish(topic, md)
        self.rate, self.fill = rate, fill
        self.written = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        period = 1.0 / self.rate
        next_time = time.monotonic()
        while not self._stop.is_set():
            self.written += 1
            self.fill(self.port.packet, self.written)
            self.port.write()
            next_time += period
            self._stop.wait(max(0.0, next_time - time.monotonic()))

    def stop(self):
        self._stop.set()
        self._thread.join(5)
        self.client.close()


class Providers:
    """Service providers of one client, served by a thread."""

    def __init__(self, name):
        self.client = ln.client(name)
        self._stop = threading.Event()
        self._thread = None

    def provide(self, service, interface, handler, group=None):
        svc = self.client.get_service_provider(service, interface)
        svc.set_handler(handler)
        svc.do_register(group)
        return svc

    @classmethod
    def serving(cls, name, *services):
        """A client `name` providing each (service, interface, handler), its thread started."""
        providers = cls(name)
        for service in services:
            providers.provide(*service)
        providers.start()
        return providers

    def start(self):
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            self.client.wait_and_handle_service_group_requests(None, 0.1)

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
        self.client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


@pytest.fixture
def no_manager_env(manager):
    """An environment whose LN_MANAGER points at a port where nothing listens."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return manager.env(LN_MANAGER="127.0.0.1:%d" % port)
