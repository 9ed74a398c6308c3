"""Physical limit: kernel socket round trip, 64 B, two processes (bench/probes/sock_rtt.c).

Unix stream sockets are the local service path (the reference within each placement);
UDP and TCP (TCP_NODELAY) on 127.0.0.1 stand in for the remote paths.
"""

from benchlib import Row, median, spread_note

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
                (r,) = ctx.run_json(
                    [
                        ctx.probe("sock_rtt"),
                        "--kind",
                        kind,
                        "--cpus",
                        ctx.cpus_arg(cpus),
                        "--iters",
                        iters,
                        "--warmup",
                        warmup,
                        "--size",
                        SIZE,
                    ],
                    timeout=60,
                )
                runs.setdefault((placement, kind), []).append(r)

    for placement, cpus in ctx.placements.items():
        group = f"physical: socket RTT {SIZE} B, {PLACEMENT_TEXT[placement]}"
        ref = {key: median(r[key] for r in runs[(placement, "unix")]) for key in ("median_us", "p99_us")}
        for kind, label in KINDS:
            for key, metric in (("median_us", "RTT median"), ("p99_us", "RTT p99")):
                values = [r[key] for r in runs[(placement, kind)]]
                is_ref = kind == "unix"
                yield Row(
                    group=group,
                    name=label,
                    metric=metric,
                    unit="us",
                    value=median(values),
                    reference_name="" if is_ref else "Unix stream",
                    reference_value=None if is_ref else ref[key],
                    note="; ".join(
                        x
                        for x in (spread_note(values), f"cpus {cpus[0]}+{cpus[1]}; n={iters} x {len(values)} runs")
                        if x
                    ),
                )
