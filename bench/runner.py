"""bench/run: runs the benchmark cases in bench/cases/, prints one table, writes CSV, JSON and a PNG.

Every ratio in the table is value / reference, both measured in this run, side by side.
"""

from __future__ import annotations

import argparse
import csv
import importlib
import itertools
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time
import traceback
import types
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # cases import benchlib

from benchlib import BENCH_DIR, REPO_ROOT, CaseSkipped, Context, Row, fmt_num

CASES_DIR = BENCH_DIR / "cases"
RESULTS_DIR = BENCH_DIR / "results"
CSV_FIELDS = [
    "group",
    "name",
    "metric",
    "unit",
    "value",
    "reference_name",
    "reference_value",
    "ratio",
    "better",
    "case",
    "note",
]


# ---------------------------------------------------------------------------------------------
# cases
def discover_cases() -> list:
    """Every bench/cases/*.py with a run() function, ordered by its ORDER (then name)."""
    modules = []
    for path in sorted(CASES_DIR.glob("*.py")):
        if path.name.startswith("_"):
            continue
        try:
            module = importlib.import_module(f"cases.{path.stem}")
        except Exception as e:
            module = broken_case(path.stem, e)
        if callable(getattr(module, "run", None)):
            modules.append(module)
    return sorted(modules, key=lambda m: (getattr(m, "ORDER", 100), m.__name__))


def broken_case(name: str, error: Exception):
    """Stands in for a case module whose import raised: it is listed, and fails when run."""

    def run(_ctx):
        raise RuntimeError(f"cannot import bench/cases/{name}.py: {type(error).__name__}: {error}")

    return types.SimpleNamespace(__name__=f"cases.{name}", TITLE="(import failed)", run=run)


def case_name(module) -> str:
    return module.__name__.rsplit(".", 1)[-1]


def select_cases(modules: list, pattern: str | None) -> list:
    """--only: a case-insensitive regular expression searched in the case's name and TITLE."""
    if not pattern:
        return modules
    rx = re.compile(pattern, re.IGNORECASE)
    return [m for m in modules if rx.search(case_name(m)) or rx.search(getattr(m, "TITLE", ""))]


def run_case(module, ctx: Context) -> tuple[list[Row], str, str]:
    """Returns (rows, status, detail); status is ok | skipped | failed. Rows yielded before a
    failure are kept: a broken later measurement should not hide the earlier ones."""
    rows: list[Row] = []
    try:
        for item in module.run(ctx):
            row = Row.coerce(item)
            row.case = case_name(module)
            rows.append(row)
        return rows, "ok", ""
    except CaseSkipped as e:
        return rows, "skipped", str(e)
    except Exception as e:
        ctx.log(f"{case_name(module)} FAILED: {e}")
        ctx.log_text(traceback.format_exc())
        return rows, "failed", f"{type(e).__name__}: {e}"


# ---------------------------------------------------------------------------------------------
# machine state
def machine_info() -> dict:
    model = next(
        (
            line.split(":", 1)[1].strip()
            for line in Path("/proc/cpuinfo").read_text().splitlines()
            if line.startswith("model name")
        ),
        platform.processor() or "?",
    )
    try:
        rev = (
            subprocess.run(
                ["git", "-C", str(REPO_ROOT), "rev-parse", "--short", "HEAD"],
                capture_output=True,
                text=True,
                timeout=10,
            ).stdout.strip()
            or "none"
        )
    except (OSError, subprocess.TimeoutExpired):
        rev = "unknown"
    return {
        "date": time.strftime("%Y-%m-%d %H:%M:%S %z"),
        "host_cpu": model,
        "cpus_online": os.cpu_count(),
        "cpus_allowed": sorted(os.sched_getaffinity(0)),
        "kernel": platform.release(),
        "python": platform.python_version(),
        "git": rev,
    }


def cpu_busy_share(interval: float) -> float:
    """Share of all CPUs busy (0..1) over `interval` seconds, from /proc/stat."""

    def sample():
        fields = [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
        idle = fields[3] + fields[4]  # idle + iowait
        return sum(fields), idle

    total0, idle0 = sample()
    time.sleep(interval)  # sampling window for the load meter, not a wait for another process
    total1, idle1 = sample()
    return 1.0 - (idle1 - idle0) / max(1, total1 - total0)


def wait_until_quiet(max_wait: float, threshold: float = 0.15) -> float:
    """Poll the load (1 s windows) until it is below `threshold` or `max_wait` s passed.
    Other sessions' builds share these 2 CPUs; starting in a quiet moment keeps tails honest."""
    deadline = time.monotonic() + max_wait
    busy = cpu_busy_share(1.0)
    while busy > threshold and time.monotonic() < deadline:
        print(
            f"[bench] CPUs {busy:.0%} busy, waiting for a quiet moment "
            f"(up to {deadline - time.monotonic():.0f} s more)",
            file=sys.stderr,
            flush=True,
        )
        busy = cpu_busy_share(1.0)
    return busy


# ---------------------------------------------------------------------------------------------
# output
def fmt_ratio(r: float | None) -> str:
    return "" if r is None else f"{r:.3g}x"


def render_table(rows: list[Row]) -> str:
    """Aligned text table; the group is printed once per section to keep lines short."""
    header = ["group", "case", "metric", "value", "reference", "ref value", "ratio", "better is"]
    body = []
    previous_group = None
    for r in rows:
        body.append(
            [
                r.group if r.group != previous_group else "",
                r.name,
                r.metric,
                f"{fmt_num(r.value)} {r.unit}",
                r.reference_name,
                f"{fmt_num(r.reference_value)} {r.unit}" if r.reference_value is not None else "",
                fmt_ratio(r.ratio),
                r.better,
            ]
        )
        previous_group = r.group
    widths = [max(len(str(line[i])) for line in [header] + body) for i in range(len(header))]
    right = {3, 5, 6}  # numbers align right

    def line(cells):
        return "  ".join(
            str(c).rjust(w) if i in right else str(c).ljust(w) for i, (c, w) in enumerate(zip(cells, widths))
        ).rstrip()

    out = [line(header), line(["-" * w for w in widths])]
    for cells in body:
        if cells[0] and len(out) > 2:
            out.append("")  # blank line between groups
        out.append(line(cells))
    return "\n".join(out)


def write_csv(rows: list[Row], path: Path) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow(
                {
                    "group": r.group,
                    "name": r.name,
                    "metric": r.metric,
                    "unit": r.unit,
                    "value": repr(r.value),
                    "reference_name": r.reference_name,
                    "reference_value": "" if r.reference_value is None else repr(r.reference_value),
                    "ratio": "" if r.ratio is None else repr(r.ratio),
                    "better": r.better,
                    "case": r.case,
                    "note": r.note,
                }
            )


def plot(rows: list[Row], path: Path, title: str) -> str:
    """One PNG: a panel of ratios (bars grow from 1 toward the measured ratio, green where the
    measured side is better), then one panel of absolute values per (group, unit), log scale.
    Returns an empty string, or why no plot was made."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    except ImportError:
        return "matplotlib is not installed for this interpreter: no PNG (set LN_BENCH_PYTHON to the project venv)"
    if not rows:
        return "no rows to plot"

    panels = []  # (kind, title, rows)
    ratio_rows = [r for r in rows if r.ratio is not None and r.ratio > 0]
    if ratio_rows:
        panels.append(
            (
                "ratio",
                "ratio = measured / reference, both from this run (log scale; green: measured side is better)",
                ratio_rows,
            )
        )
    for (group, unit), grp in itertools.groupby(rows, key=lambda r: (r.group, r.unit)):
        panels.append(("value", f"{group}  [{unit}]", list(grp)))

    def slots(kind, prs):  # bar slots a panel needs: ratio panels add one per group heading
        return len(prs) + (len({r.group for r in prs}) if kind == "ratio" else 0)

    heights = [0.7 + 0.26 * slots(k, prs) * (1 if k == "ratio" else 1.3) for k, _, prs in panels]
    fig_h = sum(heights) + 0.6
    fig, axes = plt.subplots(len(panels), 1, figsize=(12, fig_h), gridspec_kw={"height_ratios": heights}, squeeze=False)
    fig.suptitle(title, fontsize=9, x=0.01, ha="left")

    def tick_label(v, _pos):
        return f"{v / 1e6:g}M" if v >= 1e6 else f"{v / 1e3:g}k" if v >= 1e4 else f"{v:g}"

    tick_fmt = FuncFormatter(tick_label)
    for ax, (kind, panel_title, prs) in zip(axes[:, 0], panels):
        ax.set_title(panel_title, fontsize=9, loc="left")
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(tick_fmt)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(axis="x", which="major", alpha=0.3)
        ax.tick_params(labelsize=8)
        if kind == "ratio":
            # one line per row, and a heading line above each group's rows
            ys, labels, y = [], [], slots(kind, prs)
            headings = []
            for r in prs:
                if not headings or headings[-1][1] != r.group:
                    y -= 1
                    headings.append((y, r.group))
                y -= 1
                ys.append(y)
                labels.append(f"{r.name} vs {r.reference_name}, {r.metric}")
            good = [(r.ratio < 1) == (r.better == "lower") for r in prs]
            ax.barh(
                ys,
                [r.ratio - 1 for r in prs],
                left=1,
                height=0.6,
                color=["tab:green" if g else "tab:red" for g in good],
            )
            ax.axvline(1, color="black", linewidth=0.8)
            lo = min(min(r.ratio for r in prs), 1) / 4
            ax.set_xlim(lo, max(max(r.ratio for r in prs), 1) * 4)
            for hy, group in headings:
                ax.text(lo * 1.05, hy, group, va="center", fontsize=8, style="italic", color="dimgray")
            for by, r in zip(ys, prs):
                ax.text(
                    r.ratio,
                    by,
                    f" {fmt_ratio(r.ratio)} ",
                    va="center",
                    fontsize=7,
                    ha="left" if r.ratio >= 1 else "right",
                )
            ax.set_ylim(-0.7, slots(kind, prs) - 0.3)
        else:
            ys = list(range(len(prs)))[::-1]
            labels = [f"{r.name}, {r.metric}" for r in prs]
            has_ref = any(r.reference_value for r in prs)
            off = 0.18 if has_ref else 0
            ax.barh(
                [y + off for y in ys],
                [r.value for r in prs],
                height=0.36 if has_ref else 0.6,
                color="tab:blue",
                label="measured",
            )
            if has_ref:
                ax.barh(
                    [y - off for y in ys],
                    [r.reference_value or 0 for r in prs],
                    height=0.36,
                    color="tab:gray",
                    alpha=0.6,
                    label="its reference",
                )
                ax.legend(fontsize=7, loc="lower right")
            values = [v for r in prs for v in (r.value, r.reference_value) if v]
            if values:
                ax.set_xlim(min(values) / 3, max(values) * 8)
            else:  # every value 0 (e.g. messages lost): nothing to put on a log scale
                ax.set_xscale("linear")
                ax.set_xlim(0, 1)
            for y, r in zip(ys, prs):
                ax.text(r.value, y + off, f" {fmt_num(r.value)} {r.unit}", va="center", fontsize=7)
        ax.set_yticks(ys)
        ax.set_yticklabels(labels)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig_h))  # leave room for the title line
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return ""


# ---------------------------------------------------------------------------------------------
def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="bench/run", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--quick", action="store_true", help="small counts for CI smoke runs (whole run < 60 s)")
    p.add_argument(
        "--only",
        metavar="PATTERN",
        help="run only cases whose name or title matches this regular expression (case-insensitive)",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        help="output directory (default bench/results/<timestamp>/, also copied to bench/results/latest/)",
    )
    p.add_argument("--cpus", metavar="A,B", help="the two CPUs for split placement (default: first two allowed)")
    p.add_argument(
        "--wait-quiet",
        metavar="SECONDS",
        type=float,
        default=None,
        help="before measuring, wait up to this long for the CPUs to be <15%% busy "
        "(default 30 for full runs, 0 with --quick)",
    )
    p.add_argument("--list", action="store_true", help="list the cases and exit")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    cases = discover_cases()
    if args.list:
        for m in cases:
            print(f"{case_name(m):24s} {getattr(m, 'TITLE', '')}")
        return 0
    try:
        selected = select_cases(cases, args.only)
    except re.error as e:
        print(f"bench/run: --only {args.only!r} is not a regular expression: {e}", file=sys.stderr)
        return 2
    if not selected:
        print(
            f"bench/run: no case matches --only {args.only!r}; cases: " + ", ".join(case_name(m) for m in cases),
            file=sys.stderr,
        )
        return 2

    allowed = sorted(os.sched_getaffinity(0))
    cpus = allowed
    if args.cpus:
        try:
            cpus = [int(x) for x in args.cpus.split(",")]
        except ValueError:
            cpus = []
        if not cpus or any(c not in allowed for c in cpus):
            print(f"bench/run: --cpus {args.cpus!r}: want CPU numbers from {allowed}", file=sys.stderr)
            return 2
    stamp = time.strftime("%Y%m%d-%H%M%S")
    out_dir = (args.out or RESULTS_DIR / stamp).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)

    info = machine_info()
    wait = args.wait_quiet if args.wait_quiet is not None else (0 if args.quick else 30)
    info["cpu_busy_before"] = round(wait_until_quiet(wait) if wait > 0 else cpu_busy_share(0.5), 3)
    info.update(mode="quick" if args.quick else "full", only=args.only or "", cpus_used=cpus[:2])

    started = time.monotonic()
    statuses = []
    rows: list[Row] = []
    with (out_dir / "run.log").open("w") as log:
        log.write(json.dumps(info) + "\n")
        ctx = Context(quick=args.quick, out_dir=out_dir, build_dir=REPO_ROOT / "build-bench", cpus=cpus, log_file=log)
        for module in selected:
            t0 = time.monotonic()
            ctx.log(f"case {case_name(module)}: {getattr(module, 'TITLE', '')}")
            case_rows, status, detail = run_case(module, ctx)
            rows += case_rows
            statuses.append((case_name(module), status, detail, time.monotonic() - t0))
    info["seconds"] = round(time.monotonic() - started, 1)

    title = (
        f"bench/run {info['mode']} {info['date']}  git {info['git']}  {info['host_cpu']}, "
        f"{info['cpus_online']} CPUs, kernel {info['kernel']}, CPUs {info['cpu_busy_before']:.0%} busy before start"
    )
    print(title)
    print()
    print(render_table(rows))
    print()
    write_csv(rows, out_dir / "results.csv")
    (out_dir / "results.json").write_text(
        json.dumps(
            {
                "meta": info,
                "cases": [{"case": n, "status": s, "detail": d, "seconds": round(t, 1)} for n, s, d, t in statuses],
                "rows": [{**{k: getattr(r, k) for k in CSV_FIELDS if k != "ratio"}, "ratio": r.ratio} for r in rows],
            },
            indent=1,
        )
    )
    why_no_plot = plot(rows, out_dir / "results.png", title)

    for name, status, detail, _secs in statuses:
        if status != "ok":
            print(f"case {name}: {status.upper()}: {detail}")
    if why_no_plot:
        print(f"note: {why_no_plot}")
    print(
        f"{len(rows)} rows from {len(statuses)} cases in {info['seconds']} s; results in {out_dir}/ "
        f"(results.csv, results.json{'' if why_no_plot else ', results.png'}, run.log)"
    )
    if args.out is None:
        latest = RESULTS_DIR / "latest"
        shutil.rmtree(latest, ignore_errors=True)
        shutil.copytree(out_dir, latest)
        print(f"copied to {latest}/")
    return 1 if any(s == "failed" for _, s, _, _ in statuses) else 0


if __name__ == "__main__":
    sys.exit(main())
