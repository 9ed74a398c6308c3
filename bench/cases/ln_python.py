"""ln_core vs LN 2.9, Python binding: the same scripts (bench/ln/py/pingpong.py, srv.py, plain
`import links_and_nodes as ln`) run once with LN 2.9's package (its venv's interpreter) and once
with ln_core's package on PYTHONPATH, each against its own manager; interleaved, same placement.

* 64 B pub/sub round trip (buffers=1, reads with timeout, payload pattern checked via numpy),
  split cores and same core.
* Small service round trip (lnbench/small_srv, provider in Python too, answers checked), split
  cores and same core.
* 1 MiB pub/sub round trip, split cores: the packet's `pad` field is read into numpy on every
  hop (stamps on every 4 KiB page checked after the timed part); for ln_core also with its
  zero-copy read `port.borrow()` (numpy views of the packet in place), against LN's copying read.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ln"))

import harness as H
from harness import compare_rows

TITLE = "ln_core vs LN 2.9 (ln): Python binding: 64 B pub/sub, small service, 1 MiB read into numpy"
ORDER = 102

PY = H.LN_DIR / "py"
PLACEMENT_TEXT = {"split": "split cores", "same": "same core"}


def run(ctx):
    results = {}  # (test, placement, system key) -> [result]
    split = ctx.placements.get("split", ctx.placements["same"])
    with H.Comparison(ctx, python=True) as cmp:

        def pair(test, placement, system, cpus, script, roles, shared, counts, what):
            """Runs bench/ln/py/<script> as server and client; counts = (n, warm-up) of the client."""
            ctx.log(f"ln {what} {system.label} run {rep + 1}/{ctx.reps}")
            client = ["--n", counts[0], "--warmup", counts[1]]
            cmp.pair(
                system,
                PY / script,
                roles,
                shared,
                client,
                store=results,
                key=(test, placement, system.key),
                cpus=cpus,
                timeout=90,
                what=what,
            )

        pingpong = ("pingpong.py", ("pong", "ping"))
        for rep in range(ctx.reps):
            small = (ctx.n(10000, 1000), ctx.n(200, 50))
            for placement, cpus in ctx.placements.items():
                for system in cmp.systems:
                    shared = ["--size", 64, "--topic", f"lnbench.pyrtt{rep}{placement}"]
                    pair(
                        "rtt64",
                        placement,
                        system,
                        cpus,
                        *pingpong,
                        shared,
                        small,
                        f"Python pub/sub RTT 64 B {placement}",
                    )
                for system in cmp.systems:
                    shared = ["--name", f"lnbench.pysrv{rep}{placement}"]
                    srv = ("srv.py", ("provide", "call"))
                    pair("srv", placement, system, cpus, *srv, shared, small, f"Python service RTT {placement}")
            big = (ctx.n(1000, 100), ctx.n(50, 10))
            for system in cmp.systems:
                shared = ["--size", 1 << 20, "--topic", f"lnbench.pyrtt1m{rep}"]
                pair("rtt1m", "split", system, split, *pingpong, shared, big, "Python pub/sub RTT 1 MiB (numpy) split")
            # ln_core only: the same with its zero-copy read port.borrow() (numpy views in place)
            shared = ["--size", 1 << 20, "--topic", f"lnbench.pyrtt1mb{rep}", "--mode", "borrow"]
            pair(
                "rtt1m_borrow", "split", cmp.core, split, *pingpong, shared, big, "Python pub/sub RTT 1 MiB, lent read"
            )

    ln29, core = cmp.ln29, cmp.core

    def runs(test, placement, system):
        return results.get((test, placement, system.key), [])

    def rows(group, name, ref_name, ref_runs, core_runs, target, **kw):
        return compare_rows(
            cmp,
            group,
            name,
            ref_name,
            ref_runs,
            core_runs,
            [("median_us", "RTT median"), ("p99_us", "RTT p99")],
            "us",
            target,
            extra=lambda rs: f"n={rs[0]['n']}",
            **kw,
        )

    for placement in ctx.placements:
        where = PLACEMENT_TEXT[placement]
        rtt64 = (runs("rtt64", placement, ln29), runs("rtt64", placement, core))
        yield from rows(f"ln: Python pub/sub RTT 64 B, {where}", "Python pub/sub", "LN 2.9 Python pub/sub", *rtt64, 0.5)
        srv = (runs("srv", placement, ln29), runs("srv", placement, core))
        group = f"ln: Python service RTT, small request, {where}"
        yield from rows(group, "Python service call", "LN 2.9 Python service call", *srv, 0.5)
    group = "ln: Python pub/sub RTT 1 MiB, read into numpy, split cores"
    ref_name, ref_runs = "LN 2.9 Python pub/sub 1 MiB", runs("rtt1m", "split", ln29)
    yield from rows(group, "Python pub/sub 1 MiB", ref_name, ref_runs, runs("rtt1m", "split", core), None)
    lent = "Python pub/sub 1 MiB, lent read (port.borrow)"
    yield from rows(group, lent, ref_name, ref_runs, runs("rtt1m_borrow", "split", core), None, ref_only=False)
    cmp.finish()
