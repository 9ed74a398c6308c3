"""Events in the Python package (LN 2.9's client.connect_to_event): the
manager's ln.resource_event, events another program emits through the
connection's handler service, disconnecting, and bad input."""

import struct
import threading
import time

import links_and_nodes as ln
import ln_testing  # tests/support, on sys.path through conftest.py
import pytest


def handle_until(clnt, condition, timeout=20.0):
    deadline = time.time() + timeout
    while not condition():
        assert time.time() < deadline, "condition not met within %s s" % timeout
        clnt.wait_and_handle_service_group_requests(None, 0.05)


def test_resource_events_arrive_as_messages(clnt, manager, unique):
    seen = []
    conn = clnt.connect_to_event(
        "ln.resource_event",
        "ln/resource_event",
        lambda ev: seen.append((ev.event, ev.name, ev.md, ev.client, ev.connection)),
        event_pattern="*",
        name_pattern="*.%s" % unique,
        md_pattern="*",
        client_pattern="*",
    )
    assert conn.connect_signature.startswith("ln/resource_event: uint32_t 4 1,char* 1 1")
    assert conn.id == 1
    handle_until(clnt, lambda: any(e[0] == "initial_sync_done" for e in seen))
    other = ln.client("py_other_" + unique)
    other_name = other.name
    try:
        port = other.publish("topic.%s" % unique, "counter/count_message")
        handle_until(clnt, lambda: len(seen) >= 2)
        assert seen[1][:4] == ("topic_new_publisher", "topic.%s" % unique, "counter/count_message", other.name)
        assert seen[1][4] is conn
        assert isinstance(seen[1][1], str)
        conn.disconnect()
        other.unpublish(port)
    finally:
        other.close()
    # Once the manager has dropped the other client, its departure would be an event now.
    ln_testing.wait_for(
        lambda: all(c.name != other_name for c in clnt.list_clients()), 20, "the manager to drop " + other_name
    )
    clnt.wait_and_handle_service_group_requests(None, 0.2)
    assert [e[0] for e in seen] == ["initial_sync_done", "topic_new_publisher"], "nothing after disconnect"


def test_other_programs_emit_events_through_the_handler_service(clnt, manager, unique):
    got = []
    conn = clnt.connect_to_event(
        "my.event_%s" % unique,
        "ln/resource_event",
        got.append,
        event_pattern="",
        name_pattern="",
        md_pattern="",
        client_pattern="",
    )
    emitter = ln.client("py_emitter_" + unique)
    try:
        handler = emitter.get_service("my.event_%s.%s" % (unique, clnt.name), "ln/event/call")
        flat = b"".join(struct.pack("<I", len(s)) + s for s in (b"hello", b"n", b"", b"c"))
        stop = threading.Event()
        serving = threading.Thread(
            target=lambda: [clnt.wait_and_handle_service_group_requests(None, 0.05) for _ in iter(stop.is_set, True)]
        )
        serving.start()
        try:
            handler.call(data=flat, signature=conn.call_signature)
        finally:
            stop.set()
            serving.join()
    finally:
        emitter.close()
    assert len(got) == 1
    assert (got[0].event, got[0].name, got[0].md, got[0].client) == ("hello", "n", "", "c")
    conn.disconnect()


def test_bad_connects_are_clear_errors(clnt, unique):
    with pytest.raises(ln.LNError) as unknown:
        clnt.connect_to_event("ln.unknown", "ln/resource_event", print)
    assert unknown.value.code == ln.LNE_REQUEST_FAILED and "unknown event 'ln.unknown'" in str(unknown.value)
    with pytest.raises(AttributeError, match="no connect field 'bogus'"):
        clnt.connect_to_event("ln.resource_event", "ln/resource_event", print, bogus=1)
    with pytest.raises(ln.LNError, match="not an event definition"):
        clnt.connect_to_event("x.%s" % unique, "ln/event/call", print)
