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

        def checked(system, fn):
            def go():
                r = fn()
                # ln_core's rows must not silently run LN 2.9's package (or the reverse)
                mod = r.get("ln_module", "")
                if (system is cmp.core) == (cmp.ln29.venv is not None and str(cmp.ln29.venv) in mod):
                    raise H.MeasureError(f"{system.label}: links_and_nodes came from {mod}")
                return r

            return cmp.measure(system, go)

        for rep in range(ctx.reps):
            for placement, cpus in ctx.placements.items():
                for system in cmp.systems:
                    ctx.log(f"ln Python pub/sub RTT 64 B {placement} {system.label} run {rep + 1}/{ctx.reps}")
                    common = ["--size", 64, "--topic", f"lnbench.pyrtt{rep}{placement}"]
                    r = checked(
                        system,
                        lambda: H.run_pair(
                            ctx,
                            system,
                            [PY / "pingpong.py", "pong", *common],
                            [
                                PY / "pingpong.py",
                                "ping",
                                *common,
                                "--n",
                                ctx.n(10000, 1000),
                                "--warmup",
                                ctx.n(200, 50),
                            ],
                            cpus=cpus,
                            timeout=90,
                            what=f"Python pub/sub RTT 64 B {placement}",
                            python=True,
                        )[0],
                    )
                    if r is not None:
                        results.setdefault(("rtt64", placement, system.key), []).append(r)
                for system in cmp.systems:
                    ctx.log(f"ln Python service RTT {placement} {system.label} run {rep + 1}/{ctx.reps}")
                    name = f"lnbench.pysrv{rep}{placement}"
                    r = checked(
                        system,
                        lambda: H.run_pair(
                            ctx,
                            system,
                            [PY / "srv.py", "provide", "--name", name],
                            [
                                PY / "srv.py",
                                "call",
                                "--name",
                                name,
                                "--n",
                                ctx.n(10000, 1000),
                                "--warmup",
                                ctx.n(200, 50),
                            ],
                            cpus=cpus,
                            timeout=90,
                            what=f"Python service RTT {placement}",
                            python=True,
                        )[0],
                    )
                    if r is not None:
                        results.setdefault(("srv", placement, system.key), []).append(r)
            for system in cmp.systems:
                ctx.log(f"ln Python pub/sub RTT 1 MiB (numpy) split {system.label} run {rep + 1}/{ctx.reps}")
                common = ["--size", 1 << 20, "--topic", f"lnbench.pyrtt1m{rep}"]
                r = checked(
                    system,
                    lambda: H.run_pair(
                        ctx,
                        system,
                        [PY / "pingpong.py", "pong", *common],
                        [PY / "pingpong.py", "ping", *common, "--n", ctx.n(1000, 100), "--warmup", ctx.n(50, 10)],
                        cpus=split,
                        timeout=90,
                        what="Python pub/sub RTT 1 MiB",
                        python=True,
                    )[0],
                )
                if r is not None:
                    results.setdefault(("rtt1m", "split", system.key), []).append(r)
            # ln_core only: the same with its zero-copy read port.borrow() (numpy views in place)
            ctx.log(f"ln Python pub/sub RTT 1 MiB (lent read) split ln_core run {rep + 1}/{ctx.reps}")
            common = ["--size", 1 << 20, "--topic", f"lnbench.pyrtt1mb{rep}", "--mode", "borrow"]
            r = checked(
                cmp.core,
                lambda: H.run_pair(
                    ctx,
                    cmp.core,
                    [PY / "pingpong.py", "pong", *common],
                    [PY / "pingpong.py", "ping", *common, "--n", ctx.n(1000, 100), "--warmup", ctx.n(50, 10)],
                    cpus=split,
                    timeout=90,
                    what="Python pub/sub RTT 1 MiB, lent read",
                    python=True,
                )[0],
            )
            if r is not None:
                results.setdefault(("rtt1m_borrow", "split", cmp.core.key), []).append(r)

    ln29, core = cmp.ln29, cmp.core

    def runs(test, placement, system):
        return results.get((test, placement, system.key), [])

    for placement in ctx.placements:
        yield from compare_rows(
            cmp,
            f"ln: Python pub/sub RTT 64 B, {PLACEMENT_TEXT[placement]}",
            "Python pub/sub",
            "LN 2.9 Python pub/sub",
            runs("rtt64", placement, ln29),
            runs("rtt64", placement, core),
            [("median_us", "RTT median"), ("p99_us", "RTT p99")],
            "us",
            0.5,
            extra=lambda rs: f"n={rs[0]['n']}",
        )
        yield from compare_rows(
            cmp,
            f"ln: Python service RTT, small request, {PLACEMENT_TEXT[placement]}",
            "Python service call",
            "LN 2.9 Python service call",
            runs("srv", placement, ln29),
            runs("srv", placement, core),
            [("median_us", "RTT median"), ("p99_us", "RTT p99")],
            "us",
            0.5,
            extra=lambda rs: f"n={rs[0]['n']}",
        )
    yield from compare_rows(
        cmp,
        "ln: Python pub/sub RTT 1 MiB, read into numpy, split cores",
        "Python pub/sub 1 MiB",
        "LN 2.9 Python pub/sub 1 MiB",
        runs("rtt1m", "split", ln29),
        runs("rtt1m", "split", core),
        [("median_us", "RTT median"), ("p99_us", "RTT p99")],
        "us",
        None,
        extra=lambda rs: f"n={rs[0]['n']}",
    )
    yield from compare_rows(
        cmp,
        "ln: Python pub/sub RTT 1 MiB, read into numpy, split cores",
        "Python pub/sub 1 MiB, lent read (port.borrow)",
        "LN 2.9 Python pub/sub 1 MiB",
        runs("rtt1m", "split", ln29),
        runs("rtt1m_borrow", "split", core),
        [("median_us", "RTT median"), ("p99_us", "RTT p99")],
        "us",
        None,
        extra=lambda rs: f"n={rs[0]['n']}",
        ref_only=False,
    )
    cmp.finish()
