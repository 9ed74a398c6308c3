"""ln_core vs LN 2.9, C++ services: the same program (bench/ln/srv.cpp, LN 2.9 C++ API, provider
built on the base classes ln_generate emits) compiled against each system, run against each
system's own manager, interleaved run by run, same CPU placement.

* Small request round trip (lnbench/small_srv, 12 B each way; every answer checked), provider
  served by wait_and_handle_service_group_requests(NULL, 0.2); split cores and same core.
* 1 MiB dynamic response (lnbench/blob_srv; length, sequence number and payload pattern checked),
  split cores.
* Throughput: 8 caller threads (one service handle each, one process) against a provider whose
  group is handled by a thread pool of 2 threads; calls/s over the run, split cores. LN 2.9's
  pool sometimes stalls for good with 8 callers; such an attempt is retried (up to 3 in all)
  and counted in the note.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ln"))

import harness as H
from harness import compare_rows

TITLE = "ln_core vs LN 2.9 (ln): C++ services: small round trip, 1 MiB response, 8 callers vs 2-thread pool"
ORDER = 101

PLACEMENT_TEXT = {"split": "split cores", "same": "same core"}


def run(ctx):
    rtt, blob, tput = {}, {}, {}
    stalls = {}
    split = ctx.placements.get("split", ctx.placements["same"])
    with H.Comparison(ctx) as cmp:
        srv = ("provide", "call")
        for rep in range(ctx.reps):
            for placement, cpus in ctx.placements.items():
                for system in cmp.systems:
                    ctx.log(f"ln service RTT small {placement} {system.label} run {rep + 1}/{ctx.reps}")
                    cmp.pair(
                        system,
                        "srv",
                        srv,
                        ["--name", f"lnbench.srv.rtt{rep}{placement}"],
                        ["--test", "rtt", "--n", ctx.n(20000, 2000), "--warmup", ctx.n(500, 100)],
                        store=rtt,
                        key=(placement, system.key),
                        cpus=cpus,
                        timeout=90,
                        what=f"service RTT {placement}",
                    )
            for system in cmp.systems:
                ctx.log(f"ln service 1 MiB response split {system.label} run {rep + 1}/{ctx.reps}")
                cmp.pair(
                    system,
                    "srv",
                    srv,
                    ["--name", f"lnbench.srv.blob{rep}"],
                    ["--test", "blob", "--size", 1 << 20, "--n", ctx.n(500, 50), "--warmup", ctx.n(20, 5)],
                    store=blob,
                    key=system.key,
                    cpus=split,
                    timeout=90,
                    what="service 1 MiB response",
                )
            for system in cmp.systems:
                if not cmp.ready.get(system.key):
                    continue
                attempts = 3 if system is cmp.ln29 else 1
                for attempt in range(attempts):
                    ctx.log(
                        f"ln service throughput 8 callers / pool 2 split {system.label} run {rep + 1}/{ctx.reps}"
                        + (f" (attempt {attempt + 1})" if attempt else "")
                    )
                    name = f"lnbench.srv.tput{rep}.{attempt}"
                    call = lambda: H.run_pair(  # noqa: E731
                        ctx,
                        system,
                        [system.program("srv"), "provide", "--name", name, "--pool", 2],
                        [
                            system.program("srv"),
                            "call",
                            "--test",
                            "tput",
                            "--name",
                            name,
                            "--threads",
                            8,
                            "--seconds",
                            ctx.n(2, 0.5),
                        ],
                        cpus=split,
                        timeout=60,
                        what="service throughput",
                    )[0]
                    if attempt + 1 < attempts:
                        try:
                            r = call()
                        except H.MeasureError as e:
                            stalls[system.key] = stalls.get(system.key, 0) + 1
                            ctx.log(f"{system.label} throughput attempt failed ({e}); retrying")
                            continue
                        except H.Unavailable as e:
                            cmp.note_unavailable(system, str(e))
                            break
                    else:
                        r = cmp.measure(system, call)
                    if r is not None:
                        tput.setdefault(system.key, []).append(r)
                    break

    ln29, core = cmp.ln29, cmp.core
    for placement in ctx.placements:
        yield from compare_rows(
            cmp,
            f"ln: C++ service RTT, small request, {PLACEMENT_TEXT[placement]}",
            "service call",
            "LN 2.9 service call",
            rtt.get((placement, ln29.key), []),
            rtt.get((placement, core.key), []),
            [("median_us", "RTT median"), ("p99_us", "RTT p99")],
            "us",
            0.7,
            extra=lambda runs: f"n={runs[0]['n']}",
        )
    yield from compare_rows(
        cmp,
        "ln: C++ service, 1 MiB dynamic response, split cores",
        "1 MiB response call",
        "LN 2.9 1 MiB response call",
        blob.get(ln29.key, []),
        blob.get(core.key, []),
        [("median_us", "RTT median"), ("p99_us", "RTT p99")],
        "us",
        None,
        extra=lambda runs: f"n={runs[0]['n']}",
    )

    def tput_extra(runs):
        return f"calls per thread {runs[-1]['min_thread_calls']}..{runs[-1]['max_thread_calls']} (last run)"

    note_stalls = "; ".join(
        f"{s.label}: {stalls[s.key]} stalled attempt(s) retried" for s in cmp.systems if stalls.get(s.key)
    )
    for row in compare_rows(
        cmp,
        "ln: C++ service throughput, 8 callers vs 2-thread pool, split cores",
        "8 callers",
        "LN 2.9 8 callers",
        tput.get(ln29.key, []),
        tput.get(core.key, []),
        [("calls_per_s", "calls/s")],
        "calls/s",
        1.5,
        extra=tput_extra,
    ):
        if note_stalls:
            row.note = "; ".join(x for x in (row.note, note_stalls) if x)
        yield row
    cmp.finish()
