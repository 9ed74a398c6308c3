"""Topics through the bridge with rclpy peers (Fast DDS): both directions,
field by field, and what the ROS graph shows of the bridge."""

import itertools
import time

from conftest import wait_until

SAMPLE = "bridgetest/sample"


def _sample_config(direction="ln_to_ros", **extra):
    return {"topics": [dict({"ln": "bt.sample", "ros": "/bt/sample", "type": SAMPLE, "direction": direction}, **extra)]}


def test_ln_to_ros_fields(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample

    bridge = start_bridge(_sample_config(), wait=["bridging topic bt.sample"])
    received = []
    ros.node.create_subscription(Sample, "/bt/sample", received.append, 50)
    # for up to 20 s: samples published before DDS discovery matched our subscription are lost
    publisher = ln_peer("lnpub", "publish", "bt.sample", "--count", 2000, "--rate", 100, "--wait-subscriber")
    wait_until(lambda: len(received) >= 20, 30, "20 samples on /bt/sample")
    message = received[-1]
    seq = message.seq
    assert abs(message.vec[0] - seq * 0.5) < 1e-6 and list(message.vec[1:]) == [-1.25, 3.0]
    assert message.small == -seq and message.flags == seq % 256
    assert bytes(message.label).rstrip(b"\0").decode() == "n%d" % seq
    assert abs(message.stamp - time.time()) < 30
    assert all(b.seq > a.seq for a, b in zip(received, received[1:])), "out of order or repeated"
    publisher.stop()
    assert bridge.running()


def test_ros_to_ln_fields(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample

    start_bridge(_sample_config("ros_to_ln"), wait=["bridging topic bt.sample"])
    subscriber = ln_peer("lnsub", "subscribe", "bt.sample", "--count", 10)
    subscriber.wait_event("ready")
    publisher = ros.node.create_publisher(Sample, "/bt/sample", 10)
    wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the bridge subscribing /bt/sample")
    seqs = itertools.count()

    def publish():
        seq = next(seqs)
        publisher.publish(
            Sample(
                seq=seq,
                stamp=1.5 * seq,
                vec=[1.0, 2.0, float(seq)],
                small=-7,
                flags=9,
                label=list(b"ros%d" % seq) + [0] * (16 - len(b"ros%d" % seq)),
            )
        )

    subscriber.feed_until(publish, 10, timeout=30)
    packets = subscriber.wait_event("packet", 10, count=10)
    last = packets[-1]
    assert last["vec"] == [1.0, 2.0, float(last["seq"])] and last["stamp"] == 1.5 * last["seq"]
    assert last["small"] == -7 and last["flags"] == 9 and last["label"] == "ros%d" % last["seq"]


def test_graph_shows_the_bridge(ln, start_bridge, ln_peer, ros):
    """ros2 node list / topic list -t / service list: the bridge's node, topics with types, services."""
    config = _sample_config()
    config["services"] = [{"ln": "bt.compute", "ros": "/bt/compute", "type": "bridgetest/compute"}]
    start_bridge(config, wait=["bridging topic bt.sample", "bridging service bt.compute"])
    node = ros.node
    wait_until(lambda: ("ln_ros2_bridge", "/") in node.get_node_names_and_namespaces(), 20, "the bridge node")
    wait_until(
        lambda: ("/bt/sample", ["bridgetest_ln_msgs/msg/Sample"]) in node.get_topic_names_and_types(),
        20,
        "/bt/sample with its type",
    )
    publishers = node.get_publishers_info_by_topic("/bt/sample")
    assert [(p.node_name, p.topic_type) for p in publishers] == [("ln_ros2_bridge", "bridgetest_ln_msgs/msg/Sample")]
    wait_until(
        lambda: (
            ("/bt/compute", ["bridgetest_ln_msgs/srv/Compute"])
            in node.get_service_names_and_types_by_node("ln_ros2_bridge", "/")
        ),
        20,
        "/bt/compute served",
    )


def test_latched_topic_reaches_late_subscriber(ln, start_bridge, ln_peer, ros):
    """transient_local (the /tf_static pattern): a subscriber that joins after the
    last LN packet still gets it."""
    from bridgetest_ln_msgs.msg import Sample
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    start_bridge(_sample_config(qos="latched"), wait=["bridging topic bt.sample"])
    publisher = ln_peer(
        "lnpub", "publish", "bt.sample", "--count", 3, "--rate", 20, "--wait-subscriber", "--linger", "--duration", 30
    )
    publisher.wait_event("done", 30)
    received = []
    qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    ros.node.create_subscription(Sample, "/bt/sample", received.append, qos)
    wait_until(lambda: received, 20, "the latched sample")
    assert received[-1].seq == 2


def test_rule_mapped_standard_type_both_ways(ln, start_bridge, ln_peer, ros):
    """An LN definition carried as geometry_msgs/msg/PointStamped by a msg_mapping rule file."""
    from pathlib import Path

    from conftest import MANAGER_MD_DIRS
    from geometry_msgs.msg import PointStamped

    here = Path(__file__).resolve().parent
    start_bridge(
        {
            "ln": {"message_definition_dirs": [str(d) for d in MANAGER_MD_DIRS]},
            "rules": [str(here / "rules" / "point.yaml")],
            "topics": [
                {"ln": "bt.point_out", "type": "bridgetest_extra/point"},
                {"ln": "bt.point_in", "type": "bridgetest_extra/point", "direction": "ros_to_ln"},
            ],
        },
        wait=[
            "bridging topic bt.point_out.*geometry_msgs/msg/PointStamped",
            "bridging topic bt.point_in.*geometry_msgs/msg/PointStamped",
        ],
    )
    received = []
    ros.node.create_subscription(PointStamped, "/bt/point_out", received.append, 10)
    ln_peer("lnpub", "publish", "bt.point_out", "--definition", "point", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= 3, 20, "points on /bt/point_out")
    point = received[-1]
    assert point.header.frame_id == "map" and (point.point.y, point.point.z) == (2.0, -3.0)
    assert point.header.stamp.sec >= 100 and abs(point.point.x * 1000 - round(point.point.x * 1000)) < 1e-6

    subscriber = ln_peer("lnsub", "subscribe", "bt.point_in", "--definition", "point", "--count", 3)
    subscriber.wait_event("ready")
    publisher = ros.node.create_publisher(PointStamped, "/bt/point_in", 10)
    wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the bridge subscribing /bt/point_in")
    message = PointStamped()
    message.header.frame_id = "odom"
    message.header.stamp.sec, message.header.stamp.nanosec = 12, 500000000
    message.point.x, message.point.y, message.point.z = 1.5, -0.25, 0.001
    subscriber.feed_until(lambda: publisher.publish(message), 3)
    packet = subscriber.wait_event("packet", 10, count=3)[-1]
    assert packet["time"] == 12.5 and packet["frame"] == "odom"
    assert [round(v, 6) for v in packet["pos_mm"]] == [1500.0, -250.0, 1.0]


def test_both_directions_follow_the_publishing_side(ln, start_bridge, ln_peer, ros):
    """direction: both -- the side with a (non-bridge) publisher feeds the other; when it
    goes and the other side starts publishing, the bridge turns around."""
    from bridgetest_ln_msgs.msg import Sample

    bridge = start_bridge({"auto": {"period": 0.3}, "topics": [{"ln": "bt.both", "type": SAMPLE, "direction": "both"}]})
    received = []
    ros.node.create_subscription(Sample, "/bt/both", received.append, 50)
    publisher = ln_peer("lnpub", "publish", "bt.both", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= 5, 20, "LN -> ROS samples")
    publisher.stop()
    subscriber = ln_peer("lnsub", "subscribe", "bt.both", "--count", 5)
    subscriber.wait_event("ready")
    ros_publisher = ros.node.create_publisher(Sample, "/bt/both", 10)
    bridge.wait_log("stopped bridging topic bt.both \\(ln_to_ros\\)", 20)
    bridge.wait_log("bridging topic bt.both <- /bt/both", 20)
    wait_until(lambda: ros_publisher.get_subscription_count() > 0, 20, "the bridge subscribing /bt/both")
    seqs = itertools.count(1000)
    subscriber.feed_until(lambda: ros_publisher.publish(Sample(seq=next(seqs), label=[0] * 16)), 5)
    assert min(e["seq"] for e in subscriber.wait_event("packet", 10, count=5)) >= 1000


def test_diagnostics_and_rosout(ln, start_bridge, ln_peer, ros):
    """Each entry's state on /diagnostics (rate, forwarded, or why it does not run) and the
    bridge's log lines on /rosout."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rcl_interfaces.msg import Log
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    arrays, logs = [], []
    ros.node.create_subscription(DiagnosticArray, "/diagnostics", arrays.append, 10)
    ros.node.create_subscription(
        Log,
        "/rosout",
        logs.append,
        QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    )
    start_bridge(
        {"topics": [{"ln": "bt.sample", "type": SAMPLE}, {"ln": "bt.broken", "type": "bridgetest/does_not_exist"}]},
        wait=["bridging topic bt.sample"],
    )
    ln_peer("lnpub", "publish", "bt.sample", "--count", 100000, "--rate", 50)

    def statuses():
        latest = {}
        for array in arrays:
            for status in array.status:
                latest[status.name] = status
        return latest

    def running():
        status = statuses().get("ln_ros2_bridge: topic bt.sample -> /bt/sample")
        values = {v.key: v.value for v in status.values} if status else {}
        return status if values and float(values["rate"]) > 10 and int(values["forwarded"]) > 20 else None

    status = wait_until(running, 30, "bt.sample running with a rate on /diagnostics")
    values = {v.key: v.value for v in status.values}
    assert status.level == DiagnosticStatus.OK and values["dropped"] == "0"
    assert values["ln type"] == SAMPLE and values["ros type"] == "bridgetest_ln_msgs/msg/Sample"
    broken = statuses()["ln_ros2_bridge: topic bt.broken -> /bt/broken"]
    assert broken.level == DiagnosticStatus.ERROR and "bridgetest/does_not_exist cannot be loaded" in broken.message
    assert statuses()["ln_ros2_bridge: LN connection"].level == DiagnosticStatus.OK

    wait_until(
        lambda: any(log.name == "ln_ros2_bridge" and log.msg.startswith("bridging topic bt.sample") for log in logs),
        20,
        "the bridge's log line on /rosout",
    )
    assert any(log.level == Log.WARN and "bt.broken" in log.msg for log in logs)
