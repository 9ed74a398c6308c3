"""ln_ros2_bridge vs a direct ROS 2 hop, measured in the same run, interleaved rep by rep
(ln_ros2_bridge/bench/bridge_bench.py does each measurement inside netns-run):

* one-way latency, 64 B at 200 Hz: LN publisher -> bridge -> rclpy subscriber, against
  rclpy publisher -> rclpy subscriber (same sink, same QoS, sender stamps CLOCK_MONOTONIC);
  target: bridged median <= 1.2x the direct hop;
* 1 MiB images offered at 1000/s: messages/s arriving through the bridge against
  rclpy -> rclpy; target >= 0.9x;
* the bridge process's CPU per 1000 msg/s (64 B, LN -> ROS 2 at 1000 msg/s), no reference.

Each LN system that is installed (LN 2.9's package and manager, ln_core's) gets its rows;
the direct hop does not involve LN and is measured once per rep.

Hook-up: bench/cases/ros2_bridge.py imports TITLE, ORDER and run from this file.
"""
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from benchlib import Row, median, spread_note  # noqa: E402  (bench/ is on sys.path under bench/run)

TITLE = "ln_ros2_bridge vs a direct ROS 2 hop: latency, 1 MiB image rate, bridge CPU"
ORDER = 300
DRIVER = HERE / "bridge_bench.py"


def _systems():
    """The LN systems installed here ("ln29", "ln_core")."""
    from ln_ros2_bridge import support
    found = []
    probe_dir = tempfile.mkdtemp(prefix="ln_ros2_bridge_probe-")
    for kind in ("ln29", "ln_core"):
        try:
            support.ln_system(kind, probe_dir)   # raises Unavailable when not installed
            found.append(kind)
        except support.Unavailable as error:
            print("ros2 bridge bench: no %s: %s" % (kind, error), file=sys.stderr)
    shutil.rmtree(probe_dir, ignore_errors=True)
    return found


def run(ctx):
    from ln_ros2_bridge import support
    try:
        import msg_mapping  # noqa: F401
        import rclpy  # noqa: F401
    except ImportError as error:
        ctx.skip("needs rclpy and msg_mapping (. launchless_scripts/env.sh): %s" % error)
    systems = _systems()
    if not systems:
        ctx.skip("no LN system installed (LN 2.9 venv or ln_core's manager and Python package)")
    netns = support.netns_run()
    prefix = [netns] if netns and not support.network_is_isolated() else []
    env = dict(support.loopback_dds_env())
    python = sys.executable

    def measure(*args, timeout=240):
        return ctx.run_json(prefix + [python, DRIVER, *map(str, args)], timeout=timeout, env=env)[-1]

    if ctx.quick:
        systems = systems[:1]   # --quick: one LN system, short runs (the whole bench/run stays < 60 s)
    latency, image, cpu = {}, {}, {}
    n = ctx.n(3000, 300)
    seconds = ctx.n(5, 1.5)
    for rep in range(ctx.reps):
        ctx.log("ros2 bridge: run %d/%d" % (rep + 1, ctx.reps))
        latency.setdefault("direct", []).append(measure("latency", "--via", "direct", "--n", n, "--rate", 200))
        image.setdefault("direct", []).append(measure("image", "--via", "direct", "--seconds", seconds))
        for kind in systems:
            latency.setdefault(kind, []).append(measure("latency", "--via", "bridge", "--ln", kind,
                                                        "--n", n, "--rate", 200))
            image.setdefault(kind, []).append(measure("image", "--via", "bridge", "--ln", kind,
                                                      "--seconds", seconds))
            cpu.setdefault(kind, []).append(measure("cpu", "--ln", kind, "--rate", 1000, "--seconds", seconds))

    label = {"ln29": "LN 2.9", "ln_core": "ln_core"}
    direct_median = [r["median_us"] for r in latency["direct"]]
    direct_p90 = [r["p90_us"] for r in latency["direct"]]
    direct_rate = [r["rate"] for r in image["direct"]]
    for kind in systems:
        name = "%s -> bridge -> rclpy" % label[kind]
        values = [r["median_us"] for r in latency[kind]]
        yield Row(group="ROS 2 bridge: one-way latency 64 B @ 200 Hz", name=name, metric="median", unit="us",
                  value=median(values), reference_name="rclpy -> rclpy", reference_value=median(direct_median),
                  note="target <= 1.2x; " + spread_note(values))
        values = [r["p90_us"] for r in latency[kind]]
        yield Row(group="ROS 2 bridge: one-way latency 64 B @ 200 Hz", name=name, metric="p90", unit="us",
                  value=median(values), reference_name="rclpy -> rclpy", reference_value=median(direct_p90),
                  note=spread_note(values))
        values = [r["rate"] for r in image[kind]]
        yield Row(group="ROS 2 bridge: 1 MiB images offered at 1000/s", name=name, metric="delivered",
                  unit="msg/s", value=median(values), reference_name="rclpy -> rclpy",
                  reference_value=median(direct_rate), note="target >= 0.9x; " + spread_note(values))
        values = [r["cpu_percent_per_1000_msgs"] for r in cpu[kind]]
        yield Row(group="ROS 2 bridge: CPU", name="%s -> ROS 2, 64 B at 1000 msg/s" % label[kind],
                  metric="bridge CPU per 1000 msg/s", unit="% core", value=median(values), better="lower",
                  note=spread_note(values))
