"""Pub/sub round trip with the LN Python binding (`import links_and_nodes as ln`).

Run with LN 2.9's or ln_core's package on the path; same code for both.

    pingpong.py pong --size S [--topic T] [--idle 20] [--mode copy|borrow]
    pingpong.py ping --size S [--topic T] --n N --warmup W [--mode copy|borrow]

Topics T.ping / T.pong, buffers=1, lnbench/p64 or lnbench/p1m. ping stamps the
sequence number and a payload pattern (every word up to 4 KiB, one word per
4 KiB page above: numpy over the packet's `pad` array), writes, and reads
T.pong until the echo of that number arrives (timed: write -> matching read;
for 1 MiB that includes reading the packet into numpy), then checks the payload.
pong copies the received packet's fields into its own packet and writes it.
--mode borrow (ln_core extension port.borrow()): both sides read by lending the packet in place
(numpy views, no copy into the port's packet); LN 2.9 has no such read.
Output: one JSON line, like the C++ programs.
"""

import argparse
import json
import sys
import time

import links_and_nodes as ln
import numpy as np

HANDSHAKE = 0xFFFFFFF0
STOP = 0xFFFFFFFF
MD = {64: "lnbench/p64", 4096: "lnbench/p4k", 1048576: "lnbench/p1m"}


def stamp_words(size):
    """Packet word indices (word 0 = seq) that carry the pattern, as in common.hpp."""
    words = size // 4
    if size <= 4096:
        return np.arange(1, words, dtype=np.uint64)
    return np.append(np.arange(1024, words, 1024, dtype=np.uint64), np.uint64(words - 1))


def expected(seq, words):
    return ((np.uint64(seq) * np.uint64(2654435761) + words * np.uint64(40503)) & np.uint64(0xFFFFFFFF)).astype(
        np.uint32
    )


class Stamper:
    def __init__(self, size):
        self.words = stamp_words(size)
        self.pad_index = (self.words - 1).astype(np.intp)  # pad starts at packet word 1

    def stamp(self, packet, seq):
        packet.seq = seq
        packet.pad.view(np.uint32)[self.pad_index] = expected(seq, self.words)

    def check(self, packet, seq):
        got = packet.pad.view(np.uint32)[self.pad_index]
        bad = np.nonzero(got != expected(seq, self.words))[0]
        if len(bad):
            return f"payload word {int(self.words[bad[0]])} of packet {seq} is wrong (torn or stale)"
        return ""


def fail(msg, not_implemented=False):
    print(json.dumps({"ok": False, "error": msg, "not_implemented": not_implemented}), flush=True)
    sys.exit(2)


def pong(clnt, a):
    inp = clnt.subscribe(a.topic + ".ping", MD[a.size], -1, 1)
    out = clnt.publish(a.topic + ".pong", MD[a.size], 1)
    if a.mode == "borrow" and not hasattr(inp, "borrow"):
        fail("port.borrow() (zero-copy read) not yet implemented in this binding", not_implemented=True)
    print(json.dumps({"ready": True}), flush=True)
    last = time.monotonic()
    for _ in range(100_000_000):
        if a.mode == "borrow":
            with inp.borrow(0.5) as p:
                seq = None if p is None else p.seq
                if p is not None and seq != STOP:
                    out.packet.seq = seq
                    out.packet.pad = p.pad
                    out.write()
        else:
            p = inp.read(0.5)
            seq = None if p is None else p.seq
            if p is not None and seq != STOP:
                out.packet.seq = seq
                out.packet.pad = p.pad
                out.write()
        if seq is None:
            if time.monotonic() - last > a.idle:
                fail(f"pong: nothing to echo for {a.idle} s")
            continue
        if seq == STOP:
            return
        last = time.monotonic()


def ping(clnt, a):
    out = clnt.publish(a.topic + ".ping", MD[a.size], 1)
    inp = clnt.subscribe(a.topic + ".pong", MD[a.size], -1, 1)
    st = Stamper(a.size)
    stale = 0
    if a.mode == "borrow" and not hasattr(inp, "borrow"):
        fail("port.borrow() (zero-copy read) not yet implemented in this binding", not_implemented=True)

    # handshake: repeat until the first echo comes back (deadline 20 s)
    t_hs = time.monotonic()
    connected = False
    for _ in range(2000):
        if time.monotonic() - t_hs > 20:
            break
        out.packet.seq = HANDSHAKE
        out.write()
        p = inp.read(0.05)
        if p is not None and p.seq == HANDSHAKE:
            connected = True
            break
    if not connected:
        fail("handshake: no echo from pong within 20 s")
    handshake_s = time.monotonic() - t_hs

    rtt = []
    t_start = time.monotonic()
    clock = time.perf_counter
    for i in range(a.warmup + a.n):
        if time.monotonic() - t_start > a.max_seconds:
            fail(f"round trips took longer than {a.max_seconds} s")
        seq = i
        st.stamp(out.packet, seq)  # outside the timed part
        t0 = clock()
        out.write()
        for _ in range(1000):
            if a.mode == "borrow":
                with inp.borrow(2.0) as p:
                    if p is None:
                        fail(f"no echo of packet {seq} within 2 s")
                    if p.seq != seq:
                        stale += 1
                        continue
                    t1 = clock()
                    bad = st.check(p, seq)  # in place, before the loan ends
                break
            p = inp.read(2.0)
            if p is None:
                fail(f"no echo of packet {seq} within 2 s")
            if p.seq != seq:
                stale += 1
                continue
            t1 = clock()
            bad = st.check(p, seq)
            break
        else:
            fail("1000 stale echoes in a row")
        if i >= a.warmup:
            rtt.append((t1 - t0) * 1e6)
        if bad:
            fail("echo check failed: " + bad)
    seconds = time.monotonic() - t_start
    out.packet.seq = STOP
    out.write()
    v = np.sort(np.array(rtt))

    def q(x):
        return float(v[min(len(v) - 1, int(x * (len(v) - 1) + 0.5))])

    print(
        json.dumps(
            {
                "ok": True,
                "test": "py_pingpong",
                "size": a.size,
                "mode": a.mode,
                "n": len(v),
                "median_us": q(0.5),
                "p90_us": q(0.9),
                "p99_us": q(0.99),
                "min_us": float(v[0]),
                "max_us": float(v[-1]),
                "mean_us": float(v.mean()),
                "stale_echoes": stale,
                "handshake_s": handshake_s,
                "seconds": seconds,
                "ln_module": ln.__file__,
            }
        ),
        flush=True,
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["ping", "pong"])
    ap.add_argument("--size", type=int, default=64, choices=sorted(MD))
    ap.add_argument("--topic", default="lnbench.pyrtt")
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--idle", type=float, default=20)
    ap.add_argument("--max-seconds", type=float, default=60)
    ap.add_argument("--mode", choices=["copy", "borrow"], default="copy")
    a = ap.parse_args()
    try:
        clnt = ln.client("lnbench_py_" + a.role)
        (pong if a.role == "pong" else ping)(clnt, a)
    except SystemExit:
        raise
    except Exception as e:
        msg = f"{type(e).__name__}: {e}"
        fail(msg, "not yet implemented" in msg.lower() or "NOT_YET_IMPLEMENTED" in msg)


if __name__ == "__main__":
    main()
