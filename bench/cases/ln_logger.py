"""What a topic logger costs its publisher: bench/ln/logger.cpp (LN 2.9 C++ API, compiled for
both systems) publishes 64 B packets at 1 kHz with no subscriber and times every write() (and how
late its loop woke), once without and once with a logger of the topic enabled, interleaved run by
run, pinned to the first CPU of the split placement. The reference of each "with a logger" row is
the same system without one, measured in the same run: a ratio near 1 means the logger does not
slow the publisher. ln_core's manager records by polling the publisher's segment (no wake-up
system call in write(); ln_core/src/manager/recorder.hpp), LN 2.9's daemon by a blocking read
that LN's write() wakes every time. The note says how many of the packets the logger recorded.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ln"))

import harness as H
from benchlib import Row, median, spread_note

TITLE = "ln_core vs LN 2.9 (ln): a topic logger's cost to a 1 kHz publisher"
ORDER = 105
METRICS = [
    ("write_median_us", "write() median"),
    ("write_p99_us", "write() p99"),
    ("late_p99_us", "wake-up lateness p99 (jitter)"),
]


def run(ctx):
    runs = {}  # (system key, with logger) -> [results]
    n, warmup = ctx.n(3000, 400), ctx.n(200, 50)
    cpu = ctx.placements["split"][0] if "split" in ctx.placements else ctx.cpus[0]
    with H.Comparison(ctx) as cmp:
        for rep in range(ctx.reps):
            for system in cmp.systems:
                for logger in (0, 1):
                    ctx.log(f"ln logger 1 kHz {system.label} logger={logger} run {rep + 1}/{ctx.reps}")
                    r = cmp.measure(
                        system,
                        lambda: H.run_single(
                            ctx,
                            system,
                            [
                                system.program("logger"),
                                "pub",
                                "--topic",
                                f"lnbench.logged{logger}",
                                "--n",
                                n,
                                "--warmup",
                                warmup,
                                "--logger",
                                logger,
                            ],
                            cpu=cpu,
                            timeout=60 + 2 * (n + warmup) / 1000,
                            what=f"1 kHz publisher, logger={logger}",
                        ),
                    )
                    if r is not None:
                        runs.setdefault((system.key, logger), []).append(r)

    group = "ln: 1 kHz 64 B publisher, without / with a topic logger"
    for system in cmp.systems:
        without, with_logger = runs.get((system.key, 0), []), runs.get((system.key, 1), [])
        if not with_logger:
            continue
        recorded = [r["recorded"] for r in with_logger]
        for key, metric in METRICS:
            values = [r[key] for r in with_logger]
            note = f"{spread_note(values)}; logger recorded {min(recorded)}..{max(recorded)} of {n} packets"
            yield Row(
                group=group,
                name=f"{system.label}: write() with a logger",
                metric=metric,
                unit="us",
                value=median(values),
                reference_name=f"{system.label} without a logger" if without else "",
                reference_value=median([r[key] for r in without]) if without else None,
                note=note,
            )
    core_with, ln29_with = runs.get((cmp.core.key, 1), []), runs.get((cmp.ln29.key, 1), [])
    if core_with and ln29_with:
        for key, metric in METRICS[:2]:
            yield Row(
                group=group,
                name="ln_core vs LN 2.9, both with a logger",
                metric=metric,
                unit="us",
                value=median([r[key] for r in core_with]),
                reference_name="LN 2.9 with a logger",
                reference_value=median([r[key] for r in ln29_with]),
            )
    cmp.finish()
