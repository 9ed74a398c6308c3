#!/usr/bin/env python3
"""Measurements of ln_ros2_bridge for bench/run (see bridge_case.py). Run inside
netns-run; prints one JSON object per result.

  bridge_bench.py latency --via bridge|direct [--ln ln29|ln_core] [--n N] [--rate HZ]
      one-way latency LN -> bridge -> ROS 2 subscriber, or rclpy -> rclpy (the reference):
      64-byte messages stamped with CLOCK_MONOTONIC by the sender, read by the same rclpy sink
  bridge_bench.py image --via bridge|direct [--seconds S] [--rate HZ]
      1 MiB messages offered at --rate (default 1000/s, more than either path carries
      here; a sender flooding flat out would mostly measure whose sender steals more CPU
      from the rest on 2 vCPUs): messages/s arriving at an rclpy sink
  bridge_bench.py image-latency --via bridge|direct [--n N] [--rate HZ]
      one-way latency of 1 MiB images at a rate both paths carry (default 20/s)
  bridge_bench.py cpu [--rate HZ] [--seconds S]
      the bridge's CPU time per message at a fixed LN -> ROS rate (64 B): what the
      bridge process spends beyond its idle CPU (measured just before), per message
  bridge_bench.py ros-to-ln --topics N [--rate HZ] [--seconds S]
      ROS 2 -> bridge -> LN at HZ messages/s in total, spread over N topics (64 B,
      reliable, depth 100): messages lost on the way (by sequence number), the bridge's
      CPU share and its CPU time per message beyond idle, and the rclpy publisher's
  bridge_bench.py ln-to-ros --topics N [--rate HZ] [--seconds S] [--reliability R]
      LN -> bridge -> ROS 2 -> a second bridge (a fast ROS sink) -> LN: the first
      bridge's CPU time per message beyond idle, and messages lost end to end

Both paths use the same sink (raw subscription, fields read from the CDR bytes) and the
same QoS (reliable, keep last 10); the reference sender publishes pre-serialized bytes,
rclpy's fastest path, as the bridge does. Every process is bounded and ended by PID.
Roles used internally: ln-source, ros-source, ros-sink.
"""

import argparse
import json
import os
import statistics
import struct
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PACKAGE_ROOT = HERE.parent
sys.path.insert(0, str(PACKAGE_ROOT))
sys.path.insert(0, str(PACKAGE_ROOT.parent / "tests" / "support"))
import ln_testing  # noqa: E402
import ros_testing  # noqa: E402

MSGDEFS = HERE / "msgdefs"
KINDS = {
    "stamped": ("bridgebench/stamped", "bridgebench_ln_msgs/msg/Stamped", 64),
    "image": ("bridgebench/image", "bridgebench_ln_msgs/msg/Image", 1048576 + 24),
}
# CDR offsets (after the 4-byte encapsulation): stamp (float64) at 4, seq (uint32) at 12
STAMP_AT, SEQ_AT = 4, 12


def emit(**result):
    print(json.dumps(result), flush=True)


# ---------------------------------------------------------------------------------------------
# roles (separate processes)
def ln_source(args):
    """Publishes on args.topics LN topics (args.topic, or with "0", "1", ... appended),
    round robin, args.rate packets/s in total, once each has a subscriber."""
    import links_and_nodes as ln

    client = ln.client("bench_source", os.environ["LN_MANAGER"])
    md_name = KINDS[args.kind][0]
    ports = [client.publish(topic, md_name, buffers=4) for topic in _topics(args.topic, args.topics)]
    deadline = time.monotonic() + args.timeout
    while not all(p.has_subscriber() for p in ports) and time.monotonic() < deadline:
        time.sleep(0.005)  # polling the subscriber flags, bounded
    writes = [(p.port.write, p.packet._data if hasattr(p.packet, "_data") else p.packet._buf) for p in ports]
    emit(event="ready")
    time.sleep(args.start_delay)  # the driver measures the bridge's idle CPU meanwhile
    emit(event="start")

    def write(seq):
        write_port, buffer = writes[seq % len(writes)]
        _stamp(buffer, 0, 8, seq // len(writes))
        write_port(buffer)

    send(write, args)


def _stamp(buffer, stamp_at, seq_at, seq):
    struct.pack_into("<d", buffer, stamp_at, time.monotonic())
    struct.pack_into("<I", buffer, seq_at, seq)


def ros_source(args):
    """Publishes on args.topics topics (args.topic, or args.topic + "0", "1", ... when
    there are several), round robin, args.rate messages/s in total."""
    import rclpy
    from rclpy.qos import QoSProfile
    from rclpy.serialization import serialize_message

    rclpy.init()
    node = rclpy.create_node("bench_source")
    cls = _ros_class(KINDS[args.kind][1])
    topics = _topics(args.topic, args.topics)
    publishers = [node.create_publisher(cls, topic, QoSProfile(depth=args.depth)) for topic in topics]
    buffer = bytearray(serialize_message(cls()))
    deadline = time.monotonic() + args.timeout
    while any(p.get_subscription_count() == 0 for p in publishers) and time.monotonic() < deadline:
        time.sleep(0.005)  # discovery: wait for the sink to match, bounded
    emit(event="ready")
    time.sleep(args.start_delay)  # the driver measures the others' idle CPU meanwhile
    emit(event="start")

    def publish(seq):
        _stamp(buffer, STAMP_AT, SEQ_AT, seq // len(publishers))
        publishers[seq % len(publishers)].publish(bytes(buffer))

    send(publish, args)
    time.sleep(0.5)  # reliable: let the last ones be acknowledged before the publishers go
    node.destroy_node()
    rclpy.shutdown()


def _topics(topic, n):
    return [topic] if n == 1 else ["%s%d" % (topic, i) for i in range(n)]


def send(write, args):
    """Writes args.count messages at args.rate (0: as fast as possible) or for args.seconds,
    in batches of one millisecond's worth (sleeps are that coarse)."""
    period = 1.0 / args.rate if args.rate > 0 else 0.0
    batch = max(1, int(args.rate / 1000)) if period else 1
    start = next_at = time.monotonic()
    end = start + args.seconds if args.seconds > 0 else float("inf")
    seq = 0
    while seq < args.count and time.monotonic() < end:
        for _ in range(batch):
            write(seq)
            seq += 1
        if period:
            next_at += period * batch
            delay = next_at - time.monotonic()
            if delay > 0:
                time.sleep(delay)
    emit(event="sent", count=seq, seconds=time.monotonic() - start)


def ln_sink(args):
    """Reads args.topics LN topics (polling, 512 buffers each: room for seconds of its own delays on a busy
    machine, which are not the bridge's losses) and reports the sequence
    numbers that arrived per topic."""
    import links_and_nodes as ln

    client = ln.client("bench_sink", os.environ["LN_MANAGER"])
    topics = _topics(args.topic, args.topics)
    ports = [client.subscribe(topic, KINDS[args.kind][0], buffers=512) for topic in topics]
    reads = [(p.port.read, p.packet._data if hasattr(p.packet, "_data") else p.packet._buf) for p in ports]
    seqs = [set() for _ in ports]
    emit(event="ready")
    deadline = time.monotonic() + args.timeout
    last_change = time.monotonic()
    while time.monotonic() < deadline:
        got = 0
        for i, (read, buffer) in enumerate(reads):
            while read(buffer, False):
                seqs[i].add(struct.unpack_from("<I", buffer, 8)[0])
                got += 1
        if got:
            last_change = time.monotonic()
        elif any(seqs) and time.monotonic() - last_change > args.idle:
            break  # the sender is done
        else:
            time.sleep(0.0005)
    emit(event="received", counts=[len(s) for s in seqs], max_seq=[max(s) if s else -1 for s in seqs])


def ros_sink(args):
    import rclpy
    from rclpy.qos import QoSProfile

    rclpy.init()
    node = rclpy.create_node("bench_sink")
    latencies, arrivals, seqs = [], [], set()

    def on_message(data):
        now = time.monotonic()
        seq = struct.unpack_from("<I", data, SEQ_AT)[0]
        if seq in seqs:
            return
        seqs.add(seq)
        latencies.append(now - struct.unpack_from("<d", data, STAMP_AT)[0])
        arrivals.append(now)

    subscription = node.create_subscription(
        _ros_class(KINDS[args.kind][1]), args.topic, on_message, QoSProfile(depth=10), raw=True
    )
    emit(event="ready")
    deadline = time.monotonic() + args.timeout
    while subscription.get_publisher_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)  # discovery: the sender starts once we are matched
    emit(event="matched")
    last_change, last_count = time.monotonic(), 0
    while len(seqs) < args.count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
        if len(seqs) != last_count:
            last_change, last_count = time.monotonic(), len(seqs)
        elif seqs and time.monotonic() - last_change > args.idle:
            break  # the sender is done
    emit(event="received", count=len(seqs), latencies=latencies, arrivals=arrivals)
    node.destroy_node()
    rclpy.shutdown()


def _ros_class(ros_type):
    import importlib

    package, kind, name = ros_type.split("/")
    return getattr(importlib.import_module("%s.%s" % (package, kind)), name)


# ---------------------------------------------------------------------------------------------
# the driver
class Run:
    """Starts the processes of one measurement; stops them all (by PID) at the end."""

    def __init__(self, ln_kind):
        self.work = Path(tempfile.mkdtemp(prefix="bridge-bench-"))
        install = ros_testing.build_interfaces([MSGDEFS], "bench", log=str(self.work / "interfaces.log"))
        self.env = ros_testing.interface_env(install)
        self.env.update(ros_testing.loopback_dds_env())
        self.env["PYTHONPATH"] = os.pathsep.join([str(PACKAGE_ROOT), self.env.get("PYTHONPATH", "")])
        self.ln_kind = ln_kind
        self.system = None
        self.processes = []

    def ln(self):
        if self.system is None:
            self.system = ln_testing.ln_system(self.ln_kind, self.work / self.ln_kind)
            self.system.start([str(MSGDEFS)])
        return self.system

    def start(self, name, cmd, env):
        proc = ln_testing.start(cmd, self.work / (name + ".log"), env=env)
        self.processes.append((name, proc))
        return proc

    def role(self, name, role, *args, ln_env=False, python=None):
        env = self.ln().env(self.env) if ln_env else self.env
        return self.start(name, [python or sys.executable, __file__, role, *map(str, args)], env)

    def ln_role(self, name, role, *args):
        """A role that talks LN: the LN system's environment and its peer interpreter."""
        return self.role(name, role, *args, ln_env=True, python=self.ln().peer_python())

    def ln_sink(self, topic, topics, timeout):
        """The LN sink of `topics` topics from `topic` on (idle 2 s ends it), ready."""
        sink = self.ln_role(
            "sink", "ln-sink", "--topic", topic, "--topics", topics, "--timeout", timeout, "--idle", 2.0
        )
        self.events("sink", "ready", 60)
        return sink

    def bridge(self, config_text, name="bridge"):
        config = self.work / (name + ".yaml")
        config.write_text(config_text)
        proc = self.start(
            name,
            [
                sys.executable,
                "-m",
                "ln_ros2_bridge",
                "--config",
                config,
                "--ln-manager",
                self.ln().address,
                "--log-level",
                "warning",
            ],
            self.ln().env(self.env),
        )
        return proc

    def events(self, name, event, timeout):
        path = self.work / (name + ".log")

        def found():
            proc = dict(self.processes)[name]
            for item in ln_testing.json_events(path):
                if item.get("event") == event:
                    return item
            if proc.poll() is not None:
                raise RuntimeError("%s exited before '%s':\n%s" % (name, event, ln_testing.tail(path)))
            return None

        return ln_testing.wait_for(found, timeout, "%s: %s" % (name, event), interval=0.01)

    def close(self):
        for _, proc in reversed(self.processes):
            ln_testing.stop(proc)
        ln_testing.remove_ln_segments(proc.pid for _, proc in self.processes)
        if self.system is not None:
            self.system.stop()
        import shutil

        shutil.rmtree(self.work, ignore_errors=True)


def bridge_config(topic, kind, direction="ln_to_ros", topics=1, depth=10, reliability="reliable"):
    ln_name = KINDS[kind][0]
    return "topics:\n" + "".join(
        "  - {ln: %s, ros: /%s, type: %s, direction: %s, qos: {depth: %d, reliability: %s}, ln_port: {buffers: 16}}\n"
        % (t, t.replace(".", "/"), ln_name, direction, depth, reliability)
        for t in _topics(topic, topics)
    )


class CpuMeter:
    """A process's CPU time beyond its idle rate: idle() measures the rate for a moment
    (while nothing flows), then flow() from the end of that to now."""

    def __init__(self, pid):
        self.pid = pid
        self.idle_share = 0.0
        self._mark = None

    def idle(self, seconds, also=None):
        """`also`: another CpuMeter measured over the same window."""
        meters = [self] + ([also] if also else [])
        starts = [(_cpu_seconds(m.pid), time.monotonic()) for m in meters]
        time.sleep(seconds)  # a measurement window, not a wait for the other side
        for m, (cpu, wall) in zip(meters, starts):
            m._mark = (_cpu_seconds(m.pid), time.monotonic())
            m.idle_share = (m._mark[0] - cpu) / (m._mark[1] - wall)

    def flow(self):
        """(CPU seconds, wall seconds, CPU seconds beyond the idle rate) since idle() ended."""
        cpu, wall = _cpu_seconds(self.pid) - self._mark[0], time.monotonic() - self._mark[1]
        return cpu, wall, max(0.0, cpu - self.idle_share * wall)


IDLE_WINDOW = 1.0  # seconds of the bridge's idle CPU measured before the sender starts


def measure_flow(args, kind, rate, count, seconds, idle):
    """One sender -> (bridge ->) ROS sink run; returns the sink's report (+ bridge CPU)."""
    run = Run(args.ln)
    try:
        topic = "bench.%s" % kind
        ros_topic = "/" + topic.replace(".", "/")
        sink = run.role(
            "sink",
            "ros-sink",
            "--kind",
            kind,
            "--topic",
            ros_topic,
            "--count",
            count,
            "--timeout",
            args.timeout,
            "--idle",
            idle,
        )
        run.events("sink", "ready", 60)
        bridge = meter = None
        delay = IDLE_WINDOW + 0.5
        timing = _pace(count, rate, seconds, args.timeout, delay)
        if args.via == "bridge":
            bridge = run.bridge(bridge_config(topic, kind))
            run.events("sink", "matched", 60)  # the bridge's ROS publisher exists: no start-up losses
            source = run.ln_role("source", "ln-source", "--kind", kind, "--topic", topic, *timing)
        else:
            source = run.role("source", "ros-source", "--kind", kind, "--topic", ros_topic, *timing)
        run.events("source", "ready", 60)
        if bridge:
            meter = CpuMeter(bridge.pid)
            meter.idle(IDLE_WINDOW)
        sent = run.events("source", "sent", args.timeout + 30)
        cpu = meter.flow() if meter else (0.0, 0.0, 0.0)
        received = run.events("sink", "received", args.timeout + 30)
        received.update(
            sent=sent["count"],
            send_seconds=sent["seconds"],
            bridge_cpu=cpu[0],
            wall=cpu[1],
            bridge_cpu_beyond_idle=cpu[2],
            bridge_idle_share=meter.idle_share if meter else 0.0,
        )
        sink.wait(timeout=30)
        source.wait(timeout=30)
        return received
    finally:
        run.close()


def _pace(count, rate, seconds, timeout, delay):
    """A source's arguments: up to `count` messages at `rate` for `seconds`, after `delay`."""
    return ["--count", count, "--rate", rate, "--seconds", seconds, "--timeout", timeout, "--start-delay", delay]


def _count_flow(run, args, sink, source, bridge, source_cpu=False):
    """Once the source is ready (the bridge has every topic): the bridge's idle CPU (and the
    source's), then the flow; returns (counts and CPU shares, bridge CPU seconds beyond idle,
    source CPU seconds beyond idle or 0). Messages are sent round robin over args.topics."""
    run.events("source", "ready", 60)
    meter = CpuMeter(bridge.pid)
    source_meter = CpuMeter(source.pid) if source_cpu else None
    meter.idle(IDLE_WINDOW, also=source_meter)
    sent = run.events("source", "sent", args.timeout + 30)
    cpu, wall, beyond = meter.flow()
    source_beyond = source_meter.flow()[2] if source_meter else 0.0
    received = run.events("sink", "received", args.timeout + 30)
    per_topic = [len(range(t, sent["count"], args.topics)) for t in range(args.topics)]
    lost = sum(max(0, n - got) for n, got in zip(per_topic, received["counts"]))
    sink.wait(timeout=30)
    source.wait(timeout=30)
    report = dict(
        sent=sent["count"],
        rate=sent["count"] / max(1e-9, sent["seconds"]),
        received=sum(received["counts"]),
        lost=lost,
        bridge_cpu_share=cpu / max(1e-9, wall),
        bridge_idle_share=meter.idle_share,
    )
    return report, beyond, source_beyond


def measure_ln_to_ros(args):
    """LN source on args.topics topics -> the measured bridge -> ROS 2 -> a second bridge
    (a compiled ROS sink fast enough for any rate; its node name is no bridge name of the
    first) -> LN sink. Returns the first bridge's CPU and the messages lost end to end."""
    run = Run(args.ln)
    try:
        source_topic, sink_topic, ros_topic = "bench.s", "bench.r", "/bench/s"
        sink = run.ln_sink(sink_topic, args.topics, args.timeout)
        entries = "".join(
            "  - {ln: %s, ros: %s, type: %s, direction: ros_to_ln, qos: {depth: 100, reliability: %s}}\n"
            % (ln_name, ros_name, KINDS["stamped"][0], args.reliability)
            for ln_name, ros_name in zip(_topics(sink_topic, args.topics), _topics(ros_topic, args.topics))
        )
        run.bridge(
            "ln: {client_name: bench_forwarder}\nros: {node_name: bench_forwarder}\n"
            "loop_prevention: {bridge_names: [bench_forwarder]}\ntopics:\n" + entries,
            name="forwarder",
        )
        bridge = run.bridge(
            bridge_config(source_topic, "stamped", "ln_to_ros", args.topics, depth=100, reliability=args.reliability)
        )
        source = run.ln_role(
            "source",
            "ln-source",
            "--topic",
            source_topic,
            "--topics",
            args.topics,
            *_pace(10**9, args.rate, args.seconds, args.timeout, IDLE_WINDOW + 2.0),
        )
        report, beyond, _ = _count_flow(run, args, sink, source, bridge)
        return dict(report, cpu_us_per_msg=1e6 * beyond / max(1, report["sent"]))
    finally:
        run.close()


def measure_ros_to_ln(args):
    """ROS source on args.topics topics -> bridge -> LN sink; messages lost, bridge CPU."""
    run = Run(args.ln)
    try:
        topic, ros_topic = "bench.s", "/bench/s"
        sink = run.ln_sink(topic, args.topics, args.timeout)
        bridge = run.bridge(bridge_config(topic, "stamped", "ros_to_ln", args.topics, depth=100))
        source = run.role(
            "source",
            "ros-source",
            "--topic",
            ros_topic,
            "--topics",
            args.topics,
            "--depth",
            100,
            *_pace(10**9, args.rate, args.seconds, args.timeout, IDLE_WINDOW + 1.0),
        )
        report, beyond, source_beyond = _count_flow(run, args, sink, source, bridge, source_cpu=True)
        return dict(
            report,
            cpu_us_per_msg=1e6 * beyond / max(1, report["received"]),
            source_cpu_us_per_msg=1e6 * source_beyond / max(1, report["sent"]),
        )
    finally:
        run.close()


def _cpu_seconds(pid):
    """utime + stime of a process and its threads, in seconds."""
    fields = Path("/proc/%d/stat" % pid).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))] if values else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "mode",
        choices=[
            "latency",
            "image",
            "image-latency",
            "cpu",
            "ros-to-ln",
            "ln-to-ros",
            "ln-source",
            "ros-source",
            "ros-sink",
            "ln-sink",
        ],
    )
    parser.add_argument("--via", default="bridge", choices=["bridge", "direct"])
    parser.add_argument("--ln", default="ln29", choices=["ln29", "ln_core"])
    parser.add_argument("--kind", default="stamped", choices=list(KINDS))
    parser.add_argument("--topic", default="bench.stamped")
    parser.add_argument("--topics", type=int, default=1)
    parser.add_argument("--depth", type=int, default=10)
    parser.add_argument("--reliability", default="reliable", choices=["reliable", "best_effort"])
    parser.add_argument("--n", "--count", dest="count", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=None)
    parser.add_argument("--seconds", type=float, default=0.0)
    parser.add_argument("--start-delay", type=float, default=0.0)
    parser.add_argument("--timeout", type=float, default=60.0)
    parser.add_argument("--idle", type=float, default=1.0)
    args = parser.parse_args()
    roles = {"ln-source": ln_source, "ros-source": ros_source, "ros-sink": ros_sink, "ln-sink": ln_sink}
    if args.mode in roles:
        args.rate = 200.0 if args.rate is None else args.rate
        return roles[args.mode](args)
    if args.mode in ("latency", "image-latency"):
        # 64 B stamped messages in us, or 1 MiB images in ms; the first few are warm-up
        kind, rate, scale, unit, warmup, quantiles = {
            "latency": ("stamped", 200.0, 1e6, "us", 50, (0.9, 0.99)),
            "image-latency": ("image", 20.0, 1e3, "ms", 5, (0.9,)),
        }[args.mode]
        report = measure_flow(args, kind, args.rate or rate, args.count, 0, 1.0)
        lat = [v * scale for v in report["latencies"][min(warmup, len(report["latencies"]) // 10) :]]
        emit(
            mode=args.mode,
            via=args.via,
            ln=args.ln,
            n=len(lat),
            sent=report["sent"],
            received=report["count"],
            **{f"median_{unit}": statistics.median(lat)},
            **{f"p{round(q * 100)}_{unit}": percentile(lat, q) for q in quantiles},
        )
    elif args.mode == "image":
        report = measure_flow(args, "image", args.rate or 1000.0, 10**9, args.seconds or 5.0, 1.0)
        arrivals = report["arrivals"]
        rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0]) if len(arrivals) > 1 else 0.0
        emit(
            mode="image",
            via=args.via,
            ln=args.ln,
            received=report["count"],
            sent=report["sent"],
            rate=rate,
            sender_rate=report["sent"] / max(1e-9, report["send_seconds"]),
            median_latency_ms=statistics.median(report["latencies"]) * 1e3 if report["latencies"] else None,
        )
    elif args.mode == "cpu":
        report = measure_flow(args, "stamped", args.rate or 1000.0, 10**9, args.seconds or 5.0, 1.0)
        emit(
            mode="cpu",
            ln=args.ln,
            rate=args.rate,
            delivered_rate=report["count"] / max(1e-9, report["send_seconds"]),
            bridge_cpu_share=report["bridge_cpu"] / max(1e-9, report["wall"]),
            bridge_idle_share=report["bridge_idle_share"],
            cpu_us_per_msg=1e6 * report["bridge_cpu_beyond_idle"] / max(1, report["count"]),
        )
    else:  # ln-to-ros, ros-to-ln
        flow = argparse.Namespace(**dict(vars(args), rate=args.rate or 2000.0, seconds=args.seconds or 5.0))
        if args.mode == "ln-to-ros":
            emit(
                mode=args.mode, ln=args.ln, topics=args.topics, reliability=args.reliability, **measure_ln_to_ros(flow)
            )
        else:
            emit(mode=args.mode, ln=args.ln, topics=args.topics, **measure_ros_to_ln(flow))
    return 0


if __name__ == "__main__":
    sys.exit(main())
