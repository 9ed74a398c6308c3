"""`ln play`: recordings of `ln record` and ROS 2 bags published into LN topics."""

import json
import signal
import threading
import time

import links_and_nodes as ln
from cli_helpers import ok, one_line_error, run_ln, wait_until
from test_record import EPOCH, Source, fill_pose, finish, start_ln

ROS_EPOCH = 1_700_000_000_000_000_000


class Sink:
    """An LN subscriber (own client) collecting (receive time, LN timestamp, packet fields) in a thread."""

    def __init__(self, topic, md, fields):
        self.client = ln.client("bag_sink")
        self.port = self.client.subscribe(topic, md, buffers=4096)
        self.fields = fields
        self.received = []
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stopped.is_set():
            packet = self.port.read(0.05)
            if packet is not None:
                self.received.append(
                    (time.monotonic(), self.port.timestamp, tuple(_value(packet, f) for f in self.fields))
                )

    def close(self):
        self.stopped.set()
        self.thread.join(10)
        self.client.close()


def _value(packet, path):
    for part in path.split("."):
        packet = getattr(packet, part)
    return packet.tolist() if hasattr(packet, "tolist") else packet  # arrays view the read buffer


def record_poses(manager, topic, path, n=50, rate=100):
    record = start_ln(manager, "record", topic, "-o", path, "--count", str(n), "--duration", "20")
    source = Source(topic, "bagtest/pose", fill_pose, n, rate=rate)
    try:
        source.wait_for_subscriber().start()
        ok(finish(record))
    finally:
        source.close(stop=False)


def test_play_publishes_a_recording_with_its_timing_and_timestamps(manager, unique, tmp_path):
    topic = "bag.%s.pose" % unique
    path = str(tmp_path / "poses.mcap")
    record_poses(manager, topic, path)
    sink = Sink(topic, "bagtest/pose", ("counter", "position.y", "flags"))
    try:
        start = time.monotonic()
        summary = json.loads(ok(run_ln(manager, "play", path, "--rate", "2", "--json")))
        wait_until(lambda: len(sink.received) >= 50, 10, what="50 messages")
        took = time.monotonic() - start
    finally:
        sink.close()
    assert summary["messages"] == 50 and summary["topics"][0]["definition"] == "bagtest/pose"
    assert [r[2][0] for r in sink.received] == list(range(50))
    assert [r[1] for r in sink.received] == [EPOCH + i / 1000.0 for i in range(50)]  # the recorded LN timestamps
    assert sink.received[7][2][1] == -7.0 and list(sink.received[7][2][2]) == [1, -1, 7]
    span = sink.received[-1][0] - sink.received[0][0]
    assert 0.15 < span < 0.5 + 2.0  # 49 periods of 10 ms at twice the speed: about 0.25 s
    assert took < 15


def test_play_topics_start_and_loop(manager, unique, tmp_path):
    first, second = "bag.%s.first" % unique, "bag.%s.second" % unique
    path = str(tmp_path / "two.mcap")
    record = start_ln(manager, "record", first, second, "-o", path, "--count", "80", "--duration", "20")
    sources = [
        Source(first, "bagtest/pose", fill_pose, 40, rate=100),
        Source(second, "bagtest/pose", fill_pose, 40, rate=100),
    ]
    try:
        for s in sources:
            s.wait_for_subscriber()
        for s in sources:
            s.start()
        ok(finish(record))
    finally:
        for s in sources:
            s.close(stop=False)

    sink = Sink(second, "bagtest/pose", ("counter",))
    try:
        summary = json.loads(ok(run_ln(manager, "play", path, "--topics", second, "--start", "0.2", "--json")))
        wait_until(lambda: len(sink.received) >= summary["messages"], 10, what="the messages")
    finally:
        sink.close()
    assert [t["ln_topic"] for t in summary["topics"]] == [second]
    counters = [r[2][0] for r in sink.received]
    assert 10 <= len(counters) <= 25 and counters == list(range(40 - len(counters), 40))  # the last 0.2 s

    sink = Sink(first, "bagtest/pose", ("counter",))
    try:
        player = start_ln(manager, "play", path, "--topics", "/bag/%s/first" % unique, "--loop", "--rate", "4")
        wait_until(lambda: len(sink.received) >= 100, 20, what="a second round")
        player.send_signal(signal.SIGINT)
        result = finish(player)
    finally:
        sink.close()
    assert result.returncode == 0 and "interrupted" in result.stdout
    counters = [r[2][0] for r in sink.received]
    assert counters[:80] == list(range(40)) * 2


def write_ros_bag(path, messages):
    """A rosbag2 bag (MCAP) written by rosbags: messages = [(topic, msgtype, ns, message)]."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, msgtype, stamp, message in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], stamp, store.serialize_cdr(message, msgtype))
    return store


def test_play_a_ros2_bag_of_standard_types_into_their_ln_form(manager, unique, tmp_path):
    from rosbags.typesys import Stores, get_typestore

    import msg_mapping

    store = get_typestore(Stores.ROS2_JAZZY)
    point, text = store.types["geometry_msgs/msg/Point"], store.types["std_msgs/msg/String"]
    bag = str(tmp_path / "ros_bag")
    write_ros_bag(
        bag,
        [
            m
            for i in range(20)
            for m in (
                ("/%s/point" % unique, point.__msgtype__, ROS_EPOCH + i * 10_000_000, point(x=float(i), y=2.0, z=-1.0)),
                ("/%s/name" % unique, text.__msgtype__, ROS_EPOCH + i * 10_000_000 + 1, text(data="n%d" % i)),
            )
        ],
    )

    # The LN node's side: the LN form of the ROS types (ln_ros2_gen --from-ros makes the same definitions).
    ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
    ros.add("geometry_msgs/msg/Point")
    ros.add("std_msgs/msg/String")
    with ln.client("bag_definitions") as c:
        for name, definition in ros.definitions().items():
            c.put_message_definition(name, definition)
    points = Sink("%s.point" % unique, "ros2/geometry_msgs/msg/Point", ("x", "y", "z"))
    names = Sink("%s.name" % unique, "ros2/std_msgs/msg/String", ("data_len", "data"))
    try:
        summary = json.loads(ok(run_ln(manager, "play", bag, "--json")))
        wait_until(lambda: len(points.received) >= 20 and len(names.received) >= 20, 10, what="the messages")
    finally:
        points.close()
        names.close()
    assert summary["messages"] == 40
    assert [r[2] for r in points.received] == [(float(i), 2.0, -1.0) for i in range(20)]
    assert points.received[3][1] == ROS_EPOCH / 1e9 + 0.03
    length, data = names.received[5][2]
    assert length == 2 and data[:length] == "n5"  # char arrays read as text


def test_a_ros2_bag_of_a_generated_type_plays_as_its_ln_definition(manager, unique, tmp_path):
    """A bag recorded in ROS 2 from the bridge (type generated by ln_ros2_gen, no LN metadata) drives
    the LN node that subscribes with the original definition."""
    from conftest import MSGDEFS
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    import ln_bag

    mapping = ln_bag.TopicMapping("bagtest/pose", md_dirs=[MSGDEFS])
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(mapping.schema, mapping.ros_type))
    pose, vec3 = store.types["bagtest_ln_msgs/msg/Pose"], store.types["bagtest_ln_msgs/msg/Vec3"]
    import numpy as np

    def message(i):
        return pose(
            time=i * 0.5,
            position=vec3(x=1.0, y=float(i), z=3.0),
            orientation=np.zeros(4, np.float32),
            counter=i,
            frame=np.frombuffer(b"map".ljust(16, b"\0"), np.uint8),
            flags=np.array([i, 0, 0], np.int8),
        )

    from rosbags.rosbag2 import StoragePlugin, Writer

    bag = str(tmp_path / "from_ros")
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/bag/%s/pose" % unique, mapping.ros_type, typestore=store)
        for i in range(10):
            writer.write(connection, ROS_EPOCH + i * 1_000_000, store.serialize_cdr(message(i), mapping.ros_type))
    sink = Sink("bag.%s.pose" % unique, "bagtest/pose", ("counter", "position.y", "time"))
    try:
        summary = json.loads(ok(run_ln(manager, "play", bag, "--json")))
        wait_until(lambda: len(sink.received) >= 10, 10, what="the messages")
    finally:
        sink.close()
    assert summary["topics"] == [{"ln_topic": "bag.%s.pose" % unique, "definition": "bagtest/pose", "messages": 10}]
    assert [r[2] for r in sink.received] == [(i, float(i), i * 0.5) for i in range(10)]


def test_play_reports_what_it_cannot_play(manager, unique, tmp_path):
    one_line_error(run_ln(manager, "play", str(tmp_path / "missing.mcap")), "missing.mcap", "No such file")
    not_mcap = tmp_path / "notes.txt"
    not_mcap.write_text("hello")
    one_line_error(run_ln(manager, "play", str(not_mcap)), "notes.txt", "is not an MCAP file")

    from mcap.writer import Writer

    odd = str(tmp_path / "json.mcap")
    with open(odd, "wb") as f:
        writer = Writer(f)
        writer.start()
        schema = writer.register_schema("Point", "jsonschema", b"{}")
        channel = writer.register_channel("/%s/json" % unique, "json", schema)
        writer.add_message(channel, log_time=1, publish_time=1, data=b"{}")
        writer.finish()
    result = run_ln(manager, "play", odd)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    note, error = result.stderr.strip().splitlines()
    assert note.startswith("ln play: not playing /%s/json: messages in 'json'" % unique)
    assert error.startswith("ln: error: nothing to play in %s" % odd)
