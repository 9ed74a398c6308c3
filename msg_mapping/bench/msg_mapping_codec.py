"""msg_mapping codec (LN packet <-> CDR) vs rclpy serialize/deserialize_message and memcpy.

std_msgs/msg/Float64MultiArray with 64 B / 4 KiB / 1 MiB of data, as an LN topic packet
(msg_mapping's ROS -> LN fixed-size form). Measured in one process pinned to the first CPU
(msg_mapping/bench/codec_bench.py), all methods interleaved per repetition, median per-call
time over batches:
* LN -> CDR (new bytes)  vs  rclpy serialize_message of the same ROS message   (target >= 10x at 64 B)
* CDR -> LN (new bytes)  vs  rclpy deserialize_message
* LN -> CDR into a preallocated buffer  vs  memcpy of the same LN packet through the same
  Python call path (ctypes.memmove), and vs this run's native memcpy probe at 1 MiB
  (target >= 0.5x memcpy at 1 MiB).
Needs msg_mapping built (colcon install/ or build/) and the project venv (rclpy).
Hook-up: bench/cases/msg_mapping_codec.py -> ../../msg_mapping/bench/msg_mapping_codec.py
"""

import glob
import os
import subprocess
import sys
from pathlib import Path

from benchlib import Row, median, spread_note

TITLE = "msg_mapping: LN <-> CDR codec vs rclpy serialize/deserialize and memcpy"
ORDER = 300

HERE = Path(__file__).resolve().parent
SIZES = [(64, "64 B"), (4096, "4 KiB"), (1048576, "1 MiB")]


def msg_mapping_pythonpath(repo_root):
    """Where an importable msg_mapping lives: $MSG_MAPPING_PYTHONPATH, the colcon install or build tree."""
    if os.environ.get("MSG_MAPPING_PYTHONPATH"):
        return os.environ["MSG_MAPPING_PYTHONPATH"]
    candidates = glob.glob(str(repo_root / "install" / "msg_mapping" / "lib" / "python3*" / "site-packages"))
    candidates.append(str(repo_root / "build" / "msg_mapping" / "python"))
    for path in candidates:
        if glob.glob(os.path.join(path, "msg_mapping", "_native*.so")):
            return path
    return None


def run(ctx):
    pythonpath = msg_mapping_pythonpath(ctx.repo_root)
    if not pythonpath:
        ctx.skip("msg_mapping is not built (colcon build, or set MSG_MAPPING_PYTHONPATH)")
    env = {"PYTHONPATH": os.pathsep.join(p for p in (pythonpath, os.environ.get("PYTHONPATH", "")) if p)}
    check = subprocess.run(
        [sys.executable, "-c", "import rclpy.serialization, std_msgs.msg, msg_mapping"],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=120,
    )
    if check.returncode != 0:
        ctx.skip(
            f"{sys.executable} cannot import rclpy/std_msgs/msg_mapping (use the project venv: "
            f"LN_BENCH_PYTHON): {check.stderr.strip().splitlines()[-1:]}"
        )
    cpu = ctx.cpus[0]
    results = {}  # (size, method) -> [per-call seconds]
    details = {}
    memcpy = []  # native memcpy probe, GB/s at 1 MiB (median trial)
    for rep in range(ctx.reps):
        ctx.log(f"msg_mapping codec run {rep + 1}/{ctx.reps}")
        rows = ctx.run_json(
            [
                sys.executable,
                str(HERE / "codec_bench.py"),
                "--cpu",
                cpu,
                "--reps",
                1,
                "--batches",
                ctx.n(15, 5),
                "--batch-ms",
                ctx.n(15, 5),
            ],
            timeout=240,
            env=env,
        )
        for r in rows:
            results.setdefault((r["size"], r["method"]), []).append(r["seconds_per_call"])
            details[(r["size"], r["method"])] = r
        memcpy += [
            r["median_gbps"]
            for r in ctx.run_json(
                [
                    ctx.probe("memcpy_bw"),
                    "--cpu",
                    cpu,
                    "--trials",
                    ctx.n(5, 3),
                    "--trial-ms",
                    ctx.n(100, 40),
                    "--sizes",
                    "1048576",
                ],
                timeout=60,
            )
        ]

    def rate(key):
        return 1.0 / median(results[key])

    for size, text in SIZES:
        if (size, "ln_to_cdr") not in results:
            continue
        ln_bytes = details[(size, "ln_to_cdr")]["ln_bytes"]
        group = f"msg_mapping codec, Float64MultiArray {text} data (LN packet {ln_bytes} B)"
        for name, method, reference, reference_method in (
            ("LN -> CDR, msg_mapping ln_to_cdr", "ln_to_cdr", "rclpy serialize_message", "serialize_message"),
            ("CDR -> LN, msg_mapping cdr_to_ln", "cdr_to_ln", "rclpy deserialize_message", "deserialize_message"),
        ):
            yield Row(
                group=group,
                name=name,
                metric="rate",
                unit="msg/s",
                value=rate((size, method)),
                reference_name=reference,
                reference_value=rate((size, reference_method)),
                note=spread_note([1 / t for t in results[(size, method)]]),
            )
        # LN -> CDR into a preallocated buffer against a copy of the packet, and at 1 MiB against native memcpy
        memmove = ln_bytes * rate((size, "memmove")) / 1e9
        references = [("bandwidth", "memcpy of the LN packet (ctypes.memmove)", memmove, "")]
        if size == 1048576 and memcpy:
            native = "native memcpy 1 MiB (memcpy_bw probe, median trial)"
            references.append(("bandwidth vs native", native, median(memcpy), spread_note(memcpy)))
        for metric, reference, reference_value, note in references:
            yield Row(
                group=group,
                name="LN -> CDR into preallocated buffer",
                metric=metric,
                unit="GB/s",
                value=ln_bytes * rate((size, "ln_to_cdr_into")) / 1e9,
                reference_name=reference,
                reference_value=reference_value,
                note=note,
            )
