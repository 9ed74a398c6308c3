"""Automatic mode: endpoints follow LN publishers/providers and ROS peers as
they come and go; filters; unknown types; two bridges without echo."""

import itertools
import time

from conftest import ln_core_probe, ln_snapshot, wait_until

AUTO = {"auto": {"enabled": True, "period": 0.3}}


def ros_publishers(ros, topic):
    return [(p.node_name, p.topic_type) for p in ros.node.get_publishers_info_by_topic(topic)]


def served_by(ros, node_name, service):
    try:
        return any(name == service for name, _ in ros.node.get_service_names_and_types_by_node(node_name, "/"))
    except Exception:  # the node is not (yet) known
        return False


def test_topics_follow_ln_publishers(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample

    start_bridge(AUTO)
    received = []
    ros.node.create_subscription(Sample, "/bt/auto", received.append, 50)
    publisher = ln_peer("lnpub", "publish", "bt.auto", "--count", 100000, "--rate", 50)
    wait_until(
        lambda: ros_publishers(ros, "/bt/auto") == [("ln_ros2_bridge", "bridgetest_ln_msgs/msg/Sample")],
        20,
        "the bridge publishing /bt/auto",
    )
    wait_until(lambda: len(received) >= 5, 20, "samples on /bt/auto")
    publisher.stop()
    wait_until(lambda: ros_publishers(ros, "/bt/auto") == [], 20, "/bt/auto to lose its bridge publisher")
    publisher = ln_peer("lnpub", "publish", "bt.auto", "--count", 100000, "--rate", 50)  # and back again
    count = len(received)
    wait_until(lambda: len(received) >= count + 5, 20, "samples after the LN publisher returned")


def test_services_follow_ln_providers(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.srv import Compute

    bridge = start_bridge(AUTO)
    provider = ln_peer("lnsrv", "provide", "bt.acompute")
    provider.wait_event("ready")
    wait_until(lambda: served_by(ros, "ln_ros2_bridge", "/bt/acompute"), 20, "/bt/acompute on ROS")
    client = ros.node.create_client(Compute, "/bt/acompute")
    assert client.wait_for_service(timeout_sec=20)
    assert ros.call(client, Compute.Request(a=1, values=[2.0], op="sum")).result == 3.0
    provider.stop()
    wait_until(lambda: not served_by(ros, "ln_ros2_bridge", "/bt/acompute"), 20, "/bt/acompute to go away")
    assert bridge.running()


def test_ln_changes_reach_ros_at_once(ln, start_bridge, ln_peer, ros):
    """With auto.period ten minutes away, an LN publisher or provider leaving, and coming
    back, changes the ROS side within seconds: the manager reports it, the bridge does
    not wait for its next pass."""

    def ros_side():
        return bool(ros_publishers(ros, "/bt/prompt")), served_by(ros, "ln_ros2_bridge", "/bt/prompt_srv")

    def start_ln_side():
        peers = (
            ln_peer("lnpub", "publish", "bt.prompt", "--count", 100000, "--rate", 20),
            ln_peer("lnsrv", "provide", "bt.prompt_srv"),
        )
        for peer in peers:
            peer.wait_event("ready")
        return peers

    peers = start_ln_side()
    start_bridge({"auto": {"enabled": True, "period": 600.0}})
    wait_until(lambda: ros_side() == (True, True), 20, "the bridge's first pass bridging both")
    for peer in peers:
        peer.stop()
    # well within the 600 s period, with room for a loaded machine
    wait_until(lambda: ros_side() == (False, False), 30, "both to leave ROS after the LN side left")
    start_ln_side()
    wait_until(lambda: ros_side() == (True, True), 30, "both back on ROS")
    if ln.kind == "ln_core":  # and it asks the manager on its one LN connection
        probe = ln_core_probe(ln)
        try:
            clients = [c.name for c in probe.list_clients()]
        finally:
            probe.close()
        assert [c for c in clients if c.startswith("ln_ros2_bridge") and c != probe.name] == ["ln_ros2_bridge"], clients


def test_ros_publishers_and_servers_appear_in_ln(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample
    from bridgetest_ln_msgs.srv import Compute

    bridge = start_bridge(AUTO)
    publisher = ros.node.create_publisher(Sample, "/bt/from_ros", 10)
    # (on LN 2.9 by the bridge's data client, which the manager names "ln_ros2_bridge 1")
    wait_until(
        lambda: any(t.name == "bt.from_ros" and t.publisher.startswith("ln_ros2_bridge") for t in ln_snapshot(ln)[0]),
        20,
        "LN topic bt.from_ros published by the bridge",
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.from_ros", "--count", 5)
    subscriber.wait_event("ready")
    seqs = itertools.count()
    subscriber.feed_until(lambda: publisher.publish(Sample(seq=next(seqs), label=[0] * 16)), 5)
    subscriber.wait_event("done", 10)

    ros.node.create_service(Compute, "/bt/from_ros_srv", lambda req, resp: Compute.Response(result=42.0))
    bridge.wait_log("bridging service bt.from_ros_srv", 20)
    wait_until(lambda: any(s.name == "bt.from_ros_srv" for s in ln_snapshot(ln)[1]), 20, "LN service bt.from_ros_srv")
    caller = ln_peer("lncall", "call", "bt.from_ros_srv", "--request", '{"a": 0, "values": [], "op": ""}')
    (answer,) = caller.wait_event("response", 20)
    assert answer["result"] == 42.0

    ros.node.destroy_publisher(publisher)
    wait_until(
        lambda: not any(t.name == "bt.from_ros" and t.publisher for t in ln_snapshot(ln)[0]),
        20,
        "LN topic bt.from_ros to lose its publisher",
    )


def test_filters_and_unknown_types(ln, start_bridge, ln_peer, ros):
    bridge = start_bridge({"auto": {"enabled": True, "period": 0.3, "topics": {"deny": ["bt.hidden*"]}}})
    ln_peer("lnpub1", "publish", "bt.hidden_one", "--count", 100000, "--rate", 20)
    ln_peer("lnpub2", "publish", "bt.unmapped", "--definition", "unmapped", "--count", 100000, "--rate", 20)
    ln_peer("lnpub3", "publish", "bt.visible", "--count", 100000, "--rate", 20)
    wait_until(lambda: ros_publishers(ros, "/bt/visible"), 20, "/bt/visible bridged")
    bridge.wait_log(r"bt.unmapped: LN definition bridgetest_extra/unmapped has no generated ROS interface", 20)
    assert ros_publishers(ros, "/bt/hidden_one") == []
    assert ros_publishers(ros, "/bt/unmapped") == []
    assert bridge.running()
    text = bridge.text()
    assert text.count("bridgetest_extra/unmapped has no generated") == 1, "reported more than once"


def test_two_bridges_do_not_echo_or_duplicate(ln, start_bridge, ln_peer, ros, bridge_loops):
    from bridgetest_ln_msgs.msg import Sample

    config = {"auto": {"enabled": True, "period": 0.3}}
    start_bridge(
        config, name="bridge_a", extra_args=["--node-name", "ln_ros2_bridge_a", "--ln-client-name", "ln_ros2_bridge_a"]
    )
    start_bridge(
        config, name="bridge_b", extra_args=["--node-name", "ln_ros2_bridge_b", "--ln-client-name", "ln_ros2_bridge_b"]
    )
    received = []
    ros.node.create_subscription(Sample, "/bt/twice", received.append, 100)
    ln_peer("lnpub", "publish", "bt.twice", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= 20, 20, "samples on /bt/twice")
    # Both bridges run several reconciliation passes, over more than Bridge.SETTLE: a duplicate
    # or an echo would have appeared by now.
    bridge_loops.wait_passes(["ln_ros2_bridge_a", "ln_ros2_bridge_b"])
    assert len(ros_publishers(ros, "/bt/twice")) == 1, ros_publishers(ros, "/bt/twice")
    seqs = [m.seq for m in received]
    assert len(seqs) == len(set(seqs)), "duplicated samples on ROS"
    topics, _ = ln_snapshot(ln)
    assert [t.name for t in topics if t.name.startswith("bt.")] == ["bt.twice"], topics

    # ROS -> LN: one bridge publishes into LN, nothing comes back to ROS
    publisher = ros.node.create_publisher(Sample, "/bt/ros_side", 10)
    wait_until(
        lambda: any(t.name == "bt.ros_side" and t.publisher.startswith("ln_ros2_bridge_") for t in ln_snapshot(ln)[0]),
        20,
        "bt.ros_side in LN",
    )
    for seq in range(20):
        publisher.publish(Sample(seq=seq, label=[0] * 16))
        time.sleep(0.01)  # a publisher at 100 Hz
    bridge_loops.wait_passes(["ln_ros2_bridge_a", "ln_ros2_bridge_b"])  # an echo would have appeared by now
    assert ros_publishers(ros, "/bt/ros_side") == [(ros.node.get_name(), "bridgetest_ln_msgs/msg/Sample")]


def packets(subscriber):
    return [e for e in subscriber.events() if e["event"] == "packet"]


def ros_label(text):
    data = list(text.encode())
    return data + [0] * (16 - len(data))


def test_messages_from_bridge_publishers_are_not_bridged_back(ln, start_bridge, ln_peer, ros):
    """Bridge A carries LN bt.x to ROS /bt/x; bridge B is told to carry ROS /bt/x into LN
    bt.y. B drops what A publishes -- per publisher: when a plain ROS node publishes on
    /bt/x too, B forwards exactly that node's messages, while A keeps publishing."""
    from bridgetest_ln_msgs.msg import Sample

    start_bridge(
        {"topics": [{"ln": "bt.x", "type": "bridgetest/sample"}]},
        name="bridge_a",
        extra_args=["--node-name", "ln_ros2_bridge_a", "--ln-client-name", "ln_ros2_bridge_a"],
        wait=["bridging topic bt.x"],
    )
    bridge_b = start_bridge(
        {"topics": [{"ln": "bt.y", "ros": "/bt/x", "type": "bridgetest/sample", "direction": "ros_to_ln"}]},
        name="bridge_b",
        extra_args=["--node-name", "ln_ros2_bridge_b", "--ln-client-name", "ln_ros2_bridge_b"],
        wait=["bridging topic bt.y"],
    )
    from_ros = []
    ros.node.create_subscription(Sample, "/bt/x", from_ros.append, 50)
    subscriber = ln_peer("lnsub", "subscribe", "bt.y", "--count", 10)
    subscriber.wait_event("ready")
    ln_peer("lnpub", "publish", "bt.x", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(from_ros) >= 25, 20, "bridge A's samples on /bt/x")
    assert packets(subscriber) == [], "bridge B re-bridged bridge A's data"
    last_of_a = max(m.seq for m in from_ros)

    publisher = ros.node.create_publisher(Sample, "/bt/x", 10)
    wait_until(lambda: publisher.get_subscription_count() >= 2, 20, "bridge B matching our publisher")
    deadline = time.monotonic() + 20
    seq = 90000
    while time.monotonic() < deadline and len(packets(subscriber)) < 10:
        publisher.publish(Sample(seq=seq, label=ros_label("ros%d" % seq)))
        seq += 1
        time.sleep(0.02)
    received = subscriber.wait_event("packet", 10, count=10)
    assert [p["label"] for p in received if not p["label"].startswith("ros")] == [], (
        "bridge B forwarded bridge A's messages"
    )
    assert all(p["seq"] >= 90000 for p in received)
    assert any(last_of_a < m.seq < 90000 for m in from_ros), "bridge A stopped publishing meanwhile"
    assert "without the sender of each message" not in bridge_b.text()
