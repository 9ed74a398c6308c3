#!/usr/bin/env python3
"""Python benchmarks that run unchanged on LN 2.9 and on ln_core.

  bench_py.py pong TAG                 echo bench.<TAG>.ping -> bench.<TAG>.pong (64 B)
  bench_py.py ping TAG N               N timed round trips; prints a JSON line
  bench_py.py provide NAME             provide NAME (pytest/small_srv) until killed
  bench_py.py call NAME N              N timed service calls; prints a JSON line
  bench_py.py pub1m TAG / read1m TAG N 1 MiB packets: reads into numpy (and borrowed, on ln_core)
Uses LN_MANAGER; message definitions from tests/msgdefs (pytest/p64, p1m, small_srv).
"""

import json
import statistics
import sys
import time

import links_and_nodes as ln


def stats(name, samples):
    samples = sorted(samples)
    return json.dumps(
        {
            "case": name,
            "n": len(samples),
            "median_us": round(statistics.median(samples) * 1e6, 2),
            "p99_us": round(samples[int(len(samples) * 0.99) - 1] * 1e6, 2),
        }
    )


def pong(tag, md="pytest/p64"):
    clnt = ln.client("bench_pong")
    inp = clnt.subscribe("bench.%s.ping" % tag, md)
    out = clnt.publish("bench.%s.pong" % tag, md)
    deadline = time.time() + 120
    while time.time() < deadline:
        packet = inp.read(0.5)
        if packet is None:
            continue
        out.packet.seq = packet.seq
        out.write()
        if packet.seq == 0xFFFFFFFF:
            break


def ping(tag, n, md="pytest/p64"):
    clnt = ln.client("bench_ping")
    out = clnt.publish("bench.%s.ping" % tag, md)
    inp = clnt.subscribe("bench.%s.pong" % tag, md)
    seq = 1
    while True:  # handshake: retry until an echo comes back
        out.packet.seq = seq
        out.write()
        packet = inp.read(0.05)
        if packet is not None and packet.seq == seq:
            break
        seq += 1
    samples = []
    for i in range(n + 500):
        seq += 1
        t0 = time.perf_counter()
        out.packet.seq = seq
        out.write()
        while True:
            packet = inp.read(True)
            if packet.seq == seq:
                break
        if i >= 500:
            samples.append(time.perf_counter() - t0)
    out.packet.seq = 0xFFFFFFFF
    out.write()
    print(stats("py_pubsub_rtt_64B", samples), flush=True)


def provide(name):
    clnt = ln.client("bench_provider")
    svc = clnt.get_service_provider(name, "pytest/small_srv")

    def handler(request, req, resp):
        resp.seq = req.seq
        resp.y = req.x * 2
        request.respond()
        return 0

    svc.set_handler(handler)
    svc.do_register()
    print("ready", flush=True)
    deadline = time.time() + 300
    while time.time() < deadline:
        clnt.wait_and_handle_service_group_requests(None, 0.5)


def call(name, n):
    clnt = ln.client("bench_caller")
    svc = clnt.get_service(name, "pytest/small_srv")
    samples = []
    for i in range(n + 200):
        t0 = time.perf_counter()
        svc.call(seq=i, x=1.5)
        assert svc.resp.seq == i and svc.resp.y == 3.0
        if i >= 200:
            samples.append(time.perf_counter() - t0)
    print(stats("py_service_rtt_small", samples), flush=True)


def pub1m(tag):
    clnt = ln.client("bench_pub1m")
    out = clnt.publish("bench.%s.1m" % tag, "pytest/p1m")
    out.packet.pad[:] = 1
    deadline = time.time() + 60
    seq = 0
    while time.time() < deadline:
        seq += 1
        out.packet.seq = seq
        out.write()
        time.sleep(0.002)


def read1m(tag, n):
    """Times read(False) / borrow(False) once the multi-waiter says a packet is there."""
    clnt = ln.client("bench_read1m")
    inp = clnt.subscribe("bench.%s.1m" % tag, "pytest/p1m")
    waiter = clnt.get_multi_waiter()
    waiter.add_port(inp)
    while inp.read(1.0) is None:
        pass
    total = 0

    def timed(read_once):
        samples = []
        while len(samples) < n:
            waiter.wait(1.0)
            t0 = time.perf_counter()
            if read_once():
                samples.append(time.perf_counter() - t0)
        return samples

    def copy_read():
        nonlocal total
        packet = inp.read(False)
        if packet is None:
            return False
        total += int(packet.pad[4096])  # the numpy view of the packet
        return True

    print(stats("py_read_1MiB_into_numpy", timed(copy_read)), flush=True)
    if hasattr(inp, "borrow"):

        def borrow_read():
            nonlocal total
            with inp.borrow(False) as packet:
                if packet is None:
                    return False
                total += int(packet.pad[4096])
            return True

        print(stats("py_borrow_1MiB_numpy_view", timed(borrow_read)), flush=True)


if __name__ == "__main__":
    mode, args = sys.argv[1], sys.argv[2:]
    {
        "pong": lambda: pong(args[0]),
        "ping": lambda: ping(args[0], int(args[1])),
        "provide": lambda: provide(args[0]),
        "call": lambda: call(args[0], int(args[1])),
        "pub1m": lambda: pub1m(args[0]),
        "read1m": lambda: read1m(args[0], int(args[1])),
    }[mode]()
