"""`ln process|state|group` and the client calls behind them
(client.list_processes(), control_process(), get_process_output(),
needs_provider()) against a manager that runs a config's processes."""

import os
import socket
import subprocess
import sys
import time

import links_and_nodes as ln
import pytest
from cli_helpers import ok, ok_json, one_line_error, run_ln
from conftest import HERE, Manager

QUICKSTART = os.path.join(HERE, "quickstart")

CONFIG = """
process server
command: /bin/sh -c 'echo serving; exec sleep 1000'
ready_regex: ^serving
process client
command: /bin/sh -c 'i=0; while :; do i=$((i+1)); echo line $i; sleep 0.05; done'
depends_on: server
process broken
command: /no/such/program
process area_provider
command: {python} -u {quickstart}/area_provider_wrapped.py
pass_environment: PYTHONPATH, LD_LIBRARY_PATH, PATH, HOME
provides: area_service.compute_circle_area
process broken_provider
command: /bin/sh -c 'exit 7'
provides: broken.svc
process job
command: /bin/sh -c 'echo working; sleep 0.2; echo done'
ready_regex: ^never
flags: no_error_on_successful_stop
state marker
check: test -f {home}/marker
up: touch {home}/marker
down: rm -f {home}/marker
min_check_interval: 0
state stuck
check: false
up: true
flags: need_check_after_up
group pair
members: server, client
"""


@pytest.fixture(scope="module")
def manager(tmp_path_factory):
    home = tmp_path_factory.mktemp("processes")
    m = Manager(home, extra_config=CONFIG.format(python=sys.executable, quickstart=QUICKSTART, home=home))
    yield m
    m.stop()


def test_list_start_info_output_stop(manager):
    rows = ok_json(run_ln(manager, "process", "list", "--json"))
    assert [r["name"] for r in rows] == ["server", "client", "broken", "area_provider", "broken_provider", "job"]
    assert {r["state"] for r in rows} == {"stopped"}

    out = ok(run_ln(manager, "process", "start", "client", "--timeout", "20"))
    assert "client: started (pid" in out
    by_name = {r["name"]: r for r in ok_json(run_ln(manager, "process", "list", "--json"))}
    assert by_name["server"]["state"] == "ready", "started first, as client depends on it"
    assert by_name["client"]["pid"] > 0 and by_name["client"]["depends_on"] == ["server"]

    info = ok_json(run_ln(manager, "process", "info", "server", "--json"))
    assert info["state"] == "ready" and "serving" in info["output"]
    assert "serving" in ok(run_ln(manager, "process", "info", "server"))

    # -f follows: lines printed after the command started arrive too
    followed = ok(run_ln(manager, "process", "output", "client", "-n", "1", "-f", "--duration", "0.5"))
    numbers = [int(line.split()[1]) for line in followed.splitlines() if line.startswith("line ")]
    assert len(numbers) >= 3 and numbers == sorted(numbers) and len(set(numbers)) == len(numbers), followed
    last = ok_json(run_ln(manager, "process", "output", "client", "--json"))
    assert last["last"] >= numbers[-1] and last["lines"][-1].startswith("line ")

    out = ok(run_ln(manager, "process", "restart", "client", "--timeout", "20"))
    assert "client: started" in out
    assert ok_json(run_ln(manager, "process", "info", "client", "--json"))["pid"] != by_name["client"]["pid"]

    out = ok(run_ln(manager, "process", "stop", "client", "server", "--timeout", "20"))
    assert "client: stopped (killed by SIGTERM)" in out and "server: stopped" in out


def test_failures_are_one_line_with_the_reason(manager):
    result = run_ln(manager, "process", "start", "broken", "--timeout", "10")
    assert result.returncode == 1
    assert "broken: cannot start: command not found: '/no/such/program' does not exist" in result.stdout
    assert "did not start" in result.stderr
    one_line_error(run_ln(manager, "process", "start", "nobody"), "the manager has no process 'nobody'", "it has:")
    one_line_error(run_ln(manager, "process", "info", "nobody"), "no process, state or group 'nobody'")
    one_line_error(run_ln(manager, "group", "start", "server"), "'server' is a process, not a group")


def test_a_job_that_ends_well_is_done(manager):
    """A one-shot job (ends with status 0, no_error_on_successful_stop) is
    done when it ended, also when it never printed its ready line: `start`
    says so at once instead of waiting for the timeout."""
    began = time.monotonic()
    out = ok(run_ln(manager, "process", "start", "job", "--timeout", "20"))
    assert "job: ended (exit status 0)" in out
    assert time.monotonic() - began < 15


def test_completion_knows_the_names(manager):
    def complete(line):
        return ok(run_ln(manager, "__complete", line)).split()

    assert complete("ln process ") == ["info", "list", "output", "restart", "start", "stop"]
    assert complete("ln process start b") == ["broken", "broken_provider"]
    assert complete("ln process output m") == ["marker"], "states have output too"
    assert complete("ln state up ") == ["marker", "stuck"]
    assert complete("ln group stop ") == ["pair"]


def test_states_up_down_check(manager):
    assert ok(run_ln(manager, "state", "down", "marker")).strip() == "marker: DOWN"
    assert ok(run_ln(manager, "state", "check", "marker")).strip() == "marker: DOWN"
    assert ok(run_ln(manager, "state", "up", "marker")).strip() == "marker: UP"
    assert os.path.exists(os.path.join(manager.home, "marker"))
    rows = ok_json(run_ln(manager, "state", "list", "--json"))
    assert [(r["name"], r["state"]) for r in rows] == [("marker", "UP"), ("stuck", "unknown")]
    one_line_error(run_ln(manager, "state", "up", "stuck"), "stuck did not come up")


def test_groups_start_and_stop_their_members(manager):
    assert "pair   0/2 running  client, server" in ok(run_ln(manager, "group", "list"))
    out = ok(run_ln(manager, "group", "start", "pair", "--timeout", "20"))
    assert "server: ready" in out and "client: started" in out
    assert ok_json(run_ln(manager, "group", "list", "--json"))[0]["state"] == "2/2 running"
    out = ok(run_ln(manager, "group", "stop", "pair", "--timeout", "20"))
    assert "server: stopped" in out and "client: stopped" in out


def test_the_python_api(manager):
    clnt = ln.client("pytest_processes", manager.address)
    try:
        names = [p.name for p in clnt.list_processes()]
        assert names[:2] == ["server", "client"] and "pair" in names and "marker" in names
        clnt.control_process("server", "start")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            server = {p.name: p for p in clnt.list_processes()}["server"]
            if server.ready:
                break
            time.sleep(0.02)
        assert server.state == "ready" and server.pid > 0
        output = clnt.get_process_output("server")
        assert "serving" in output.lines and output.last >= 2 and output.dropped == 0
        assert clnt.get_process_output("server", output.last).lines == []
        with pytest.raises(ln.LNError) as error:
            clnt.control_process("server", "fly")
        assert error.value.code == ln.LNE_INVALID_PARAMETER
        clnt.control_process("server", "stop")
    finally:
        clnt.close()


def test_needs_provider_starts_the_configured_process(manager):
    clnt = ln.client("pytest_needs", manager.address)
    try:
        clnt.needs_provider("area_service.compute_circle_area", 20)
        provider = {p.name: p for p in clnt.list_processes()}["area_provider"]
        assert provider.pid > 0, provider
        assert any(s.name == "area_service.compute_circle_area" for s in clnt.list_services())
        with pytest.raises(ln.LNError) as error:
            clnt.needs_provider("broken.svc", 10)
        assert error.value.code == ln.LNE_START_PROVIDER_FAILED
        assert "exit status 7" in str(error.value)
        with pytest.raises(ln.LNError) as error:
            clnt.needs_provider("nobody.svc", 1)
        assert error.value.code == ln.LNE_NO_PROVIDER_FOUND
        clnt.control_process("area_provider", "stop")
    finally:
        clnt.close()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_clients_wait_for_a_manager_that_starts_later():
    from conftest import manager_binary

    port = _free_port()
    script = (
        "import sys, time, links_and_nodes as ln; print('trying', flush=True); t = time.monotonic(); "
        "c = ln.client('early'); print('connected after %.1f s' % (time.monotonic() - t)); c.close()"
    )
    env = dict(os.environ, LN_MANAGER="127.0.0.1:%d" % port)
    env.pop("LN_MANAGER_CONNECT_TIMEOUT", None)
    refused = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=30)
    assert refused.returncode != 0 and "Connection refused" in refused.stderr, "LN 2.9's default: fail at once"
    bad = subprocess.run(
        [sys.executable, "-c", script],
        env=dict(env, LN_MANAGER_CONNECT_TIMEOUT="soon"),
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert bad.returncode != 0 and "LN_MANAGER_CONNECT_TIMEOUT='soon' is not a number of seconds" in bad.stderr

    early = subprocess.Popen(
        [sys.executable, "-c", script],
        env=dict(env, LN_MANAGER_CONNECT_TIMEOUT="20"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    manager = None
    try:
        assert early.stdout.readline() == "trying\n"  # it connects now, before the manager listens
        manager = subprocess.Popen(
            [manager_binary(), "--listen", "127.0.0.1:%d" % port], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        out, err = early.communicate(timeout=30)
    finally:
        if early.poll() is None:
            early.kill()
            early.wait()
        if manager is not None:
            manager.terminate()
            manager.wait(10)
    assert early.returncode == 0, err
    assert out.startswith("connected after"), out
