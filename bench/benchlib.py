"""What a benchmark case sees: the Row it yields and the Context it runs in.

A case is a module in bench/cases/ with a `run(ctx)` generator that yields Rows (or plain
dicts with the same keys). See bench/README.md for the contract.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shlex
import signal
import statistics
import subprocess
import sys
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parent
REPO_ROOT = BENCH_DIR.parent
PROBE_SRC_DIR = BENCH_DIR / "probes"

# Units where a smaller number is the better one; anything else (GB/s, msg/s, ...) is "higher".
LOWER_IS_BETTER_UNITS = {"ns", "us", "ms", "s", "%cpu", "B", "KiB", "MiB"}


class CaseSkipped(Exception):
    """Raised (via ctx.skip) when a case cannot run here, e.g. LN 2.9 or ROS 2 is not installed."""


class ProbeError(RuntimeError):
    """A measuring program failed, timed out or printed something that is not JSON."""


@dataclasses.dataclass
class Row:
    group: str  # table section, e.g. "shm round trip, split cores"
    name: str  # what was measured, e.g. "ln_core pub/sub 64 B"
    metric: str  # statistic, e.g. "RTT median"
    unit: str  # "us", "GB/s", "msg/s", ...
    value: float
    reference_name: str = ""  # e.g. "LN 2.9 pub/sub 64 B", measured in the same run
    reference_value: float | None = None
    better: str = ""  # "lower" | "higher"; inferred from unit when empty
    note: str = ""  # free text for the CSV: counts, spread, placement
    case: str = ""  # filled in by the runner: the module that yielded it

    def __post_init__(self) -> None:
        if not self.better:
            self.better = "lower" if self.unit in LOWER_IS_BETTER_UNITS else "higher"
        if self.better not in ("lower", "higher"):
            raise ValueError(f"row {self.name!r}: better must be 'lower' or 'higher', not {self.better!r}")
        self.value = float(self.value)
        if self.reference_value is not None:
            self.reference_value = float(self.reference_value)

    @property
    def ratio(self) -> float | None:
        """value / reference_value, the number a target like "<= 0.5x LN 2.9" is checked against."""
        if self.reference_value is None or self.reference_value == 0:
            return None
        return self.value / self.reference_value

    @classmethod
    def coerce(cls, item: Row | dict) -> Row:
        return item if isinstance(item, Row) else cls(**item)


def median(values: Iterable[float]) -> float:
    return statistics.median(list(values))


def fmt_num(v: float | None) -> str:
    """Three significant digits without exponents: 0.123, 4.56, 78.9, 1234, 56.7k, 8.9M."""
    if v is None:
        return ""
    a = abs(v)
    if a >= 1e6:
        return f"{v / 1e6:.3g}M"
    if a >= 1e4:
        return f"{v / 1e3:.3g}k"
    if a >= 100:
        return f"{v:.0f}"
    if a >= 10:
        return f"{v:.1f}"
    if a >= 1:
        return f"{v:.2f}"
    return f"{v:.3g}"


def spread_note(values: Sequence[float]) -> str:
    """'range a..b over k runs' for the note column; empty for a single run."""
    if len(values) < 2:
        return ""
    return f"range {fmt_num(min(values))}..{fmt_num(max(values))} over {len(values)} runs"


def median_row(group: str, name: str, metric: str, unit: str, values: Sequence[float], notes=(), **fields) -> Row:
    """A Row whose value is the median of `values` (one per run); its note: the spread over the
    runs, then `notes` (empty ones left out). `fields`: other Row fields (reference_name, ...)."""
    note = "; ".join(x for x in (spread_note(values), *notes) if x)
    return Row(group=group, name=name, metric=metric, unit=unit, value=median(values), note=note, **fields)


RTT_METRICS = (("median_us", "RTT median"), ("p99_us", "RTT p99"))


def rtt_rows(group: str, name: str, runs: Sequence[dict], notes=(), reference_name="", reference_runs=()):
    """median_row()s "RTT median" and "RTT p99" (us) of round-trip results (median_us, p99_us
    each), against the median of reference_runs when there are any and reference_name is set."""
    for key, metric in RTT_METRICS:
        ref = median(r[key] for r in reference_runs) if reference_runs and reference_name else None
        values = [r[key] for r in runs]
        yield median_row(
            group, name, metric, "us", values, notes, reference_name=reference_name if ref else "", reference_value=ref
        )


class Context:
    """Everything a case needs from the runner. One instance per run, shared by all cases."""

    def __init__(
        self, *, quick: bool, out_dir: Path, build_dir: Path, cpus: Sequence[int], log_file, verbose: bool = False
    ) -> None:
        self.quick = quick
        self.out_dir = out_dir
        self.build_dir = build_dir
        self.repo_root = REPO_ROOT
        self.cpus = list(cpus)
        self._log_file = log_file
        self._verbose = verbose
        self._probes_built = False

    # ---- sizing -------------------------------------------------------------------------
    def n(self, full: int, quick: int) -> int:
        """Pick a count: full runs measure `full`, --quick runs `quick`."""
        return quick if self.quick else full

    @property
    def reps(self) -> int:
        """How many times a case should repeat its measurements (interleaved, median reported)."""
        return 1 if self.quick else 3

    # ---- CPU placement --------------------------------------------------------------------
    @property
    def placements(self) -> dict[str, tuple[int, int]]:
        """Named (cpu of process A, cpu of process B). 'split' needs two CPUs we may use."""
        a = self.cpus[0]
        result = {}
        if len(self.cpus) > 1:
            result["split"] = (a, self.cpus[1])
        result["same"] = (a, a)
        return result

    @staticmethod
    def cpus_arg(pair: tuple[int, int]) -> str:
        return f"{pair[0]},{pair[1]}"

    def probe_rtt(self, name: str, cpus: tuple[int, int], iters: int, warmup: int, *args) -> list[dict]:
        """Runs a round-trip probe of bench/probes (shm_rtt, sock_rtt) between the CPUs `cpus`:
        `warmup` round trips, then `iters` timed ones; `args`: the probe's other options."""
        cmd = [self.probe(name), "--cpus", self.cpus_arg(cpus), "--iters", iters, "--warmup", warmup, *args]
        return self.run_json(cmd, timeout=60)

    # ---- running programs -----------------------------------------------------------------
    def log(self, msg: str) -> None:
        """Progress to stderr (kept short) and the run log (complete)."""
        print(f"[bench] {msg}", file=sys.stderr, flush=True)
        self._log_file.write(f"{time.strftime('%H:%M:%S')} {msg}\n")
        self._log_file.flush()

    def log_text(self, text: str) -> None:
        """Raw text to run.log only (program output, tracebacks)."""
        self._log_file.write(text)
        self._log_file.flush()

    def skip(self, reason: str) -> None:
        raise CaseSkipped(reason)

    def probe(self, name: str) -> str:
        """Path of a native probe from bench/probes/, built (incrementally) on first use."""
        if not self._probes_built:
            cmd = ["make", "-s", "-C", str(PROBE_SRC_DIR), f"BUILD_DIR={self.build_dir}"]
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            self.log_text(f"$ {shlex.join(cmd)}\n{proc.stdout}{proc.stderr}")
            if proc.returncode != 0:
                raise ProbeError(f"building probes failed:\n{proc.stdout}{proc.stderr}")
            self._probes_built = True
        path = self.build_dir / name
        if not path.exists():
            raise ProbeError(f"probe {name} not built (is it listed in bench/probes/Makefile?)")
        return str(path)

    def run_json(self, cmd: Sequence[str], timeout: float = 60.0, env: dict | None = None) -> list[dict]:
        """Run a measuring program and return the JSON objects it printed, one per line.

        Bounded by `timeout` seconds (the whole process group is killed after it). Lines that
        are not JSON objects are kept in the log and otherwise ignored, so a program may print
        human-readable progress too."""
        cmd = [str(c) for c in cmd]
        self.log_text(f"$ {shlex.join(cmd)}\n")
        full_env = None if env is None else {**os.environ, **env}
        # Own session, so a timeout can end the program's children too (probes fork).
        proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=full_env, start_new_session=True
        )
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired as e:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.communicate()
            raise ProbeError(f"{shlex.join(cmd)}: no result within {timeout:g} s") from e
        self.log_text(out + err)
        if proc.returncode != 0:
            detail = (err or out).strip().splitlines()[-3:]
            raise ProbeError(f"{shlex.join(cmd)}: exit {proc.returncode}: {' / '.join(detail)}")
        results = []
        for line in out.splitlines():
            line = line.strip()
            if line.startswith("{"):
                try:
                    results.append(json.loads(line))
                except json.JSONDecodeError:
                    pass
        if not results:
            raise ProbeError(f"{shlex.join(cmd)}: printed no JSON result")
        return results
