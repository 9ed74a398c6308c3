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

import contextlib
import json
import time

import links_and_nodes as ln
import numpy as np
from common import STOP, fail, main, rtt_stats

HANDSHAKE = 0xFFFFFFF0
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


def receive(inp, mode, timeout):
    """The next packet of `inp` (None after `timeout`) as a context: lent in place by
    port.borrow() in mode "borrow" until the block ends, else read (copied) into the port."""
    if mode == "borrow":
        return inp.borrow(timeout)
    return contextlib.nullcontext(inp.read(timeout))


def pong(clnt, a):
    inp = clnt.subscribe(a.topic + ".ping", MD[a.size], -1, 1)
    out = clnt.publish(a.topic + ".pong", MD[a.size], 1)
    if a.mode == "borrow" and not hasattr(inp, "borrow"):
        fail("port.borrow() (zero-copy read) not yet implemented in this binding", not_implemented=True)
    print(json.dumps({"ready": True}), flush=True)
    last = time.monotonic()
    for _ in range(100_000_000):
        with receive(inp, a.mode, 0.5) as p:  # a lent packet is written before the loan ends
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
            with receive(inp, a.mode, 2.0) as p:
                if p is None:
                    fail(f"no echo of packet {seq} within 2 s")
                if p.seq != seq:
                    stale += 1
                    continue
                t1 = clock()
                bad = st.check(p, seq)  # in place, before a loan ends
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
    print(
        json.dumps(
            {
                "ok": True,
                "test": "py_pingpong",
                "size": a.size,
                "mode": a.mode,
                **rtt_stats(np.sort(np.array(rtt))),
                "stale_echoes": stale,
                "handshake_s": handshake_s,
                "seconds": seconds,
                "ln_module": ln.__file__,
            }
        ),
        flush=True,
    )


def arguments(ap):
    ap.add_argument("--size", type=int, default=64, choices=sorted(MD))
    ap.add_argument("--topic", default="lnbench.pyrtt")
    ap.add_argument("--mode", choices=["copy", "borrow"], default="copy")


if __name__ == "__main__":
    main("lnbench_py_", {"ping": ping, "pong": pong}, arguments)
