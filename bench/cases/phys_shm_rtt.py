"""Physical limit: round trip through shared memory between two processes (bench/probes/shm_rtt.c).

Ways to wait for the peer: busy-poll (spin), plain futex wait/wake, adaptive spin-then-futex
(the sender skips FUTEX_WAKE while the peer still spins) and, on one core, sched_yield until the
peer's word changes (the cheapest hand-over between two processes there). The futex round trip
is the reference within each placement: it is what a blocking read costs without tricks.
All modes and placements are interleaved run by run, so load changes hit them alike.
"""

from benchlib import Row, median, spread_note

TITLE = "shared-memory round trip: spin, futex, adaptive spin-then-futex, yield"
ORDER = 20

PAYLOAD = 64  # bytes copied in and out on every hop, like a 64 B pub/sub message
SPIN_ITERS = 200  # adaptive spin budget in pause iterations (time per iteration is reported)
PLACEMENT_TEXT = {"split": "split cores", "same": "same core"}


def run(ctx):
    iters, warmup = ctx.n(20000, 2000), ctx.n(2000, 200)
    modes_for = {
        "split": ["spin", "futex", "adaptive"],
        # two spinners on one CPU only progress when preempted: not measured
        "same": ["futex", "adaptive", "yield"],
    }
    runs = {}  # (placement, mode) -> list of probe results
    for rep in range(ctx.reps):
        for placement, cpus in ctx.placements.items():
            for mode in modes_for[placement]:
                ctx.log(f"shm rtt: {mode:8s} {placement} cpus {cpus} run {rep + 1}/{ctx.reps}")
                (r,) = ctx.run_json(
                    [
                        ctx.probe("shm_rtt"),
                        "--mode",
                        mode,
                        "--cpus",
                        ctx.cpus_arg(cpus),
                        "--iters",
                        iters,
                        "--warmup",
                        warmup,
                        "--payload",
                        PAYLOAD,
                        "--spin-iters",
                        SPIN_ITERS,
                    ],
                    timeout=60,
                )
                runs.setdefault((placement, mode), []).append(r)

    for placement, cpus in ctx.placements.items():
        group = f"physical: shm RTT {PAYLOAD} B, {PLACEMENT_TEXT[placement]}"

        def stat(mode, key):
            values = [r[key] for r in runs[(placement, mode)]]
            return median(values), spread_note(values)

        ref = {key: stat("futex", key)[0] for key in ("median_us", "p99_us")}
        for mode in modes_for[placement]:
            mode_runs = runs[(placement, mode)]
            extra = f"cpus {cpus[0]}+{cpus[1]}; n={iters} x {len(mode_runs)} runs"
            if mode == "adaptive":
                extra += (
                    f"; spin budget {SPIN_ITERS} x {mode_runs[-1]['ns_per_spin_iter']:.3g} ns; "
                    f"slept in {100 * median(r['sleep_share'] for r in mode_runs):.2g}% of waits"
                )
            timeouts = sum(r["futex_timeouts"] for r in mode_runs)
            if timeouts:  # 1 s futex timeouts: a lost wake-up in the protocol, or a stalled machine
                extra += f"; {timeouts} FUTEX TIMEOUTS"
            for key, metric in (("median_us", "RTT median"), ("p99_us", "RTT p99")):
                value, spread = stat(mode, key)
                is_ref = mode == "futex"
                yield Row(
                    group=group,
                    name=f"shm {mode}",
                    metric=metric,
                    unit="us",
                    value=value,
                    reference_name="" if is_ref else "shm futex",
                    reference_value=None if is_ref else ref[key],
                    note="; ".join(x for x in (spread, extra) if x),
                )
