"""One measurement of `ln record` (or of the Python reference recorder) under a
robot-like load; prints one JSON object. Run by record_case.py (bench/run).

    record_bench.py run --scenario topics|images --recorder ln|python --seconds S --dir DIR

topics: 50 topics x 1 kHz x 64 B (lnbagbench/sample64); images: one topic of
1 MiB images at 30 Hz (lnbagbench/image1m). An ln_core manager of its own, a
publisher process (ln_core's Python package, a fixed schedule that catches up
when late), the recorder as the user runs it. The recorder's CPU time is read
from /proc over the publishing window; afterwards every topic's messages in
the file are counted against what was published (all of it was published
after the recorder had subscribed). For `ln record` also its I/O thread's
write time (summary `write_seconds`) and a plain sequential write of the same
number of bytes, 1 MiB per write(), into the same directory.

    record_bench.py publish ...     the publisher process
    record_bench.py pyrecord ...    the reference: a recorder written in Python with links_and_nodes
                                    (reads), msg_mapping (LN -> CDR) and the `mcap` package's writer
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests" / "support"))
import ln_testing  # noqa: E402

MSGDEFS = HERE / "msgdefs"
SCENARIOS = {"topics": ("lnbagbench/sample64", 50, 1000.0), "images": ("lnbagbench/image1m", 1, 30.0)}


def topic_names(scenario):
    md, count, _ = SCENARIOS[scenario]
    return ["lnbagbench.%s.t%02d" % (scenario, i) for i in range(count)]


# ------------------------------------------------------------------ publisher


def publish(args):
    import links_and_nodes as ln

    md, _, rate = SCENARIOS[args.scenario]
    client = ln.client("lnbagbench_publisher")
    ports = [client.publish(name, md) for name in topic_names(args.scenario)]
    deadline = time.monotonic() + 30
    while not all(p.has_subscriber() for p in ports):
        if time.monotonic() > deadline:
            sys.exit("publisher: no subscriber on every topic within 30 s")
        time.sleep(0.01)
    print(json.dumps({"subscribed": True}), flush=True)
    sys.stdin.readline()  # "go"
    ticks = int(args.seconds * rate)
    start = time.monotonic()
    for tick in range(ticks):
        due = start + tick / rate
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        for port in ports:
            port.packet.count = tick
            port.write()
    print(json.dumps({"published": ticks * len(ports), "seconds": time.monotonic() - start}), flush=True)
    sys.stdin.read()  # the topics stay until the driver is done
    client.close()


# ------------------------------------------------------- the Python reference


def pyrecord(args):
    """A recorder as one would write it in Python: multi-waiter, read(), codec, mcap writer."""
    import links_and_nodes as ln
    from mcap.writer import CompressionType, Writer

    import msg_mapping

    md, _, rate = SCENARIOS[args.scenario]
    client = ln.client("lnbagbench_pyrecord")
    library = msg_mapping.Library([str(MSGDEFS)])
    generator = msg_mapping.LnToRos()
    ros_type = generator.add(library, md)["ros_type"]
    codec = generator.codec(md)
    size = library.load(md)["packet_size"]
    buffers = int(min(max(16, rate * 0.5), max(2, (32 << 20) // size)))  # as ln record sizes them
    ports = [client.subscribe(name, md, buffers=buffers) for name in topic_names(args.scenario)]
    waiter = client.get_multi_waiter()
    for port in ports:
        waiter.add_port(port)
    stop = []
    signal.signal(signal.SIGINT, lambda *a: stop.append(1))
    with open(args.output, "wb") as f:
        writer = Writer(f, compression=CompressionType.NONE)
        writer.start("ros2", "pyrecord")
        schema = writer.register_schema(ros_type, "ros2msg", b"")
        channels = [writer.register_channel("/" + p.topic_name.replace(".", "/"), "cdr", schema) for p in ports]
        print(json.dumps({"recording": True}), flush=True)
        while not stop:
            waiter.wait(0.05)
            for port, channel in zip(ports, channels):
                while port.read(False) is not None:
                    sequence, _, stamp = port.sample_info
                    now = time.time_ns()
                    writer.add_message(
                        channel,
                        now,
                        codec.ln_to_cdr(port.packet._buf),
                        int(stamp * 1e9),
                        sequence=sequence & 0xFFFFFFFF,
                    )
        writer.finish()


# --------------------------------------------------------------------- driver


def ln_core_manager():
    try:
        return ln_testing.ln_core_manager()
    except ln_testing.Unavailable as error:
        sys.exit(str(error))


def cpu_seconds(pid):
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def read_line(process, what, timeout=60):
    import select

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if select.select([process.stdout], [], [], 0.5)[0]:
            line = process.stdout.readline()
            if not line:
                break
            if line.startswith("{"):
                return json.loads(line)
    raise RuntimeError("%s: nothing from %s" % (what, " ".join(map(str, process.args))))


def count_messages(path):
    from mcap.stream_reader import StreamReader

    counts, channels = {}, {}
    with open(path, "rb") as f:
        for record in StreamReader(f).records:
            kind = type(record).__name__
            if kind == "Channel":
                channels[record.id] = record.topic
            elif kind == "Message":
                topic = channels[record.channel_id]
                counts[topic] = counts.get(topic, 0) + 1
    return counts


def plain_write_seconds(directory, size, seconds):
    """Time spent in write() writing `size` bytes sequentially, 1 MiB per write(), spread
    evenly over `seconds` as a recording spreads its chunks, into a new file in `directory`."""
    block = memoryview(os.urandom(1 << 20))
    path = os.path.join(directory, "plain_write.bin")
    writes = max(1, -(-size // len(block)))
    start = time.monotonic()
    busy = 0.0
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        for i in range(writes):
            time.sleep(max(0.0, start + i * seconds / writes - time.monotonic()))
            n = min(len(block), size - i * len(block))
            began = time.perf_counter()
            os.write(fd, block[:n])
            busy += time.perf_counter() - began
    finally:
        os.close(fd)
    os.unlink(path)
    return busy


def run(args):
    directory = Path(args.dir)
    directory.mkdir(parents=True, exist_ok=True)
    server = ln_testing.LnCore(directory, manager_exe=ln_core_manager())
    home = server.home
    env = dict(os.environ, HOME=str(home))
    env.pop("LN_CLI_DEBUG", None)
    started = []

    def spawn(argv, **kw):
        p = subprocess.Popen(
            [str(a) for a in argv], env=env, text=True, stdin=subprocess.PIPE, stdout=subprocess.PIPE, **kw
        )
        started.append(p)
        return p

    server.start([MSGDEFS])
    env["LN_MANAGER"] = server.address
    output = directory / ("%s_%s.mcap" % (args.scenario, args.recorder))
    if output.exists():
        output.unlink()
    try:
        publisher = spawn([sys.executable, __file__, "publish", "--scenario", args.scenario, "--seconds", args.seconds])
        if args.recorder == "ln":
            recorder = spawn(
                [
                    sys.executable,
                    "-m",
                    "links_and_nodes.cli",
                    "record",
                    *topic_names(args.scenario),
                    "-o",
                    output,
                    "--json",
                ],
                stderr=subprocess.DEVNULL,
            )
        else:
            recorder = spawn([sys.executable, __file__, "pyrecord", "--scenario", args.scenario, "--output", output])
        read_line(publisher, "subscribed")
        time.sleep(0.3)  # the recorder's thread settles
        cpu_before = cpu_seconds(recorder.pid)
        publisher.stdin.write("go\n")
        publisher.stdin.flush()
        published = read_line(publisher, "published", timeout=args.seconds + 60)
        cpu = cpu_seconds(recorder.pid) - cpu_before
        time.sleep(1.0)  # the last messages reach the file
        recorder.send_signal(signal.SIGINT)
        out, _ = recorder.communicate(timeout=60)
        summary = json.loads(out) if args.recorder == "ln" and out.strip().startswith("{") else {}
        counts = count_messages(output)
        recorded = sum(counts.values())
        result = {
            "scenario": args.scenario,
            "recorder": args.recorder,
            "published": published["published"],
            "recorded": recorded,
            "lost": published["published"] - recorded,
            "publish_seconds": published["seconds"],
            "recorder_cpu_seconds": cpu,
            "cpu_us_per_message": cpu / max(1, published["published"]) * 1e6,
            "file_bytes": output.stat().st_size,
        }
        if summary:
            result["write_seconds"] = summary["write_seconds"]
            result["write_mb_per_s"] = result["file_bytes"] / max(1e-9, summary["write_seconds"]) / 1e6
            # the same bytes written plainly with the same pacing (a burst would meet page-cache
            # writeback throttling that the recording, spread over seconds, does not)
            output.unlink()  # its pages must not compete with the plain write's
            plain = plain_write_seconds(str(directory), result["file_bytes"], published["seconds"])
            result["plain_write_mb_per_s"] = result["file_bytes"] / max(1e-9, plain) / 1e6
        print(json.dumps(result), flush=True)
    finally:
        for p in reversed(started):
            if p.poll() is None:
                if p.stdin:
                    try:
                        p.stdin.close()
                    except OSError:
                        pass
                p.terminate()
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        server.stop()
        if output.exists():
            output.unlink()
        shutil.rmtree(home, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=("run", "publish", "pyrecord"))
    parser.add_argument("--scenario", choices=sorted(SCENARIOS), required=True)
    parser.add_argument("--recorder", choices=("ln", "python"), default="ln")
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--dir", default="/tmp/lnbagbench")
    parser.add_argument("--output")
    args = parser.parse_args()
    {"run": run, "publish": publish, "pyrecord": pyrecord}[args.mode](args)


if __name__ == "__main__":
    main()
