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
  bridge_bench.py cpu [--rate HZ] [--seconds S]
      the bridge process's CPU time per second at a fixed LN -> ROS message rate

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

MSGDEFS = HERE / "msgdefs"
KINDS = {"stamped": ("bridgebench/stamped", "bridgebench_ln_msgs/msg/Stamped", 64),
         "image": ("bridgebench/image", "bridgebench_ln_msgs/msg/Image", 1048576 + 24)}
# CDR offsets (after the 4-byte encapsulation): stamp (float64) at 4, seq (uint32) at 12
STAMP_AT, SEQ_AT = 4, 12


def emit(**result):
    print(json.dumps(result), flush=True)


# ---------------------------------------------------------------------------------------------
# roles (separate processes)
def ln_source(args):
    import links_and_nodes as ln
    client = ln.client("bench_source", os.environ["LN_MANAGER"])
    md_name = KINDS[args.kind][0]
    port = client.publish(args.topic, md_name, buffers=4)
    deadline = time.monotonic() + args.timeout
    while not port.has_subscriber() and time.monotonic() < deadline:
        time.sleep(0.005)   # polling the subscriber flag, bounded
    buffer = port.packet._data if hasattr(port.packet, "_data") else port.packet._buf
    native = port.port
    emit(event="ready")
    send(lambda seq: _stamp(buffer, 0, 8, seq) or native.write(buffer), args)


def _stamp(buffer, stamp_at, seq_at, seq):
    struct.pack_into("<d", buffer, stamp_at, time.monotonic())
    struct.pack_into("<I", buffer, seq_at, seq)


def ros_source(args):
    import rclpy
    from rclpy.serialization import serialize_message
    from rclpy.qos import QoSProfile
    rclpy.init()
    node = rclpy.create_node("bench_source")
    cls = _ros_class(KINDS[args.kind][1])
    publisher = node.create_publisher(cls, args.topic, QoSProfile(depth=10))
    buffer = bytearray(serialize_message(cls()))
    deadline = time.monotonic() + args.timeout
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.005)   # discovery: wait for the sink to match, bounded
    emit(event="ready")

    def publish(seq):
        _stamp(buffer, STAMP_AT, SEQ_AT, seq)
        publisher.publish(bytes(buffer))
    send(publish, args)
    node.destroy_node()
    rclpy.shutdown()


def send(write, args):
    """Writes args.count messages at args.rate (0: as fast as possible) or for args.seconds."""
    period = 1.0 / args.rate if args.rate > 0 else 0.0
    start = next_at = time.monotonic()
    end = start + args.seconds if args.seconds > 0 else float("inf")
    seq = 0
    while seq < args.count and time.monotonic() < end:
        write(seq)
        seq += 1
        if period:
            next_at += period
            delay = next_at - time.monotonic()
            if delay > 0:
                time.sleep(delay)
    emit(event="sent", count=seq, seconds=time.monotonic() - start)


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

    subscription = node.create_subscription(_ros_class(KINDS[args.kind][1]), args.topic, on_message,
                                            QoSProfile(depth=10), raw=True)
    emit(event="ready")
    deadline = time.monotonic() + args.timeout
    while subscription.get_publisher_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)   # discovery: the sender starts once we are matched
    emit(event="matched")
    last_change, last_count = time.monotonic(), 0
    while len(seqs) < args.count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
        if len(seqs) != last_count:
            last_change, last_count = time.monotonic(), len(seqs)
        elif seqs and time.monotonic() - last_change > args.idle:
            break   # the sender is done
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
        from ln_ros2_bridge import support
        self.support = support
        self.work = Path(tempfile.mkdtemp(prefix="bridge-bench-"))
        install = support.build_interfaces([MSGDEFS], "bench", log=str(self.work / "interfaces.log"))
        self.env = support.interface_env(install)
        self.env.update(support.loopback_dds_env())
        self.env["PYTHONPATH"] = os.pathsep.join([str(PACKAGE_ROOT), self.env.get("PYTHONPATH", "")])
        self.ln_kind = ln_kind
        self.system = None
        self.processes = []

    def ln(self):
        if self.system is None:
            self.system = self.support.ln_system(self.ln_kind, self.work / self.ln_kind)
            self.system.start([str(MSGDEFS)])
        return self.system

    def start(self, name, cmd, env):
        proc = self.support.start(cmd, self.work / (name + ".log"), env=env)
        self.processes.append((name, proc))
        return proc

    def role(self, name, role, *args, ln_env=False, python=None):
        env = self.ln().env(self.env) if ln_env else self.env
        return self.start(name, [python or sys.executable, __file__, role, *map(str, args)], env)

    def bridge(self, config_text):
        config = self.work / "bridge.yaml"
        config.write_text(config_text)
        proc = self.start("bridge", [sys.executable, "-m", "ln_ros2_bridge", "--config", config,
                                     "--ln-manager", self.ln().address, "--log-level", "warning"],
                          self.ln().env(self.env))
        return proc

    def events(self, name, event, timeout):
        path = self.work / (name + ".log")

        def found():
            proc = dict(self.processes)[name]
            for item in self.support.json_events(path):
                if item.get("event") == event:
                    return item
            if proc.poll() is not None:
                raise RuntimeError("%s exited before '%s':\n%s" % (name, event, self.support.tail(path)))
            return None
        return self.support.wait_for(found, timeout, "%s: %s" % (name, event), interval=0.01)

    def close(self):
        for _, proc in reversed(self.processes):
            self.support.stop(proc)
        self.support.remove_ln_segments(proc.pid for _, proc in self.processes)
        if self.system is not None:
            self.system.stop()
        import shutil
        shutil.rmtree(self.work, ignore_errors=True)


def bridge_config(topic, kind):
    ln_name, ros_type, _ = KINDS[kind]
    return ("topics:\n  - {ln: %s, ros: /%s, type: %s, ln_port: {buffers: 4}}\n"
            % (topic, topic.replace(".", "/"), ln_name))


def measure_flow(args, kind, rate, count, seconds, idle):
    """One sender -> (bridge ->) sink run; returns the sink's report (+ bridge CPU)."""
    run = Run(args.ln)
    try:
        topic = "bench.%s" % kind
        ros_topic = "/" + topic.replace(".", "/")
        sink = run.role("sink", "ros-sink", "--kind", kind, "--topic", ros_topic, "--count", count,
                        "--timeout", args.timeout, "--idle", idle)
        run.events("sink", "ready", 60)
        bridge = None
        if args.via == "bridge":
            bridge = run.bridge(bridge_config(topic, kind))
            run.events("sink", "matched", 60)   # the bridge's ROS publisher exists: no start-up losses
            source = run.role("source", "ln-source", "--kind", kind, "--topic", topic, "--count", count,
                              "--rate", rate, "--seconds", seconds, "--timeout", args.timeout,
                              ln_env=True, python=run.ln().peer_python())
        else:
            source = run.role("source", "ros-source", "--kind", kind, "--topic", ros_topic, "--count", count,
                              "--rate", rate, "--seconds", seconds, "--timeout", args.timeout)
        run.events("source", "ready", 60)
        cpu_start = _cpu_seconds(bridge.pid) if bridge else 0.0
        wall_start = time.monotonic()
        sent = run.events("source", "sent", args.timeout + 30)
        cpu = (_cpu_seconds(bridge.pid) - cpu_start) if bridge else 0.0
        wall = time.monotonic() - wall_start
        received = run.events("sink", "received", args.timeout + 30)
        received.update(sent=sent["count"], send_seconds=sent["seconds"], bridge_cpu=cpu, wall=wall)
        sink.wait(timeout=30)
        source.wait(timeout=30)
        return received
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
    parser.add_argument("mode", choices=["latency", "image", "cpu", "ln-source", "ros-source", "ros-sink"])
    parser.add_argument("--via", default="bridge", choices=["bridge", "direct"])
    parser.add_argument("--ln", default="ln29", choices=["ln29", "ln_core"])
    parser.add_argument("--kind", default="stamped", choices=list(KINDS))
    parser.add_argument("--topic", default="bench.stamped")
    parser.add_argument("--n", "--count", dest="count", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=200.0)
    parser.add_argument("--seconds", type=float, default=0.0)
    parser.add_argument("--timeout", type=float, default=60.0)
    parser.add_argument("--idle", type=float, default=1.0)
    args = parser.parse_args()
    if args.mode == "ln-source":
        return ln_source(args)
    if args.mode == "ros-source":
        return ros_source(args)
    if args.mode == "ros-sink":
        return ros_sink(args)
    if args.mode == "latency":
        report = measure_flow(args, "stamped", args.rate, args.count, 0, 1.0)
        lat = [v * 1e6 for v in report["latencies"][min(50, len(report["latencies"]) // 10):]]  # skip warm-up
        emit(mode="latency", via=args.via, ln=args.ln, n=len(lat), sent=report["sent"], received=report["count"],
             median_us=statistics.median(lat), p90_us=percentile(lat, 0.9), p99_us=percentile(lat, 0.99))
    elif args.mode == "image":
        seconds = args.seconds or 5.0
        rate = args.rate if args.rate != parser.get_default("rate") else 1000.0
        report = measure_flow(args, "image", rate, 10 ** 9, seconds, 1.0)
        arrivals = report["arrivals"]
        rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0]) if len(arrivals) > 1 else 0.0
        emit(mode="image", via=args.via, ln=args.ln, received=report["count"], sent=report["sent"],
             rate=rate, sender_rate=report["sent"] / max(1e-9, report["send_seconds"]),
             median_latency_ms=statistics.median(report["latencies"]) * 1e3 if report["latencies"] else None)
    elif args.mode == "cpu":
        seconds = args.seconds or 5.0
        report = measure_flow(args, "stamped", args.rate, 10 ** 9, seconds, 1.0)
        delivered = report["count"] / max(1e-9, report["send_seconds"])
        cpu_share = report["bridge_cpu"] / max(1e-9, report["wall"])
        emit(mode="cpu", ln=args.ln, rate=args.rate, delivered_rate=delivered, bridge_cpu_share=cpu_share,
             cpu_percent_per_1000_msgs=100.0 * cpu_share / max(1e-9, delivered / 1000.0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
