"""ln_core vs LN 2.9, C++ topics: the same programs (bench/ln/pingpong.cpp, rate.cpp, setup.cpp,
written against the LN 2.9 C++ API) compiled against each system and run against each system's
own manager, interleaved run by run, same CPU placement and sizes.

* Round trip 64 B / 4 KiB / 1 MiB, buffers=1, blocking reads, payload pattern checked on every
  echo; split cores (measuring side on the first CPU, echo side on the second) and same core.
  1 MiB also with loaned writes (ln_outport_get_next_buffer, LN 2.9 API: the packet is produced
  in place, pong reads straight into its loaned buffer; 2 payload copies per round trip in both
  systems) and with ln_core's zero-copy paths ("lent read": ln_read_borrow, pong writes from the
  lent packet; "zero-copy": loaned write + lent read, only stamps touched), each against LN's
  copying read. With plain write() + read() both systems copy 1 MiB four times per round trip,
  unless the copies overlap: ln_core's reader on another core copies a large packet out while the
  writer is still copying it in (streamed copies, ln_core/src/transport/shm_ring.hpp).
* Same core, the bare mechanism in the same group: two tiny processes that hand the core to each
  other with sched_yield (one system call and one context switch per hop, as ln_core's readers on
  the writer's CPU do) and copy the payload like the programs do (bench/probes/shm_rtt --mode
  yield), with LN 2.9's figure as reference: how much of a round trip is the kernel's hand-over.
  It is noisy (bimodal between runs on this VM) and a library with a real working set pays more
  per switch than the 3-page probe.
* One-way 64 B rate, buffers 1 and 256, publisher flooding: writes/s, distinct packets delivered
  per second and delivered fraction (sequence numbers and payload bytes checked by the
  subscriber); plus, split cores, the publisher paced at 2 M msg/s with buffers 256 and with
  buffers that ride out this VM's stalls: is anything lost once the stream reached the
  subscriber?
* Set-up costs: client registration, publish, subscribe, unpublish, client shutdown (medians).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ln"))

import harness as H
from harness import compare_rows

TITLE = "ln_core vs LN 2.9 (ln): C++ pub/sub round trip, one-way rate, set-up costs"
ORDER = 100

SIZES = [(64, "64 B"), (4096, "4 KiB"), (1048576, "1 MiB")]
PLACEMENT_TEXT = {"split": "split cores", "same": "same core"}
MODE_TEXT = {
    "copy": "copying read",
    "loan": "loaned write (get_next_buffer) + copying read",
    "borrow": "lent read (ln_read_borrow)",
    "zc": "zero-copy: loaned write + lent read",
}
# Buffers that suffice at 2 M msg/s on this VM: its vCPUs stall for 3-20 ms now and then
# (hypervisor, other tenants), 256 slots last 128 us, 65536 slots 33 ms.
SUFFICIENT_BUFFERS = 65536
# (buffers, paced rate or 0 = flood) per placement; the paced runs check "no loss when the
# buffers suffice" at the 2 M msg/s target rate (publisher busy-waits, so split cores only)
RATE_CONFIGS = {
    "split": [(1, 0), (256, 0), (256, 2_000_000), (SUFFICIENT_BUFFERS, 2_000_000)],
    "same": [(1, 0), (256, 0)],
}
RTT_TARGET = {(64, "copy"): 0.5, (1048576, "copy"): 0.8, (1048576, "zc"): 0.05}
BARE_SIZES = (64, 1048576)
BARE_NAME = "bare mechanism: 2 processes, sched_yield hand-over, same copies (probes/shm_rtt)"


def rate_text(paced):
    return f"paced at {paced / 1e6:g} M msg/s" if paced else "flood"


def bare_mechanism_rows(group, probe_runs, ln29_runs):
    """The same-core bare mechanism with LN 2.9's copying round trip as reference."""
    from benchlib import rtt_rows

    notes = [f"{len(probe_runs)} runs"]
    yield from rtt_rows(group, BARE_NAME, probe_runs, notes, "LN 2.9 pub/sub, copying read", ln29_runs)


def run(ctx):
    rtt = {}  # (placement, size, system key, mode) -> [results]
    rate = {}  # (placement, buffers, system key) -> [(pub, sub)]
    setup = {}  # system key -> [results]
    bare = {}  # size -> [shm_rtt --mode yield results], same core
    with H.Comparison(ctx) as cmp:
        for rep in range(ctx.reps):
            for placement, cpus in ctx.placements.items():
                for size, size_text in SIZES:
                    big = size > 4096
                    n, warmup = (ctx.n(2000, 200), ctx.n(50, 20)) if big else (ctx.n(20000, 2000), ctx.n(500, 100))
                    if placement == "same" and size in BARE_SIZES:
                        ctx.log(f"ln pub/sub RTT {size_text} same core: bare mechanism run {rep + 1}/{ctx.reps}")
                        probe_args = ["--mode", "yield", "--payload", size]
                        bare.setdefault(size, []).extend(ctx.probe_rtt("shm_rtt", cpus, n, warmup, *probe_args))
                    for system in cmp.systems:
                        modes = (
                            ["copy"]
                            + (["loan"] if big else [])
                            + (["borrow", "zc"] if big and system is cmp.core else [])
                        )
                        for mode in modes:
                            ctx.log(
                                f"ln pub/sub RTT {size_text} {placement} {system.label} {mode} run {rep + 1}/{ctx.reps}"
                            )
                            topic = f"lnbench.rtt{size}.{mode}"
                            cmp.pair(
                                system,
                                "pingpong",
                                ("pong", "ping"),
                                ["--size", size, "--topic", topic, "--mode", mode],
                                ["--n", n, "--warmup", warmup],
                                store=rtt,
                                key=(placement, size, system.key, mode),
                                cpus=cpus,
                                timeout=90,
                                what=f"pub/sub RTT {size_text} {mode} {placement}",
                            )
            for placement, cpus in ctx.placements.items():
                for buffers, paced in RATE_CONFIGS[placement]:
                    for system in cmp.systems:
                        ctx.log(
                            f"ln rate 64 B buffers={buffers} {rate_text(paced)} {placement} {system.label} "
                            f"run {rep + 1}/{ctx.reps}"
                        )
                        r = cmp.pair(
                            system,
                            "rate",
                            ("sub", "pub"),
                            ["--buffers", buffers, "--topic", f"lnbench.rate{buffers}"],
                            ["--seconds", ctx.n(2, 0.5), "--rate", paced],
                            whole=True,
                            cpus=cpus,
                            timeout=60,
                            what=f"rate buffers={buffers} {rate_text(paced)} {placement}",
                        )
                        if r is not None:
                            pub, subs = r
                            if not subs:
                                cmp.failures.append(
                                    f"{system.label} rate buffers={buffers}: subscriber printed no counts"
                                )
                                continue
                            rate.setdefault((placement, buffers, paced, system.key), []).append((pub, subs[-1]))
            for system in cmp.systems:
                ctx.log(f"ln set-up costs {system.label} run {rep + 1}/{ctx.reps}")
                r = cmp.measure(
                    system,
                    lambda: H.run_single(
                        ctx,
                        system,
                        [system.program("setup"), "run", "--reps", ctx.n(30, 10)],
                        cpu=ctx.placements["split"][0] if "split" in ctx.placements else ctx.cpus[0],
                        timeout=90,
                        what="set-up costs",
                    ),
                )
                if r is not None:
                    setup.setdefault(system.key, []).append(r)

    ln29, core = cmp.ln29, cmp.core

    # ---- round trip rows
    for placement in ctx.placements:
        for size, size_text in SIZES:
            group = f"ln: C++ pub/sub RTT {size_text}, {PLACEMENT_TEXT[placement]}"
            ref_runs = rtt.get((placement, size, ln29.key, "copy"), [])
            modes = ["copy"] + (["loan", "borrow", "zc"] if size > 4096 else [])
            for mode in modes:
                core_runs = rtt.get((placement, size, core.key, mode), [])
                # a mode LN 2.9 has too is compared with LN doing the same; the others with LN's copying read
                mode_ref = rtt.get((placement, size, ln29.key, mode))
                ref_name = f"LN 2.9 pub/sub, {MODE_TEXT[mode]}" if mode_ref else "LN 2.9 pub/sub, copying read"
                yield from compare_rows(
                    cmp,
                    group,
                    f"pub/sub, {MODE_TEXT[mode]}",
                    ref_name,
                    mode_ref or ref_runs,
                    core_runs,
                    [("median_us", "RTT median"), ("p99_us", "RTT p99")],
                    "us",
                    RTT_TARGET.get((size, mode)),
                    extra=lambda runs: f"n={runs[0]['n']}; stale echoes {sum(r['stale_echoes'] for r in runs)}",
                    ref_only=bool(mode_ref) or mode == "copy",
                )
            if placement == "same" and bare.get(size):
                yield from bare_mechanism_rows(group, bare[size], ref_runs)

    # ---- rate rows
    for placement in ctx.placements:
        for buffers, paced in RATE_CONFIGS[placement]:
            group = f"ln: C++ one-way 64 B {rate_text(paced)}, buffers={buffers}, {PLACEMENT_TEXT[placement]}"
            ref_runs = [
                {**p, **{f"sub_{k}": v for k, v in s.items()}}
                for p, s in rate.get((placement, buffers, paced, ln29.key), [])
            ]
            core_runs = [
                {**p, **{f"sub_{k}": v for k, v in s.items()}}
                for p, s in rate.get((placement, buffers, paced, core.key), [])
            ]
            for runs in (ref_runs, core_runs):
                for r in runs:
                    r["sub_delivered_pct"] = 100.0 * r["sub_delivered_fraction"]
                    # from the first packet the subscriber got on: was it keeping up?
                    reached = r["written"] - max(r.get("sub_first_seq", 0), 0)
                    r["sub_stream_pct"] = 100.0 * r["sub_delivered"] / reached if reached > 0 else 0.0

            def extra(runs):
                last = runs[-1]
                return (
                    f"last run: written {last['written']}, first delivered #{last.get('sub_first_seq')}, "
                    f"delivered {last['sub_delivered']}, lost {last['sub_lost']}, "
                    f"repeated {last['sub_repeats']}, older {last['sub_older']}, torn {last['sub_torn']}"
                )

            yield from compare_rows(
                cmp,
                group,
                "delivered",
                "LN 2.9 delivered",
                ref_runs,
                core_runs,
                [("sub_delivered_per_s", "msg/s delivered (distinct)")],
                "msg/s",
                None,
                extra=extra,
                abs_target=(2e6, ">= 2 M msg/s") if placement == "split" and not paced else None,
            )
            yield from compare_rows(
                cmp,
                group,
                "delivered fraction",
                "LN 2.9 delivered fraction",
                ref_runs,
                core_runs,
                [("sub_delivered_pct", "distinct packets seen")],
                "%",
                None,
                extra=extra,
            )
            if paced:
                yield from compare_rows(
                    cmp,
                    group,
                    "delivered after the first packet",
                    "LN 2.9 delivered after the first",
                    ref_runs,
                    core_runs,
                    [("sub_stream_pct", "distinct packets seen from the first on")],
                    "%",
                    None,
                    abs_target=(100.0, "no loss") if buffers >= SUFFICIENT_BUFFERS else None,
                )
            yield from compare_rows(
                cmp,
                group,
                "publisher",
                "LN 2.9 publisher",
                ref_runs,
                core_runs,
                [("writes_per_s", "writes/s")],
                "msg/s",
                None,
            )

    # ---- set-up rows
    group = "ln: C++ set-up costs (median per step)"
    for step, text in (
        ("register", "client construct (connect + register)"),
        ("publish", "publish (new topic)"),
        ("subscribe", "subscribe"),
        ("unpublish", "unpublish"),
        ("shutdown", "client shutdown (delete)"),
    ):
        yield from compare_rows(
            cmp,
            group,
            text,
            f"LN 2.9 {step}",
            setup.get(ln29.key, []),
            setup.get(core.key, []),
            [(f"{step}_median_ms", "median")],
            "ms",
            None,
            extra=lambda runs: f"{runs[0]['reps']} repetitions per run",
        )
    cmp.finish()
