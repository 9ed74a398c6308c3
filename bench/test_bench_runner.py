"""Smoke and unit tests for bench/run. Run: pytest bench/test_bench_runner.py (bounded: <= 120 s)."""

import csv
import os
import subprocess
import sys
import types
from pathlib import Path

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

import runner  # noqa: E402
from benchlib import Row  # noqa: E402


def run_bench(*args, timeout=120):
    # the runner uses the interpreter running the tests unless the project chose one
    env = {**os.environ, "LN_BENCH_PYTHON": os.environ.get("LN_BENCH_PYTHON", sys.executable)}
    return subprocess.run([str(BENCH / "run"), *args], capture_output=True, text=True, timeout=timeout, env=env)


def test_quick_memcpy_run_writes_table_and_csv(tmp_path):
    proc = run_bench("--quick", "--only", "^phys_memcpy$", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    header = next(line for line in proc.stdout.splitlines() if line.startswith("group"))
    assert "ratio" in header.split() and "reference" in header.split()
    with (tmp_path / "results.csv").open() as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    assert "ratio" in reader.fieldnames
    assert len(rows) >= 5, rows
    assert all(r["case"] == "phys_memcpy" and float(r["value"]) > 0 and r["unit"] == "GB/s" for r in rows)
    assert (tmp_path / "run.log").stat().st_size > 0


def test_unknown_case_pattern_is_an_error(tmp_path):
    proc = run_bench("--quick", "--only", "no-such-case-xyz", "--out", str(tmp_path), timeout=30)
    assert proc.returncode == 2
    assert "no case matches" in proc.stderr


def test_ratio_is_value_over_reference_and_printed():
    rows = [
        Row(
            group="g",
            name="ln_core pub/sub 64 B",
            metric="RTT median",
            unit="us",
            value=2.0,
            reference_name="LN 2.9 pub/sub 64 B",
            reference_value=8.0,
        ),
        Row(group="g", name="ring", metric="rate", unit="msg/s", value=3e6),
    ]
    assert rows[0].ratio == 0.25 and rows[0].better == "lower"
    assert rows[1].ratio is None and rows[1].better == "higher"
    table = runner.render_table(rows)
    assert "0.25x" in table and "LN 2.9 pub/sub 64 B" in table and "3M msg/s" in table


def test_failing_and_skipping_cases_do_not_stop_the_run(tmp_path):
    def good(ctx):
        yield {"group": "g", "name": "a", "metric": "m", "unit": "us", "value": 1.0}
        raise RuntimeError("probe exploded")

    def skipping(ctx):
        ctx.skip("LN 2.9 not installed")
        yield  # pragma: no cover

    with (tmp_path / "log").open("w") as log:
        ctx = runner.Context(quick=True, out_dir=tmp_path, build_dir=tmp_path, cpus=[0], log_file=log)
        rows, status, detail = runner.run_case(types.SimpleNamespace(__name__="cases.good", run=good), ctx)
        assert status == "failed" and "probe exploded" in detail and len(rows) == 1 and rows[0].case == "good"
        rows, status, detail = runner.run_case(types.SimpleNamespace(__name__="cases.skip", run=skipping), ctx)
        assert (status, detail, rows) == ("skipped", "LN 2.9 not installed", [])
