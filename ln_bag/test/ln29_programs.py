"""Programs run with LN 2.9's own Python package (its venv's interpreter) by
ln29_recordings.py: an LN 2.9 system to record, a logger, and LN 2.9's own
reading of its recording files (the reference the conversion is compared with).

    publish TOPIC N RATE     bagtest/pose: "ready", then on a line on stdin ("go": once the topic
                             has a subscriber, the recorder; "go now": at once) N packets
                             (counter = i), "published", and the topic stays until stdin closes
    provide SERVICE          bagtest/add (sum = a + b, text = "sum of " + text) until stdin closes
    call SERVICE N           N calls: a = i, b = 10, text = "call i"
    logger TOPIC PREFIX N RATE   publishes N packets on TOPIC (a publish child) while a logger logs them,
                             then manager_save PREFIX.pcap and PREFIX.pickle
    decode pcap|lnrdb PATH   JSON lines {kind, name, log_time, publish_time, data} as LN 2.9 reads the file
"""

import json
import sys
import time

import links_and_nodes as ln


def publish(topic, n, rate):
    client = ln.client("ln29_publisher")
    port = client.publish(topic, "bagtest/pose")
    print("ready", flush=True)
    if sys.stdin.readline().strip() == "go":  # the recorder subscribes (LN 2.9 delivers nothing written before)
        deadline = time.time() + 30
        while not port.has_subscriber() and time.time() < deadline:
            time.sleep(0.01)
    start = time.time()
    for i in range(int(n)):
        p = port.packet
        p.time = i * 0.01
        p.position.x, p.position.y, p.position.z = i, -i, 0.5
        p.orientation = [0, 0, 0, 1]
        p.counter = i
        p.frame = list(b"base".ljust(16, b"\0"))
        p.flags = [1, -1, i % 100]
        port.write()
        time.sleep(max(0.0, start + (i + 1) / float(rate) - time.time()))  # pacing at `rate`
    print("published", flush=True)
    sys.stdin.read()


def provide(service):
    client = ln.client("ln29_provider")
    provider = client.get_service_provider(service, "bagtest/add")

    def handler(request, req, resp):
        resp.sum = req.a + req.b
        resp.text = "sum of " + req.text
        request.respond()
        return 0

    provider.set_handler(handler)
    provider.do_register()
    print("providing", flush=True)
    import select

    while not select.select([sys.stdin], [], [], 0)[0]:
        client.wait_and_handle_service_group_requests(None, 0.05)


def call(service, n):
    client = ln.client("ln29_caller")
    svc = client.get_service(service, "bagtest/add")
    for i in range(int(n)):
        svc.req.a, svc.req.b, svc.req.text = i, 10, "call %d" % i
        svc.call()
        time.sleep(0.02)  # calls spread over a while, as a program makes them
    print("called", flush=True)


def logger(topic, prefix, n, rate):
    """Runs the publisher itself: LN 2.9's logger client only works reliably in
    this order (its client first, the topic published, then the logger)."""
    import subprocess

    client = ln.client("ln29_logger")
    publisher = subprocess.Popen(
        [sys.executable, __file__, "publish", topic, n, rate], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    print("publisher %d" % publisher.pid, flush=True)  # its /dev/shm segments are named after it
    assert publisher.stdout.readline().strip() == "ready"
    # LN 2.9's logger (read by its daemon, not a subscriber: has_subscriber() stays False) shows
    # nothing of when it sees the topic, has attached or has read the last packet: margins.
    time.sleep(1.0)
    log = client.get_logger("ln29_test_logger")
    log.add_topic(topic, 1000, 1)
    log.enable()
    time.sleep(1.0)
    publisher.stdin.write("go now\n")
    publisher.stdin.flush()
    assert publisher.stdout.readline().strip() == "published"
    time.sleep(0.5)
    log.disable()
    for fmt in ("pcap", "pickle"):
        log.manager_save("%s.%s" % (prefix, fmt), fmt)
    publisher.stdin.close()
    publisher.wait(10)
    print("saved", flush=True)


def _plain(value):
    if isinstance(value, bytes):
        return value.decode("latin-1")
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def decode(kind, path):
    if kind == "pcap":
        from links_and_nodes.lnrecorder.lnrecorder_log import lnrecorder_log

        log = lnrecorder_log(path)
        for p in log.iter_packets():
            d = log.decode_packet(p, with_meta=False)
            item = {
                "name": _plain(d["name"]),
                "log_time": p.header.sec + p.header.nsec / 1e9,
                "data": _plain(dict(d["data"])),
            }
            if d["type"] == "topic packet":
                item.update(kind="topic", publish_time=p.publisher_timestamp)
            else:
                item.update(kind=d["event_type"], request_id=p.request_id)
            print(json.dumps(item))
    else:
        import lnrdb

        db = lnrdb.Db(path)
        for name, table in sorted(db.tables.items()):
            if not name.startswith("topics/"):
                continue
            for row in table.mmap():
                data = {
                    field: _plain(row[field])
                    for field in row.dtype.names
                    if field not in ("timestamp", "publisher_timestamp")
                }
                data["position"] = dict(zip(("x", "y", "z"), data["position"]))
                print(
                    json.dumps(
                        {
                            "kind": "topic",
                            "name": table.meta["topic.name"],
                            "log_time": float(row.timestamp),
                            "publish_time": float(row.publisher_timestamp),
                            "data": data,
                        }
                    )
                )


if __name__ == "__main__":
    commands = {"publish": publish, "provide": provide, "call": call, "logger": logger, "decode": decode}
    commands[sys.argv[1]](*sys.argv[2:])
