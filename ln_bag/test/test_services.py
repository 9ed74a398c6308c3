"""`ln record --services`: service calls (request and response) on channels of their own."""

import json
import struct
import time
import types

import links_and_nodes as ln
from bag_readers import mcap_messages
from cli_helpers import Providers, ok
from test_record import finish, start_ln


def _flat_text(text):
    data = text.encode()
    return struct.pack("<I", len(data)) + data


def request_payload(request_id, a, b, text, client_id=7):
    """A request as LN's service logging carries it: total length, call header, the request's LN flat bytes."""
    body = struct.pack("<HII", 32, client_id, request_id) + struct.pack("<ii", a, b) + _flat_text(text)
    return struct.pack("<I", 4 + len(body)) + body


def response_payload(total, text, status=0):
    body = struct.pack("<i", status) + struct.pack("<i", total) + _flat_text(text)
    return struct.pack("<I", 4 + len(body)) + body


def test_service_calls_go_to_request_and_response_channels(manager, unique, tmp_path):
    """What --services does with each call the manager's service logging reports (independent of how
    the report arrives): the calls of bagtest/add as LN sends them, decoded by mcap-ros2-support."""
    from ln_bag.record import Definitions, ServiceCallWriter

    from ln_bag import McapWriter, Recorder

    path = str(tmp_path / "calls.mcap")
    writer = McapWriter(path)
    with ln.client("bag_service_test") as clnt:
        recorder = Recorder(writer, manager.address)
        session = types.SimpleNamespace(definitions=Definitions(clnt), recorder=recorder)
        calls = ServiceCallWriter(session)
        recorder.start()
        service = "bag.%s.add" % unique
        for i in range(3):
            calls.record(
                service,
                "bagtest/add",
                "caller",
                0,
                2,
                100 + i,
                1_600_000_000.0 + i,
                request_payload(100 + i, i, 10, "call %d" % i),
            )
            calls.record(
                service,
                "bagtest/add",
                "provider",
                1,
                0,
                100 + i,
                1_600_000_000.5 + i,
                response_payload(i + 10, "sum of call %d" % i),
            )
        recorder.stop()
    writer.close()
    by_topic = {}
    for m in mcap_messages(path):
        by_topic.setdefault(m.topic, []).append(m)
    requests, responses = by_topic["/bag/%s/add/_request" % unique], by_topic["/bag/%s/add/_response" % unique]
    assert [(m.decoded.a, m.decoded.b, m.decoded.text) for m in requests] == [(i, 10, "call %d" % i) for i in range(3)]
    assert [(m.decoded.sum, m.decoded.text) for m in responses] == [(i + 10, "sum of call %d" % i) for i in range(3)]
    assert [m.sequence for m in requests] == [100, 101, 102] == [m.sequence for m in responses]
    assert requests[1].publish_time == 1_600_000_001_000_000_000
    assert {m.schema for m in requests} == {"bagtest_ln_msgs/srv/Add_Request"}
    assert requests[0].metadata["ln.part"] == "request" and responses[0].metadata["ln.part"] == "response"
    assert responses[0].metadata["ln.definition"] == "bagtest/add" and responses[0].metadata["ln.topic"] == service
    assert calls.counts == {service: 6}


def test_ln_record_services_records_every_call(manager, unique, tmp_path):
    service = "bag.%s.svc" % unique
    providers = Providers("bag_add_provider")

    def handler(request, req, resp):
        resp.sum = req.a + req.b
        resp.text = "sum of " + req.text
        request.respond()
        return 0

    providers.provide(service, "bagtest/add", handler)
    providers.start()
    path = str(tmp_path / "services.mcap")
    calls = 30
    try:
        record = start_ln(manager, "record", "--all", "--services", "-o", path, "--duration", "5", "--json")
        with ln.client("bag_add_caller") as clnt:
            svc = clnt.get_service(service, "bagtest/add")
            for i in range(calls):  # over 3 s: the calls after ln record's logging reached both sides are recorded
                svc.req.a, svc.req.b, svc.req.text = i, 10, "call %d" % i
                svc.call()
                time.sleep(0.1)
        summary = json.loads(ok(finish(record)))
    finally:
        providers.stop()
    topics = {}
    for m in mcap_messages(path):
        topics.setdefault(m.topic, []).append(m.decoded)
    prefix = "/" + service.replace(".", "/")
    requests = [(r.a, r.text) for r in topics[prefix + "/_request"]]
    first = requests[0][0]
    assert calls - first >= 10 and requests == [(i, "call %d" % i) for i in range(first, calls)]
    responses = [r.sum for r in topics[prefix + "/_response"]]
    assert responses[-1] == calls - 1 + 10 and responses == list(range(responses[0], calls + 10))
    assert summary["services"] == {service: len(requests) + len(responses)}
