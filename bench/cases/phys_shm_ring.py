"""Physical limit: one-way 64 B message rate through an SPSC shared-memory ring (bench/probes/shm_ring.c).

Copy in, publish per message, copy out: the ceiling for a small-message pub/sub stream.
Split cores only: on one core both busy-pollers just take turns by time slice.
"""

from benchlib import Row, median, spread_note

TITLE = "SPSC shared-memory ring, one-way 64 B rate"
ORDER = 40

SIZE = 64
SLOTS = 1024


def run(ctx):
    if "split" not in ctx.placements:
        ctx.skip("needs two CPUs")
    cpus = ctx.placements["split"]
    msgs = ctx.n(20_000_000, 2_000_000)
    results = []
    for rep in range(ctx.reps):
        ctx.log(f"shm ring: {msgs} x {SIZE} B cpus {cpus} run {rep + 1}/{ctx.reps}")
        (r,) = ctx.run_json(
            [ctx.probe("shm_ring"), "--cpus", ctx.cpus_arg(cpus), "--msgs", msgs, "--size", SIZE, "--slots", SLOTS],
            timeout=60,
        )
        if r["bad_messages"]:
            raise RuntimeError(f"shm ring delivered {r['bad_messages']} wrong messages")
        results.append(r)
    values = [r["msgs_per_s"] for r in results]
    yield Row(
        group=f"physical: shm SPSC ring {SIZE} B, split cores",
        name=f"shm ring, {SLOTS} slots",
        metric="one-way rate",
        unit="msg/s",
        value=median(values),
        note="; ".join(
            x for x in (spread_note(values), f"cpus {cpus[0]}+{cpus[1]}; {msgs} msgs x {len(values)} runs") if x
        ),
    )
