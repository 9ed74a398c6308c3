"""Physical limit: round trip through shared memory between two processes (bench/probes/shm_rtt.c).

Ways to wait for the peer: busy-poll (spin), plain futex wait/wake, adaptive spin-then-futex
(the sender skips FUTEX_WAKE while the peer still spins) and, on one core, sched_yield until the
peer's word changes (the cheapest hand-over between two processes there). The futex round trip
is the reference within each placement: it is what a blocking read costs without tricks.
All modes and placements are interleaved run by run, so load changes hit them alike.
"""

from benchlib import median, rtt_rows

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
                args = ["--mode", mode, "--payload", PAYLOAD, "--spin-iters", SPIN_ITERS]
                (r,) = ctx.probe_rtt("shm_rtt", cpus, iters, warmup, *args)
                runs.setdefault((placement, mode), []).append(r)

    for placement, cpus in ctx.placements.items():
        group = f"physical: shm RTT {PAYLOAD} B, {PLACEMENT_TEXT[placement]}"
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
            ref_name = "" if mode == "futex" else "shm futex"
            yield from rtt_rows(group, f"shm {mode}", mode_runs, [extra], ref_name, runs[(placement, "futex")])
