"""ln_ros2_bridge against a direct ROS 2 hop and against its targets, measured in the same
run, interleaved rep by rep (ln_ros2_bridge/bench/bridge_bench.py does each measurement
inside netns-run):

* one-way latency, 64 B at 200 Hz: LN publisher -> bridge -> rclpy subscriber, against
  rclpy publisher -> rclpy subscriber (same sink, same QoS, sender stamps CLOCK_MONOTONIC);
  target: bridged median <= 1.2x the direct hop;
* 1 MiB images LN -> ROS 2: messages/s arriving when 1000/s are offered (target >= 1.0x
  the direct hop) and the median latency at 20/s (target <= 1.0x). The bridge's
  participant has a 32 MiB shared-memory segment (its Fast DDS profile), the rclpy pair
  Fast DDS's defaults, as typical nodes do;
* the bridge's CPU time per 64-byte message beyond its idle CPU (measured just before),
  at 10 kHz spread over 20 topics, each direction (target <= 10 us): LN -> bridge -> ROS 2
  (into a second bridge as a fast ROS sink), reliable and best effort, and rclpy -> bridge
  -> LN. The LN -> ROS 2 rows are next to what publishing the same messages costs an rclpy
  node (the publisher of the ROS 2 -> LN flow, measured the same way);
* ROS 2 -> LN, reliable, at 2 kHz on one topic and at 10 kHz over 20 topics: messages
  lost between the rclpy publisher and the LN subscriber (by sequence number; target 0)
  and the bridge's CPU share (target < 50 % of a core).

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
sys.path.insert(0, str(HERE.parents[1] / "tests" / "support"))

import ln_testing  # noqa: E402
import ros_testing  # noqa: E402
from benchlib import Row, median, median_row  # noqa: E402  (bench/ is on sys.path under bench/run)

TITLE = "ln_ros2_bridge vs a direct ROS 2 hop and its targets: latency, 1 MiB images, CPU, ROS 2 -> LN"
ORDER = 300
DRIVER = HERE / "bridge_bench.py"
LABEL = {"ln29": "LN 2.9", "ln_core": "ln_core"}


def _systems():
    """The LN systems installed here ("ln29", "ln_core")."""
    found = []
    probe_dir = tempfile.mkdtemp(prefix="ln_ros2_bridge_probe-")
    for kind in ("ln29", "ln_core"):
        try:
            ln_testing.ln_system(kind, probe_dir)  # raises Unavailable when not installed
            found.append(kind)
        except ln_testing.Unavailable as error:
            print("ros2 bridge bench: no %s: %s" % (kind, error), file=sys.stderr)
    shutil.rmtree(probe_dir, ignore_errors=True)
    return found


def run(ctx):
    try:
        import rclpy  # noqa: F401

        import msg_mapping  # noqa: F401
    except ImportError as error:
        ctx.skip("needs rclpy and msg_mapping (. launchless_scripts/env.sh): %s" % error)
    systems = _systems()
    if not systems:
        ctx.skip("no LN system installed (LN 2.9 venv or ln_core's manager and Python package)")
    netns = ros_testing.netns_run()
    prefix = [netns] if netns and not ros_testing.network_is_isolated() else []
    env = dict(ros_testing.loopback_dds_env())
    python = sys.executable

    def measure(*args, timeout=240):
        return ctx.run_json(prefix + [python, DRIVER, *map(str, args)], timeout=timeout, env=env)[-1]

    if ctx.quick:
        systems = systems[:1]  # --quick: one LN system, short runs
    n, seconds, images = ctx.n(3000, 300), ctx.n(4, 1.5), ctx.n(100, 20)
    results = {}

    def add(key, value):
        results.setdefault(key, []).append(value)

    for rep in range(ctx.reps):
        ctx.log("ros2 bridge: run %d/%d" % (rep + 1, ctx.reps))
        add("latency direct", measure("latency", "--via", "direct", "--n", n, "--rate", 200))
        add("image direct", measure("image", "--via", "direct", "--seconds", seconds))
        add("image-latency direct", measure("image-latency", "--via", "direct", "--n", images))
        for kind in systems:
            ln = ("--ln", kind)
            add(("latency", kind), measure("latency", "--via", "bridge", *ln, "--n", n, "--rate", 200))
            add(("image", kind), measure("image", "--via", "bridge", *ln, "--seconds", seconds))
            add(("image-latency", kind), measure("image-latency", "--via", "bridge", *ln, "--n", images))
            add(("ln-to-ros", kind), measure("ln-to-ros", *ln, "--topics", 20, "--rate", 10000, "--seconds", seconds))
            add(
                ("ln-to-ros best effort", kind),
                measure(
                    "ln-to-ros",
                    *ln,
                    "--topics",
                    20,
                    "--rate",
                    10000,
                    "--seconds",
                    seconds,
                    "--reliability",
                    "best_effort",
                ),
            )
            add(
                ("ros-to-ln 20", kind), measure("ros-to-ln", *ln, "--topics", 20, "--rate", 10000, "--seconds", seconds)
            )
            add(("ros-to-ln 1", kind), measure("ros-to-ln", *ln, "--topics", 1, "--rate", 2000, "--seconds", seconds))

    def values(key, field):
        return [r[field] for r in results[key]]

    for kind in systems:
        name = "%s -> bridge -> rclpy" % LABEL[kind]

        def vs_direct(group, metric, unit, test, field, *notes):
            """The bridged figure against the direct rclpy -> rclpy hop of the same runs."""
            direct = median(values(test + " direct", field))
            v = values((test, kind), field)
            return median_row(
                group, name, metric, unit, v, notes, reference_name="rclpy -> rclpy", reference_value=direct
            )

        group = "ROS 2 bridge: one-way latency 64 B @ 200 Hz"
        for metric, field, note in (("median", "median_us", "target <= 1.2x"), ("p90", "p90_us", "")):
            yield vs_direct(group, metric, "us", "latency", field, note)
        group = "ROS 2 bridge: 1 MiB images LN -> ROS 2"
        yield vs_direct(group, "delivered, 1000/s offered", "msg/s", "image", "rate", "target >= 1.0x")
        memory = "bridge: 32 MiB shared-memory segment"
        yield vs_direct(group, "latency median at 20/s", "ms", "image-latency", "median_ms", "target <= 1.0x", memory)
        group = "ROS 2 bridge: CPU per 64 B message, 10 kHz over 20 topics"
        publisher = median(values(("ros-to-ln 20", kind), "source_cpu_us_per_msg"))
        for key, what, reference in (
            ("ln-to-ros", "%s -> bridge -> ROS 2, reliable" % LABEL[kind], "rclpy publisher, reliable"),
            ("ln-to-ros best effort", "%s -> bridge -> ROS 2, best effort" % LABEL[kind], ""),
            ("ros-to-ln 20", "rclpy -> bridge -> %s, reliable" % LABEL[kind], ""),
        ):
            share = median(values((key, kind), "bridge_cpu_share"))
            idle = median(values((key, kind), "bridge_idle_share"))
            yield median_row(
                group,
                what,
                "bridge CPU beyond idle",
                "us",
                values((key, kind), "cpu_us_per_msg"),
                ["target <= 10 us", "bridge %.0f %% of a core in all, idle %.1f %%" % (100 * share, 100 * idle)],
                reference_name=reference,
                reference_value=publisher if reference else None,
            )
        group = "ROS 2 bridge: ROS 2 -> LN, reliable, nothing lost"
        for key, what in (("ros-to-ln 1", "2 kHz, 1 topic"), ("ros-to-ln 20", "10 kHz, 20 topics")):
            lost = values((key, kind), "lost")
            sent = values((key, kind), "sent")
            yield Row(
                group=group,
                name="rclpy -> bridge -> %s, %s" % (LABEL[kind], what),
                metric="lost",
                unit="msg",
                value=max(lost),
                better="lower",
                note="target 0; worst of %d runs of %s messages" % (len(lost), "/".join(map(str, sent))),
            )
            yield median_row(
                group,
                "rclpy -> bridge -> %s, %s" % (LABEL[kind], what),
                "bridge CPU",
                "%cpu",
                [100 * s for s in values((key, kind), "bridge_cpu_share")],
                ["target < 50 % of a core", "%.1f us per message" % median(values((key, kind), "cpu_us_per_msg"))],
            )
