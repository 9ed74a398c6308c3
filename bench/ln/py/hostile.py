"""A client that misbehaves, for the isolation row (bench/cases/ln_isolation.py). It speaks
ln_core's wire protocol by hand (ln_core/src/protocol/wire.hpp, services/call_frames.hpp) and
needs nothing but the standard library.

    hostile.py MODE --manager HOST:PORT --service NAME [--seconds S] [--connections N]

MODE:
  flood  as fast as it can: pipelined pings and list_topics to the manager, and pipelined calls
         of SERVICE (answers read, so nothing but the volume is wrong)
  stall  calls SERVICE pipelined and asks the manager for definition texts, and reads nothing
  idle   holds N (default 4000) idle TCP connections to the manager, opening new ones for those
         the manager closes, and 64 idle connections to SERVICE's provider
  busy   no LN traffic at all: keeps a CPU busy, to show what sharing the CPUs alone costs

Prints {"attacking": true, ...} once the attack runs (for the measured clients to start), then
{"ok": true, ...} with what it did when it stops (after S seconds, default 60, or SIGTERM).
Every loop is bounded by the deadline.
"""

import argparse
import json
import os
import resource
import select
import signal
import socket
import struct
import sys
import time

REQUEST, RESPONSE = 1, 2


def encode(kind, ident, fields):
    body = bytearray(struct.pack("<BIH", kind, ident, len(fields)))
    for key, value in fields.items():
        body += struct.pack("<B", len(key)) + key.encode()
        if isinstance(value, bool):
            body += struct.pack("<BB", 3, int(value))
        elif isinstance(value, int):
            body += struct.pack("<Bq", 1, value)
        else:
            data = value.encode()
            body += struct.pack("<BI", 4, len(data)) + data
    return struct.pack("<I", len(body)) + bytes(body)


def request(ident, method, **fields):
    return encode(REQUEST, ident, {"method": method, **fields})


def decode(payload):
    kind, ident, count = struct.unpack_from("<BIH", payload)
    pos, fields = 7, {}
    for _ in range(count):
        (size,) = struct.unpack_from("<B", payload, pos)
        key = payload[pos + 1 : pos + 1 + size].decode()
        pos += 1 + size
        (kind_of_value,) = struct.unpack_from("<B", payload, pos)
        pos += 1
        if kind_of_value in (1, 2):
            fields[key] = struct.unpack_from("<q" if kind_of_value == 1 else "<d", payload, pos)[0]
            pos += 8
        elif kind_of_value == 3:
            fields[key] = payload[pos] == 1
            pos += 1
        elif kind_of_value == 4:
            (n,) = struct.unpack_from("<I", payload, pos)
            fields[key] = payload[pos + 4 : pos + 4 + n].decode(errors="replace")
            pos += 4 + n
        else:
            (n,) = struct.unpack_from("<I", payload, pos)
            pos += 4
            items = []
            for _ in range(n):
                (m,) = struct.unpack_from("<I", payload, pos)
                items.append(payload[pos + 4 : pos + 4 + m].decode(errors="replace"))
                pos += 4 + m
            fields[key] = items
    return kind, ident, fields


def read_message(sock, deadline):
    """The next message from a blocking socket, or None at the deadline / EOF."""
    buffer = b""
    while True:
        if len(buffer) >= 4:
            (size,) = struct.unpack_from("<I", buffer)
            if len(buffer) >= 4 + size:
                return decode(buffer[4 : 4 + size])
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([sock], [], [], left)[0]:
            return None
        chunk = sock.recv(65536)
        if not chunk:
            return None
        buffer += chunk


def call(sock, message, deadline):
    sock.sendall(message)
    return read_message(sock, deadline)


def connect_manager(address):
    host, port = address.rsplit(":", 1)
    sock = socket.create_connection((host or "127.0.0.1", int(port)), timeout=10)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def register(address, deadline):
    sock = connect_manager(address)
    answer = call(
        sock,
        request(
            1,
            "hello",
            program_name="hostile",
            pid=os.getpid(),
            host_name="hostile",
            host_id="hostile-host",
            uid=os.getuid(),
        ),
        deadline,
    )
    if answer is None or "error_code" in answer[2]:
        raise SystemExit(json.dumps({"ok": False, "error": "hello refused: %r" % (answer,)}))
    return sock


def open_service(manager, service, deadline):
    """A connection to the provider of `service`, after the call handshake; its local id."""
    while True:
        answer = call(manager, request(2, "lookup_service", name=service, interface="", signature=""), deadline)
        if answer is not None and "peer_socket" in answer[2]:
            break
        if time.monotonic() > deadline:
            raise SystemExit(json.dumps({"ok": False, "error": "service %s did not appear" % service}))
        time.sleep(0.05)  # polling the manager until the provider registered
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.connect("\0" + answer[2]["peer_socket"])
    ok = call(sock, request(1, "call", service_id=answer[2]["service_id"]), deadline)
    if ok is None or "error_code" in ok[2]:
        raise SystemExit(json.dumps({"ok": False, "error": "call handshake refused: %r" % (ok,)}))
    return sock, ok[2]["service_id"]


def service_request(local_id, request_id):
    body = struct.pack("<Id", request_id & 0xFFFF, 1.5)  # lnbench/small_srv: seq, x
    return struct.pack("<IBBHIII", 16 + len(body), 0x10, 1, 0, local_id, request_id, 0) + body


def attack_targets(args, deadline):
    """A registered manager connection and one to SERVICE's provider (non-blocking), announced."""
    manager = register(args.manager, deadline)
    svc, local_id = open_service(manager, args.service, deadline)
    for sock in (manager, svc):
        sock.setblocking(False)
    print(json.dumps({"attacking": True}), flush=True)
    return manager, svc, local_id


def flood(args, deadline, report):
    manager, svc, local_id = attack_targets(args, deadline)
    batch_manager = b"".join(request(10 + i, "ping" if i % 2 else "list_topics") for i in range(32))
    batch_service = b"".join(service_request(local_id, i) for i in range(32))
    pending = {manager: b"", svc: b""}
    while time.monotonic() < deadline and not report["stop"]:
        for sock, batch in ((manager, batch_manager), (svc, batch_service)):
            if not pending[sock]:
                pending[sock] = batch
                report["requests"] += 32
        readable, writable, _ = select.select([manager, svc], [s for s in pending if pending[s]], [], 0.05)
        for sock in writable:
            try:
                sent = sock.send(pending[sock])
                pending[sock] = pending[sock][sent:]
            except BlockingIOError:
                pass
        for sock in readable:
            try:
                data = sock.recv(1 << 20)
            except BlockingIOError:
                continue
            if not data:
                report["closed"] += 1
                return
            report["bytes_read"] += len(data)


def stall(args, deadline, report):
    manager, svc, local_id = attack_targets(args, deadline)
    big_answers = b"".join(request(100 + i, "list_topics") for i in range(64))
    calls = b"".join(service_request(local_id, i) for i in range(256))
    live = {manager: big_answers, svc: calls}
    while time.monotonic() < deadline and not report["stop"] and live:
        _, writable, _ = select.select([], list(live), [], 0.05)
        for sock in writable:
            try:
                sock.send(live[sock])
                report["requests"] += 1
            except BlockingIOError:
                pass
            except OSError:
                report["closed"] += 1  # we lost our own connection: as it should be
                del live[sock]
        if not writable:
            time.sleep(0.01)  # both sides full: the peers stopped taking our requests


def idle(args, deadline, report):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, args.connections + 512), hard))
    manager = register(args.manager, deadline)
    svc, _ = open_service(manager, args.service, deadline)
    lookup = call(manager, request(3, "lookup_service", name=args.service, interface="", signature=""), deadline)
    peers = []
    for _ in range(64):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.connect("\0" + lookup[2]["peer_socket"])
        peers.append(s)
    host, port = args.manager.rsplit(":", 1)
    held = []

    def top_up():
        while len(held) < args.connections and time.monotonic() < deadline:
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.setblocking(False)
            try:
                s.connect_ex((host or "127.0.0.1", int(port)))
            except OSError:
                s.close()
                return
            held.append(s)
            report["opened"] += 1

    top_up()
    print(json.dumps({"attacking": True, "held": len(held)}), flush=True)
    while time.monotonic() < deadline and not report["stop"]:
        readable, _, _ = select.select(held[:1000], [], [], 0.1)
        for s in readable:  # closed by the manager
            held.remove(s)
            s.close()
            report["closed"] += 1
        top_up()


def busy(args, deadline, report):
    print(json.dumps({"attacking": True}), flush=True)
    while time.monotonic() < deadline and not report["stop"]:
        for _ in range(100_000):
            pass
        report["requests"] += 1


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=("flood", "stall", "idle", "busy"))
    parser.add_argument("--manager", required=True)
    parser.add_argument("--service", required=True)
    parser.add_argument("--seconds", type=float, default=60)
    parser.add_argument("--connections", type=int, default=4000)
    args = parser.parse_args()
    deadline = time.monotonic() + args.seconds
    report = {"stop": False, "requests": 0, "bytes_read": 0, "closed": 0, "opened": 0}
    signal.signal(signal.SIGTERM, lambda *_: report.update(stop=True))
    {"flood": flood, "stall": stall, "idle": idle, "busy": busy}[args.mode](args, deadline, report)
    report.pop("stop")
    print(json.dumps({"ok": True, "mode": args.mode, **report}), flush=True)


if __name__ == "__main__":
    sys.exit(main())
