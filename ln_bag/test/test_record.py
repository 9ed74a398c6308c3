"""`ln record` against a live manager, every file read back with independent
readers (mcap + mcap-ros2-support, rosbags)."""

import json
import os
import resource
import signal
import subprocess
import sys
import threading
import time
from fractions import Fraction

import links_and_nodes as ln
from bag_readers import mcap_messages, mcap_stream, rosbags_messages
from cli_helpers import ok, one_line_error, run_ln, wait_until
from conftest import MSGDEFS

#: A timestamp base far from "now", so publish_time is visibly the LN timestamp.
EPOCH = 1_500_000_000.0


def start_ln(manager, *args, **popen):
    """`ln ARGS...` running in the background (stdout/stderr captured)."""
    env = manager.env()
    env.pop("LN_CLI_DEBUG", None)
    return subprocess.Popen(
        [sys.executable, "-m", "links_and_nodes.cli", *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,
    )


def finish(process, timeout=30):
    out, err = process.communicate(timeout=timeout)
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


class Source:
    """An LN publisher (own client) writing `count` packets at `rate` Hz from a
    thread once started: fill(packet, i), timestamp EPOCH + i / 1000."""

    def __init__(self, topic, md, fill, count, rate=1000.0):
        self.client = ln.client("bag_source")
        self.port = self.client.publish(topic, md)
        self.topic, self.fill, self.count, self.rate = topic, fill, count, rate
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def wait_for_subscriber(self, timeout=15):
        wait_until(self.port.has_subscriber, timeout, what="a subscriber of %s" % self.topic)
        return self

    def start(self):
        self.thread.start()
        return self

    def _run(self):
        start = time.monotonic()
        for i in range(self.count):
            if self.stopped.is_set():
                return
            self.fill(self.port.packet, i)
            self.port.write(EPOCH + i / 1000.0)
            self.stopped.wait(max(0.0, start + (i + 1) / self.rate - time.monotonic()))

    def close(self, stop=True):
        """Stops writing (stop=False: after the last packet), then closes the client."""
        if stop:
            self.stopped.set()
        if self.thread.is_alive():
            self.thread.join(30)
        self.client.close()


def fill_pose(packet, i):
    packet.time = i * 0.01
    packet.position.x, packet.position.y, packet.position.z = i, -i, 0.5
    packet.orientation = [0, 0, 0, 1]
    packet.counter = i
    packet.frame = "base"
    packet.flags = [1, -1, i % 100]


def assert_filled_pose(d, i):
    """`d`, a decoded bagtest/pose, holds what fill_pose(_, i) wrote."""
    assert (d.time, d.counter, d.position.x, d.position.y, d.position.z) == (i * 0.01, i, i, -i, 0.5)
    assert list(d.orientation) == [0, 0, 0, 1] and list(d.flags) == [1, -1, i % 100]
    assert bytes(d.frame) == b"base" + bytes(12)


def fill_counter(packet, i):
    packet.count = i
    packet.stamp = i * 0.001


def readable(path, topic=None):
    """How many messages (of `topic`, a ROS name) a reader finds in the file so far."""
    if not os.path.exists(path):
        return 0
    messages, _ = mcap_stream(path)
    return len([m for m in messages if topic is None or m.topic == topic])


def md_text(name):
    with open(os.path.join(MSGDEFS, name)) as f:
        return f.read()


def test_records_every_message_with_its_ln_definition(manager, unique, tmp_path):
    pose, counter = "bag.%s.pose" % unique, "bag.%s.counter" % unique
    out = str(tmp_path / "two.mcap")
    n = 300
    record = start_ln(manager, "record", pose, counter, "-o", out, "--count", str(2 * n), "--duration", "25", "--json")
    sources = [Source(pose, "bagtest/pose", fill_pose, n), Source(counter, "bagtest/counter", fill_counter, n)]
    try:
        for s in sources:
            s.wait_for_subscriber().start()
        result = finish(record)
    finally:
        for s in sources:
            s.close(stop=False)
    summary = json.loads(ok(result))
    assert summary["messages"] == 2 * n and summary["lost"] == 0 and not summary["interrupted"]

    messages = mcap_messages(out)
    assert len(messages) == 2 * n
    by_topic = {}
    for m in messages:
        by_topic.setdefault(m.topic, []).append(m)
    assert sorted(by_topic) == ["/bag/%s/counter" % unique, "/bag/%s/pose" % unique]

    poses = by_topic["/bag/%s/pose" % unique]
    assert {m.schema for m in poses} == {"bagtest_ln_msgs/msg/Pose"}
    sequences = [m.sequence for m in poses]
    assert sequences == list(range(sequences[0], sequences[0] + n))  # the LN sequence numbers, no gaps
    metadata = poses[0].metadata
    assert metadata["ln.topic"] == pose and metadata["ln.definition"] == "bagtest/pose"
    assert metadata["ln.hash"] == sources[0].port.msg_def_hash
    assert metadata["ln.text"] == md_text("bagtest/pose")
    assert json.loads(metadata["ln.uses"]) == {"bagtest/vec3": md_text("bagtest/vec3")}
    for i, m in enumerate(poses):
        assert m.publish_time == round(Fraction(EPOCH + i / 1000.0) * 10**9)  # the LN timestamp, to the ns
        assert abs(m.log_time / 1e9 - time.time()) < 120  # when it was received
        assert_filled_pose(m.decoded, i)
    counts = [m.decoded.count for m in by_topic["/bag/%s/counter" % unique]]
    assert counts == list(range(n))
    log_times = [m.log_time for m in messages]
    assert min(log_times) <= max(log_times)


def test_duration_and_interrupt_close_the_file_with_its_index(manager, unique, tmp_path):
    topic = "bag.%s.slow" % unique
    source = Source(topic, "bagtest/counter", fill_counter, 10**6, rate=200)
    try:
        timed = str(tmp_path / "timed.mcap")
        start = time.monotonic()
        record = start_ln(manager, "record", topic, "-o", timed, "--duration", "1.5")
        source.wait_for_subscriber().start()
        result = finish(record)
        assert 1.5 <= time.monotonic() - start < 25  # ended by itself (a loaded machine starts it slowly)
        assert "recorded" in ok(result)
        assert 0 < len(mcap_messages(timed)) < 1000  # 300 at 200 Hz for 1.5 s; fewer under load

        interrupted = str(tmp_path / "interrupted.mcap")
        record = start_ln(manager, "record", topic, "-o", interrupted)
        wait_until(lambda: readable(interrupted) >= 50, 30, interval=0.2, what="50 messages in the file")
        record.send_signal(signal.SIGINT)
        result = finish(record)
        assert result.returncode == 0, result.stderr
        count = len(mcap_messages(interrupted))  # the summary and index are there
        assert count >= 50
        assert "recorded %d messages" % count in result.stdout
    finally:
        source.close()


def test_sigkill_leaves_everything_up_to_the_last_chunk_readable(manager, unique, tmp_path):
    topic = "bag.%s.killed" % unique
    out = str(tmp_path / "killed.mcap")
    source = Source(topic, "bagtest/counter", fill_counter, 10**6, rate=500)
    try:
        record = start_ln(manager, "record", topic, "-o", out)
        source.wait_for_subscriber().start()
        # chunks are closed at least every second: wait until more than one is in the file
        wait_until(lambda: readable(out) >= 400, 30, interval=0.2, what="400 messages in the file")
        record.kill()
        record.communicate(timeout=30)
    finally:
        source.close()
    messages, error = mcap_stream(out)
    assert len(messages) >= 400, "only %d messages readable" % len(messages)  # the first second, at least
    counts = [m.decoded.count for m in messages]
    assert counts == list(range(counts[0], counts[0] + len(counts)))
    assert error is None or "EndOfFile" in type(error).__name__ or "unpack" in str(error)

    info = run_ln(manager, "bag", "info", out, "--json")
    assert json.loads(ok(info))["messages"] == len(messages)
    assert "cut off" in info.stderr and out in info.stderr


def test_all_topics_except_excluded_ones_also_those_appearing_later(manager, unique, tmp_path):
    keep, skip, late = ("bag.%s.%s" % (unique, s) for s in ("keep", "skip", "late"))
    out = str(tmp_path / "all.mcap")
    early = [
        Source(keep, "bagtest/counter", fill_counter, 10**6, rate=100),
        Source(skip, "bagtest/counter", fill_counter, 10**6, rate=100),
    ]
    sources = list(early)
    try:
        record = start_ln(
            manager,
            "record",
            "--all",
            "--exclude",
            "*.skip",
            "--exclude",
            "other.*",
            "-o",
            out,
            "--json",
        )
        early[0].wait_for_subscriber().start()  # the recorder has looked at the topics by now
        early[1].start()
        sources.append(Source(late, "bagtest/pose", fill_pose, 10**6, rate=100))
        sources[-1].wait_for_subscriber().start()
        late_ros = "/bag/%s/late" % unique
        wait_until(lambda: readable(out, late_ros), 30, interval=0.2, what="messages of %s in the file" % late)
        record.send_signal(signal.SIGINT)
        summary = json.loads(ok(finish(record)))
    finally:
        for s in sources:
            s.close()
    recorded = {t["topic"]: t for t in summary["topics"]}
    assert skip not in recorded and keep in recorded and late in recorded
    assert recorded[late]["messages"] > 0 and recorded[late]["type"] == "bagtest_ln_msgs/msg/Pose"
    topics = {m.topic for m in mcap_messages(out)}
    assert topics == {"/bag/%s/keep" % unique, "/bag/%s/late" % unique}


def test_rosbag2_directory_opens_with_rosbags(manager, unique, tmp_path):
    topic = "bag.%s.ros" % unique
    bag = str(tmp_path / "bag_dir")
    source = Source(topic, "bagtest/pose", fill_pose, 50)
    try:
        record = start_ln(manager, "record", topic, "--rosbag2", bag, "--count", "50", "--duration", "20")
        source.wait_for_subscriber().start()
        ok(finish(record))
    finally:
        source.close(stop=False)
    assert sorted(os.listdir(bag)) == ["bag_dir_0.mcap", "metadata.yaml"]
    messages = rosbags_messages(bag)
    assert [(t, ty) for t, ty, _, _ in messages] == [("/bag/%s/ros" % unique, "bagtest_ln_msgs/msg/Pose")] * 50
    assert [m.counter for _, _, _, m in messages] == list(range(50))
    assert messages[7][3].position.y == -7.0 and list(messages[7][3].flags) == [1, -1, 7]
    info = json.loads(ok(run_ln(manager, "bag", "info", bag, "--json")))
    assert info["messages"] == 50 and info["topics"][0]["ln_topic"] == topic


def test_refuses_to_overwrite_and_reports_bad_arguments(manager, unique, tmp_path):
    existing = tmp_path / "old.mcap"
    existing.write_bytes(b"precious")
    one_line_error(run_ln(manager, "record", "a.b", "-o", str(existing)), str(existing), "already exists")
    assert existing.read_bytes() == b"precious"
    one_line_error(run_ln(manager, "record", "-o", str(tmp_path / "x.mcap")), "no topics", "--all")
    one_line_error(
        run_ln(manager, "record", "a.b", "-o", str(tmp_path / "y.mcap"), "--rosbag2", str(tmp_path / "d")), "not both"
    )
    (tmp_path / "d").mkdir()
    one_line_error(run_ln(manager, "record", "a.b", "--rosbag2", str(tmp_path / "d")), "already exists")
    one_line_error(
        run_ln(manager, "record", "a.b", "-o", str(tmp_path / "no" / "dir.mcap"), "--count", "1"),
        "cannot create",
        "no/dir.mcap",
    )
    unreachable = run_ln(manager, "record", "a.b", "-o", str(tmp_path / "z.mcap"), "--ln-manager", "127.0.0.1:1")
    one_line_error(unreachable, "cannot reach the ln_manager at 127.0.0.1:1")
    assert not (tmp_path / "z.mcap").exists()


def test_a_full_disk_ends_the_recording_with_a_clear_error_and_keeps_the_file(manager, unique, tmp_path):
    topic = "bag.%s.big" % unique
    out = str(tmp_path / "limited.mcap")
    limit = 3 << 20  # a file-size limit stands in for a full disk

    def limit_file_size():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    source = Source(topic, "bagtest/image", lambda p, i: setattr(p, "seq", i), 10**6, rate=200)
    try:
        record = start_ln(manager, "record", topic, "-o", out, "--duration", "20", preexec_fn=limit_file_size)
        source.wait_for_subscriber().start()
        result = finish(record)
    finally:
        source.close()
    line = one_line_error(result, out, "File too large")
    assert "keeps the" in line
    assert os.path.getsize(out) <= limit
    messages, _ = mcap_stream(out)
    assert len(messages) > 10
    seqs = [m.decoded.seq for m in messages]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))


def test_a_topic_without_ros_type_is_named_and_the_others_are_recorded(manager, unique, tmp_path):
    good, clash = "bag.%s.good" % unique, "bag.%s.clash" % unique
    out = str(tmp_path / "partly.mcap")
    sources = [
        Source(good, "bagtest/counter", fill_counter, 10**6, rate=100),
        Source(clash, "bagtest/clash", lambda p, i: None, 10**6, rate=100),
    ]
    try:
        record = start_ln(manager, "record", good, clash, "-o", out, "--duration", "2", "--json")
        sources[0].wait_for_subscriber().start()
        sources[1].start()
        result = finish(record)
    finally:
        for s in sources:
            s.close()
    summary = json.loads(ok(result))
    why = summary["not_recorded"][clash]
    assert "'bagtest/clash'" in why and "num_counts" in why
    assert "ln record: not recording topic '%s': " % clash in result.stderr
    assert {m.topic for m in mcap_messages(out)} == {"/bag/%s/good" % unique}
