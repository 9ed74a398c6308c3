"""Introspection (ln_core): client.list_topics(), list_clients(),
list_services() and get_manager_status(), with a publisher in another
process and topic rates measured by the publishers."""

import json
import os
import subprocess
import sys
import threading
import time

import links_and_nodes as ln
import pytest
from conftest import MSGDEFS

PUBLISHER_SCRIPT = """
import sys, time
import links_and_nodes as ln
c = ln.client("pytest_intro_pub_" + sys.argv[1])
port = c.publish(sys.argv[2], "pytest/point")
print("publishing", flush=True)
sys.stdin.readline()          # until the test says "stop"
"""


def wait_for(condition, timeout=20.0, pace=0.02):
    """Polls `condition` (at a pace that spares the manager) until it returns
    something true; returns that, or None after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        result = condition()
        if result:
            return result
        if time.monotonic() >= deadline:
            return None
        time.sleep(pace)


def topic_named(clnt, name):
    return next((t for t in clnt.list_topics() if t.name == name), None)


def test_results_are_named_tuples_with_the_contracted_fields():
    assert ln.topic_info._fields == (
        "name",
        "message_definition",
        "hash",
        "message_size",
        "publisher",
        "subscribers",
        "packets",
        "rate",
    )
    assert ln.client_info._fields == ("name", "id", "pid", "host", "host_id", "published", "subscribed", "services")
    assert ln.service_info._fields == ("name", "interface", "signature", "provider", "group")
    assert ln.manager_status._fields == (
        "version",
        "pid",
        "address",
        "uptime",
        "clients",
        "topics",
        "services",
        "message_definition_dirs",
    )


def test_lists_a_publisher_in_another_process(manager, clnt, unique, tmp_path):
    topic = "pytest.intro.%s" % unique
    script = tmp_path / "publisher.py"
    script.write_text(PUBLISHER_SCRIPT)
    proc = subprocess.Popen(
        [sys.executable, str(script), unique, topic],
        env=manager.env(),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "publishing"
        sub = clnt.subscribe(topic, "pytest/point")

        info = topic_named(clnt, topic)
        assert isinstance(info, ln.topic_info)
        assert info.message_definition == "pytest/point"
        assert info.message_size == 16
        assert len(info.hash) == 64
        assert info.publisher == "pytest_intro_pub_" + unique
        assert info.subscribers == 1
        assert info.packets == 0 and info.rate == 0.0

        clients = {c.name: c for c in clnt.list_clients()}
        publisher = clients["pytest_intro_pub_" + unique]
        me = clients[clnt.name]
        assert publisher.pid == proc.pid
        assert me.pid == os.getpid()
        assert publisher.published == [topic]
        assert topic in me.subscribed
        assert publisher.host_id == me.host_id and publisher.host == me.host
        assert isinstance(publisher.id, int) and publisher.id != me.id
        # What the CLI prints: plain JSON.
        json.loads(json.dumps([c._asdict() for c in clients.values()]))
        clnt.unsubscribe(sub)
    finally:
        proc.stdin.write("stop\n")
        proc.stdin.close()
        proc.wait(10)
    assert wait_for(lambda: topic_named(clnt, topic) is None), "the topic goes with its last client"


def test_lists_services(clnt, unique):
    name = "pytest.intro.svc.%s" % unique
    provider = ln.client("pytest_intro_provider")
    try:
        svc = provider.get_service_provider(name, "pytest/small_srv")
        svc.set_handler(lambda request, req, resp: 0)
        svc.do_register("intro_group")
        found = [s for s in clnt.list_services() if s.name == name]
        assert len(found) == 1
        info = found[0]
        assert isinstance(info, ln.service_info)
        assert info.interface.split("|")[0] == "pytest/small_srv"
        assert info.signature
        assert info.provider == provider.name
        assert info.group == "intro_group"
        assert name in {c.name: c for c in clnt.list_clients()}[provider.name].services
    finally:
        provider.close()
    assert not [s for s in clnt.list_services() if s.name == name]


def test_rate_while_writing_and_zero_after(clnt, unique):
    topic = "pytest.intro.rate.%s" % unique
    port = clnt.publish(topic, "pytest/point")
    written = 0
    stop = threading.Event()

    def writer():
        nonlocal written
        while not stop.is_set():
            port.write()
            written += 1
            time.sleep(0.01)  # a writer at up to 100 Hz

    thread = threading.Thread(target=writer)
    thread.start()
    try:
        # (a loaded machine may run the writer at well below 100 Hz)
        busy = wait_for(lambda: (lambda t: t if t and 10 < t.rate < 150 else None)(topic_named(clnt, topic)))
        assert busy, "rate of a writer at up to 100 Hz: %r" % (topic_named(clnt, topic),)
        assert busy.packets > 0
    finally:
        stop.set()
        thread.join()
    idle = wait_for(
        lambda: (lambda t: t if t and t.rate == 0 and t.packets == written else None)(topic_named(clnt, topic))
    )
    assert idle, "after writing %d packets: %r" % (written, topic_named(clnt, topic))
    assert idle.publisher == clnt.name
    clnt.unpublish(port)


def test_manager_status(manager, clnt):
    status = clnt.get_manager_status()
    assert isinstance(status, ln.manager_status)
    assert status.version.startswith("ln_core")
    assert status.pid == manager.process.pid
    assert status.address == manager.address
    assert 0 < status.uptime < 3600
    assert status.clients >= 1
    assert status.topics >= 0 and status.services >= 0
    assert status.message_definition_dirs[0] == MSGDEFS
    assert json.loads(json.dumps(status._asdict()))["address"] == manager.address


def test_a_closed_client_raises(manager):
    c = ln.client("pytest_intro_closed")
    c.close()
    with pytest.raises(ln.LNError) as error:
        c.list_topics()
    assert error.value.code == ln.LNE_CLIENT_NOT_INITIALIZED
