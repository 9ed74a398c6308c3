"""ln_core, isolation: what one misbehaving client costs the others. Normal clients measure a
service round trip (bench/ln/srv.cpp, small request, provider in its main thread) and a topic
round trip (bench/ln/pingpong.cpp, 64 B, copying read), split cores, once alone and once while
a hostile client (bench/ln/py/hostile.py, not pinned) does one of:

* flood: pipelines pings and list_topics to the manager and calls of the same service as fast as
  it can (it reads the answers: only the volume is wrong);
* stall: pipelines calls of the same service and large manager answers and never reads;
* idle: holds 4 000 idle TCP connections to the manager (replacing those the manager closes)
  and 64 idle connections to the service's provider;
* busy: not hostile at all, a process that only keeps a CPU busy: what sharing the two CPUs
  costs by itself, to read the "flood" rows against (a flooder is such a process too).

The reference of each row is the same figure without the hostile client, measured in the same
run, interleaved run by run: the ratio is the cost (goal <= 1.5x). On this 2-vCPU machine a
flooding process takes a CPU from the measured ones, so "flood" also shows plain CPU sharing.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ln"))

import harness as H

TITLE = "ln_core isolation (ln): normal clients' service and topic round trips while one client floods, stalls or idles"
ORDER = 130
MODES = ("flood", "stall", "idle", "busy")
NAMES = {
    "flood": "while one client floods",
    "stall": "while one client stalls",
    "idle": "while one client holds 4000 idle connections",
    "busy": "while a process without LN traffic keeps a CPU busy",
}
GOAL = 1.5
HOSTILE = Path(__file__).resolve().parent.parent / "ln" / "py" / "hostile.py"


def run(ctx):
    from benchlib import RTT_METRICS, median, median_row

    core = H.LnCore()
    try:
        core.prepare(ctx)
        core.start(ctx)
    except H.Unavailable as e:
        core.stop(ctx)
        ctx.skip(str(e))
        return
    cpus = ctx.placements["split"]
    runs = {}  # (workload, mode or "alone") -> [client results]
    failures = []
    try:
        for rep in range(ctx.reps):
            for mode in ("alone",) + MODES:
                for workload in ("service", "topic"):
                    name = f"lniso{rep}{mode}{workload}"
                    service = f"{name}.small"
                    counts = ["--n", ctx.n(10000, 1000), "--warmup", ctx.n(300, 50)]
                    if workload == "service":
                        roles, shared = ("provide", "call"), ["--name", name]
                        server, client = H.pair_commands(core.program("srv"), roles, shared, ["--test", "rtt", *counts])
                    else:
                        shared = ["--size", 64, "--topic", name, "--mode", "copy"]
                        server, client = H.pair_commands(core.program("pingpong"), ("pong", "ping"), shared, counts)
                        # the hostile client attacks the service of a provider started alongside
                        service = f"{name}svc.small"
                    alongside = None
                    if mode != "alone":
                        alongside = [
                            sys.executable,
                            HOSTILE,
                            mode,
                            "--manager",
                            core.address,
                            "--service",
                            service,
                            "--seconds",
                            120,
                        ]
                        if workload == "topic":
                            alongside = [
                                "sh",
                                "-c",
                                f'"$0" provide --name {name}svc & exec "$@"',
                                core.program("srv"),
                                *map(str, alongside),
                            ]
                    ctx.log(f"ln isolation {workload} {mode} run {rep + 1}/{ctx.reps}")
                    try:
                        result = H.run_pair(
                            ctx,
                            core,
                            server,
                            client,
                            cpus=cpus,
                            timeout=150,
                            what=f"isolation {workload} {mode}",
                            alongside=alongside,
                        )[0]
                        runs.setdefault((workload, mode), []).append(result)
                    except (H.MeasureError, H.Unavailable) as e:
                        failures.append(str(e))
                        ctx.log(f"FAILED: {e}")
    finally:
        core.stop(ctx)
    texts = {"service": "service RTT, small request", "topic": "topic RTT 64 B, copying read"}
    for workload in ("service", "topic"):
        alone = runs.get((workload, "alone"), [])
        for mode in MODES:
            hostile = runs.get((workload, mode), [])
            if not hostile or not alone:
                continue
            for key, metric in RTT_METRICS:
                values, ref = [r[key] for r in hostile], median(r[key] for r in alone)
                goal = ""
                if key == "median_us" and mode != "busy":
                    goal = f"goal <= {GOAL:g}x: {'met' if median(values) <= GOAL * ref else 'NOT met'}"
                yield median_row(
                    f"isolation: normal clients, {texts[workload]}, split cores",
                    NAMES[mode],
                    metric,
                    "us",
                    values,
                    [goal],
                    reference_name="no misbehaving client",
                    reference_value=ref,
                )
    if failures:
        raise RuntimeError("; ".join(failures[:3]))
