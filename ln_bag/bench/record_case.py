"""ln record under robot-like load, side by side in one run (ln_bag/bench/record_bench.py
measures, inside one process tree each: manager, publisher, recorder):

* 50 topics x 1 kHz x 64 B, and one topic of 1 MiB images at 30 Hz;
* messages lost (goal 0): published after the recorder subscribed, minus those in the file;
* the recorder's CPU per message (its /proc CPU time over the publishing window), against a
  recorder written in Python (links_and_nodes reads, msg_mapping's codec, the `mcap`
  package's writer), measured on the same load in the same run: why ln record is C++;
* its write bandwidth (bytes written / time its I/O thread spent checksumming and writing
  chunks), against a plain sequential write of the same bytes into the same directory.

Hook-up: bench/cases/ln_record.py imports TITLE, ORDER and run from this file.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "bench"))

from benchlib import Row, median, median_row  # noqa: E402  (bench/ is on sys.path under bench/run)

TITLE = "ln record: 50 topics x 1 kHz x 64 B and 1 MiB images at 30 Hz: loss, CPU per message, write bandwidth"
ORDER = 320
DRIVER = HERE / "record_bench.py"
GROUPS = {"topics": "ln record: 50 topics x 1 kHz x 64 B", "images": "ln record: 1 MiB images at 30 Hz"}
PYTHON_RECORDER = "Python recorder (links_and_nodes + msg_mapping + mcap)"


def run(ctx):
    try:
        import links_and_nodes  # noqa: F401
        import mcap  # noqa: F401

        import ln_bag  # noqa: F401
    except ImportError as error:
        ctx.skip("needs ln_bag, links_and_nodes and mcap (. launchless_scripts/env.sh): %s" % error)
    seconds = ctx.n(5, 1.5)
    results = {}
    for rep in range(ctx.reps):
        for scenario in GROUPS:
            for recorder in ("ln", "python"):
                ctx.log("ln record bench: %s, %s recorder, run %d/%d" % (scenario, recorder, rep + 1, ctx.reps))
                r = ctx.run_json(
                    [
                        sys.executable,
                        DRIVER,
                        "run",
                        "--scenario",
                        scenario,
                        "--recorder",
                        recorder,
                        "--seconds",
                        seconds,
                        "--dir",
                        ctx.out_dir / "ln_record",
                    ],
                    timeout=seconds + 180,
                )
                results.setdefault((scenario, recorder), []).append(r[-1])
    for scenario, group in GROUPS.items():
        ours, python = results[(scenario, "ln")], results[(scenario, "python")]
        worst = "goal 0; worst of %d runs of %d messages each" % (len(ours), ours[0]["published"])
        for name, runs, note in (
            ("ln record", ours, worst),
            (PYTHON_RECORDER, python, "the reference recorder, same load"),
        ):
            lost = max(r["lost"] for r in runs)
            yield Row(
                group=group, name=name, metric="messages lost", unit="msgs", value=lost, better="lower", note=note
            )
        yield median_row(
            group,
            "ln record",
            "recorder CPU per message",
            "us",
            [r["cpu_us_per_message"] for r in ours],
            reference_name=PYTHON_RECORDER,
            reference_value=median(r["cpu_us_per_message"] for r in python),
        )
        yield median_row(
            group,
            "ln record",
            "write bandwidth",
            "MB/s",
            [r["write_mb_per_s"] for r in ours],
            ["I/O thread: CRC + write() per chunk"],
            reference_name="plain sequential write of the same bytes",
            reference_value=median(r["plain_write_mb_per_s"] for r in ours),
        )
