"""Robustness: bad configuration, unknown types, the LN manager restarting,
LN and ROS peers coming and going -- the bridge reports, recovers, never dies."""

import os
import subprocess
import sys

import pytest
from conftest import MANAGER_MD_DIRS, wait_until


def run_check(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "ln_ros2_bridge", "--config", str(path), "--check"],
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "topics: [{ln: a.b, direction: sideways}]",
            "topic a.b: 'direction' must be one of ln_to_ros, ros_to_ln, both",
        ),
        ("topics: [{ln: a.b, qos: {depth: 0}}]", "'depth': must be 1..100000"),
        ("topics: [{ln: a.b, ros: '/1bad'}]", "invalid ROS name '/1bad'"),
        ("topics: [{ln: a.b, colour: red}]", "unknown key(s) colour"),
        ("topics: [{ln: a.b, direction: ros_to_ln}]", "needs 'type'"),
        ("services: [{ln: s, timeout: -1}]", "'timeout': must be > 0"),
        ("ln: {client_name: my_bridge}\ntopics: [{ln: a}]", "must match loop_prevention.bridge_names"),
        ("topics: [{ln: a}, {ln: a}]", "a is bridged twice"),
        ("{}", "nothing to bridge"),
        ("topics: [oops", "is not valid YAML"),
        (
            "topics: [{ln: a, type: std_srvs/srv/Trigger}]",
            "topic a: 'type' 'std_srvs/srv/Trigger' is a ROS service type; a topic needs a message type",
        ),
        (
            "services: [{ln: s, type: std_msgs/msg/String}]",
            "service s: 'type' 'std_msgs/msg/String' is a ROS message type",
        ),
        (
            "topics: [{ln: a, type: robot/state, capacities: {name: 3}}]",
            "topic a: 'capacities' key 'name' must name the ROS type: 'package/msg/Type.name' (or give the entry a ROS type)",
        ),
        (
            "topics: [{ln: a, type: sensor_msgs/msg/JointState, capacities: {name: 0}}]",
            "'capacities' name must be an integer 1..16777216, not 0",
        ),
        (
            "topics: [{ln: a, type: sensor_msgs/msg/JointState, capacities: {name: 4}},"
            " {ln: b, type: sensor_msgs/msg/JointState, capacities: {name: 8}}]",
            "topic b: capacity of sensor_msgs/msg/JointState.name is 8 here but 4 in topic a",
        ),
        ("defaults: {capacities: {frame_id: 3}}\ntopics: [{ln: a}]", "defaults: 'capacities' key 'frame_id' must name"),
    ],
)
def test_bad_configuration_is_a_clear_error(tmp_path, text, message):
    result = run_check(tmp_path, text)
    assert result.returncode == 2, result
    assert "configuration error" in result.stderr and message in result.stderr, result.stderr
    assert "bad.yaml" in result.stderr and "Traceback" not in result.stderr


def test_good_configuration_checks(tmp_path):
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "config" / "example.yaml"
    result = subprocess.run(
        [sys.executable, "-m", "ln_ros2_bridge", "--config", str(example), "--check"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0 and "is valid" in result.stdout, result


FASTDDS_CHILD = """
import rclpy
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node("profile_check")
publisher = node.create_publisher(String, "/profile_check", 10)
publisher.publish(String(data="x"))
node.destroy_node()
rclpy.shutdown()
print("participant, writer and sample made")
"""


def test_the_bridges_fastdds_profile_loads_without_errors():
    """Fast DDS drops a whole profile file over one unknown element (printing an XMLPARSER
    error and going on with its defaults), so a typo would silently cost the bridge its
    32 MiB segment and its writer timing."""
    from ln_ros2_bridge.main import FASTDDS_PROFILE

    env = dict(os.environ, RMW_IMPLEMENTATION="rmw_fastrtps_cpp", FASTRTPS_DEFAULT_PROFILES_FILE=FASTDDS_PROFILE)
    env.pop("FASTDDS_DEFAULT_PROFILES_FILE", None)
    result = subprocess.run([sys.executable, "-c", FASTDDS_CHILD], capture_output=True, text=True, timeout=60, env=env)
    assert result.returncode == 0 and "sample made" in result.stdout, result
    output = result.stdout + result.stderr  # (Fast DDS logs its errors on standard output)
    assert "XMLPARSER" not in output and "Error" not in output, output


def test_unknown_type_is_reported_and_skipped(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample

    bridge = start_bridge(
        {
            "topics": [
                {"ln": "bt.unmapped", "type": "bridgetest_extra/unmapped"},
                {"ln": "bt.nosuch", "type": "bridgetest/does_not_exist"},
                {"ln": "bt.ok", "type": "bridgetest/sample"},
            ]
        },
        wait=["bridging topic bt.ok"],
    )
    bridge.wait_log("bt.unmapped: LN definition bridgetest_extra/unmapped has no generated ROS interface.*not bridged")
    bridge.wait_log("bt.nosuch: LN definition bridgetest/does_not_exist cannot be loaded")
    received = []
    ros.node.create_subscription(Sample, "/bt/ok", received.append, 10)
    ln_peer("lnpub", "publish", "bt.ok", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= 5, 20, "samples on /bt/ok")
    assert bridge.running()


def test_ln_manager_restart(ln, start_bridge, ln_peer, ros):
    """The manager goes away and comes back on the same address: the bridge
    notices, reconnects and carries the topic (and service) again."""
    from bridgetest_ln_msgs.msg import Sample

    bridge = start_bridge(
        {"topics": [{"ln": "bt.sample", "type": "bridgetest/sample"}], "auto": {"period": 0.3}},
        wait=["bridging topic bt.sample"],
    )
    received = []
    ros.node.create_subscription(Sample, "/bt/sample", received.append, 50)
    publisher = ln_peer("lnpub", "publish", "bt.sample", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= 5, 20, "samples before the restart")
    port = ln.port
    ln.stop(keep_daemons=False)
    publisher.stop()
    bridge.wait_log("LN (connection lost|manager unreachable)", 20)
    ln.start([str(d) for d in MANAGER_MD_DIRS], port=port)
    bridge.wait_log("connected to the LN manager.*\n(.*\n)*.*connected to the LN manager", 30)
    count = len(received)
    ln_peer("lnpub", "publish", "bt.sample", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(received) >= count + 5, 30, "samples after the restart")
    assert bridge.running()


def test_ln_publisher_and_provider_come_and_go(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample
    from bridgetest_ln_msgs.srv import Compute

    start_bridge(
        {
            "topics": [{"ln": "bt.sample", "type": "bridgetest/sample"}],
            "services": [{"ln": "bt.compute", "type": "bridgetest/compute", "timeout": 2.0}],
        },
        wait=["bridging topic bt.sample", "bridging service bt.compute"],
    )
    received = []
    ros.node.create_subscription(Sample, "/bt/sample", received.append, 50)
    client = ros.node.create_client(Compute, "/bt/compute")
    assert client.wait_for_service(timeout_sec=20)
    for round_ in range(2):
        publisher = ln_peer("lnpub", "publish", "bt.sample", "--count", 100000, "--rate", 50)
        provider = ln_peer("lnsrv", "provide", "bt.compute")
        provider.wait_event("ready")
        count = len(received)
        wait_until(lambda: len(received) >= count + 5, 20, "samples in round %d" % round_)
        assert ros.call(client, Compute.Request(a=round_, values=[1.0], op="sum")).result == 1.0 + round_
        publisher.stop()
        provider.stop()
        response = ros.call(client, Compute.Request(a=0, values=[], op="sum"))
        assert response.error_code != 0, "expected an error answer with no LN provider"


def test_ros_peers_come_and_go(ln, start_bridge, ln_peer, ros):
    from bridgetest_ln_msgs.msg import Sample
    from bridgetest_ln_msgs.srv import Compute

    start_bridge(
        {
            "topics": [{"ln": "bt.in", "type": "bridgetest/sample", "direction": "ros_to_ln"}],
            "services": [{"ln": "bt.rsrv", "type": "bridgetest/compute", "direction": "ros_to_ln", "timeout": 2.0}],
        },
        wait=["bridging topic bt.in", "bridging service bt.rsrv"],
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.in", "--count", 1000)
    subscriber.wait_event("ready")
    for round_ in range(2):
        publisher = ros.node.create_publisher(Sample, "/bt/in", 10)
        server = ros.node.create_service(Compute, "/bt/rsrv", lambda req, resp: Compute.Response(result=7.0 + round_))
        wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the bridge matching the publisher")
        before = len(subscriber.events_named("packet"))
        subscriber.feed_until(lambda: publisher.publish(Sample(seq=round_, label=[0] * 16)), before + 5)
        assert len(subscriber.events_named("packet")) >= before + 5
        for _ in range(20):  # until the bridge's client has discovered this server
            caller = ln_peer("lncall", "call", "bt.rsrv", "--request", '{"a": 0, "values": [], "op": ""}')
            event = caller.wait_event("response", 20) if "response" in _events_of(caller) else None
            if event:
                assert event[0]["result"] == 7.0 + round_
                break
        else:
            pytest.fail("the LN caller never got the ROS server's answer")
        ros.node.destroy_publisher(publisher)
        ros.node.destroy_service(server)
        caller = ln_peer("lncall", "call", "bt.rsrv", "--request", '{"a": 0, "values": [], "op": ""}')
        assert "error" in _events_of(caller), "expected an LN error with the ROS server gone"


def _events_of(proc, timeout=20):
    """The set of event names once the peer finished (it always ends with one)."""
    wait_until(lambda: not proc.running(), timeout, "%s to finish" % proc.name)
    return {e["event"] for e in proc.events()}
