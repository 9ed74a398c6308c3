"""Physical limit: kernel socket round trip, 64 B, two processes (bench/probes/sock_rtt.c).

Unix stream sockets are the local service path (the reference within each placement);
UDP and TCP (TCP_NODELAY) on 127.0.0.1 stand in for the remote paths.
"""

from benchlib import rtt_rows

TITLE = "socket round trip: Unix stream, UDP, TCP loopback"
ORDER = 30

SIZE = 64
KINDS = [("unix", "Unix stream"), ("udp", "UDP loopback"), ("tcp", "TCP loopback nodelay")]
PLACEMENT_TEXT = {"split": "split cores", "same": "same core"}


def run(ctx):
    iters, warmup = ctx.n(20000, 2000), ctx.n(2000, 200)
    runs = {}
    for rep in range(ctx.reps):
        for placement, cpus in ctx.placements.items():
            for kind, _ in KINDS:
                ctx.log(f"socket rtt: {kind:4s} {placement} cpus {cpus} run {rep + 1}/{ctx.reps}")
                (r,) = ctx.probe_rtt("sock_rtt", cpus, iters, warmup, "--kind", kind, "--size", SIZE)
                runs.setdefault((placement, kind), []).append(r)

    for placement, cpus in ctx.placements.items():
        group = f"physical: socket RTT {SIZE} B, {PLACEMENT_TEXT[placement]}"
        for kind, label in KINDS:
            kind_runs = runs[(placement, kind)]
            notes = [f"cpus {cpus[0]}+{cpus[1]}; n={iters} x {len(kind_runs)} runs"]
            ref_name = "" if kind == "unix" else "Unix stream"
            yield from rtt_rows(group, label, kind_runs, notes, ref_name, runs[(placement, "unix")])
