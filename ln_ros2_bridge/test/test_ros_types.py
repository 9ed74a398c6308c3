"""Standard ROS types with nothing generated: an entry names a ROS type, LN gets
the definition msg_mapping derives from it (ros2/<pkg>/msg/<Type>, capacities
for unbounded strings and sequences), in both directions, for topics and
services, and in automatic mode."""

import time

from conftest import ln_snapshot, wait_until


def packets(subscriber):
    return [e for e in subscriber.events() if e["event"] == "packet"]


def publish_until(publisher, make, subscriber, count, timeout=20):
    """Publishes make(i) every 20 ms until the LN subscriber got `count` packets."""
    deadline = time.monotonic() + timeout
    i = 0
    while time.monotonic() < deadline and len(packets(subscriber)) < count:
        publisher.publish(make(i))
        i += 1
        time.sleep(0.02)
    return subscriber.wait_event("packet", 10, count=count)


def test_standard_message_types_both_ways(ln, start_bridge, ln_peer, ros):
    """geometry_msgs/msg/Twist from ROS into LN, sensor_msgs/msg/JointState (an array
    of strings: its joint names) from LN to ROS."""
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import JointState

    start_bridge(
        {
            "topics": [
                {"ln": "bt.cmd_vel", "ros": "/bt/cmd_vel", "type": "geometry_msgs/msg/Twist", "direction": "ros_to_ln"},
                {
                    "ln": "bt.joints",
                    "ros": "/bt/joints",
                    "type": "sensor_msgs/msg/JointState",
                    "capacities": {"name": 8, "name[]": 32, "position": 8, "velocity": 8, "effort": 8},
                },
            ]
        },
        wait=[
            "bridging topic bt.cmd_vel <- /bt/cmd_vel .ros2/geometry_msgs/msg/Twist",
            "bridging topic bt.joints -> /bt/joints .ros2/sensor_msgs/msg/JointState",
        ],
    )

    subscriber = ln_peer("lnsub", "subscribe", "bt.cmd_vel", "--definition", "twist", "--count", 3)
    subscriber.wait_event("ready")
    publisher = ros.node.create_publisher(Twist, "/bt/cmd_vel", 10)
    wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the bridge subscribing /bt/cmd_vel")

    def twist(i):
        message = Twist()
        message.linear.x, message.linear.y, message.angular.z = 0.5 + i, -1.0, 0.25
        return message

    received = publish_until(publisher, twist, subscriber, 3)[-1]
    assert received["linear"][1:] == [-1.0, 0.0] and received["linear"][0] >= 0.5
    assert received["angular_z"] == 0.25

    states = []
    ros.node.create_subscription(JointState, "/bt/joints", states.append, 10)
    ln_peer("lnpub", "publish", "bt.joints", "--definition", "joint_state", "--count", 100000, "--rate", 50)
    wait_until(lambda: len(states) >= 3, 20, "joint states on /bt/joints")
    state = states[-1]
    assert list(state.name) == ["joint_0", "joint_1", "joint_2"] and state.header.frame_id == "base"
    assert list(state.position) == [state.header.stamp.sec + 0.25 * i for i in range(3)]
    assert list(state.velocity) == [] and list(state.effort) == []


def test_standard_service_type_both_ways(ln, start_bridge, ln_peer, ros):
    """std_srvs/srv/Trigger: a ROS server called from LN, an LN provider called from ROS."""
    from std_srvs.srv import Trigger

    start_bridge(
        {
            "services": [
                {
                    "ln": "bt.trigger_ros",
                    "ros": "/bt/trigger_ros",
                    "type": "std_srvs/srv/Trigger",
                    "direction": "ros_to_ln",
                    "timeout": 8.0,
                },
                {"ln": "bt.trigger_ln", "ros": "/bt/trigger_ln", "type": "std_srvs/srv/Trigger"},
            ]
        },
        wait=["bridging service bt.trigger_ros", "bridging service bt.trigger_ln"],
    )
    calls = []

    def on_trigger(request, response):
        calls.append(request)
        response.success, response.message = True, "triggered in ROS"
        return response

    ros.node.create_service(Trigger, "/bt/trigger_ros", on_trigger)
    # the bridge waits for discovery of the server within the entry's timeout (8 s)
    caller = ln_peer("lncall", "call", "bt.trigger_ros", "--definition", "trigger", "--timeout", 15)
    (event,) = caller.wait_event("response", 30)
    assert (event["success"], event["message"]) == (1.0, "triggered in ROS") and calls

    provider = ln_peer("lnsrv", "provide", "bt.trigger_ln", "--definition", "trigger")
    provider.wait_event("ready")
    client = ros.node.create_client(Trigger, "/bt/trigger_ln")
    assert client.wait_for_service(timeout_sec=20)
    response = ros.call(client, Trigger.Request())
    assert response.success and response.message.startswith("triggered in LN by lnsrv")


def test_automatic_mode_bridges_any_installed_type(ln, start_bridge, ln_peer, ros):
    """/chatter (std_msgs/msg/String) and a std_srvs/srv/Trigger server appear in LN."""
    from std_msgs.msg import String
    from std_srvs.srv import Trigger

    bridge = start_bridge(
        {"auto": {"enabled": True, "period": 0.3, "topics": {"allow": ["bt.*"]}, "services": {"allow": ["bt.*"]}}}
    )
    publisher = ros.node.create_publisher(String, "/bt/chatter", 10)
    ros.node.create_service(Trigger, "/bt/reset", lambda req, resp: Trigger.Response(success=True, message="reset"))
    wait_until(
        lambda: any(t.name == "bt.chatter" and t.md_name == "ros2/std_msgs/msg/String" for t in ln_snapshot(ln)[0]),
        20,
        "LN topic bt.chatter",
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.chatter", "--definition", "string", "--count", 3)
    subscriber.wait_event("ready")
    received = publish_until(publisher, lambda i: String(data="hello %d" % i), subscriber, 3)
    assert all(p["data"].startswith("hello ") for p in received)

    wait_until(
        lambda: any(s.name == "bt.reset" and s.interface == "ros2/std_srvs/srv/Trigger" for s in ln_snapshot(ln)[1]),
        20,
        "LN service bt.reset",
    )
    caller = ln_peer("lncall", "call", "bt.reset", "--definition", "trigger", "--timeout", 10)
    (answer,) = caller.wait_event("response", 30)
    assert answer["success"] == 1.0 and answer["message"] == "reset"
    assert "has no LN counterpart" not in bridge.text()


def test_bad_types_and_capacities_are_reported_per_entry(ln, start_bridge, ln_peer, ros):
    """A ROS type that is not installed, and ROS messages beyond an LN capacity: an
    error naming the entry (and the field); everything else keeps running."""
    from sensor_msgs.msg import JointState

    bridge = start_bridge(
        {
            "topics": [
                {"ln": "bt.nope", "type": "nope_msgs/msg/Nothing", "direction": "ros_to_ln"},
                {
                    "ln": "bt.js_in",
                    "ros": "/bt/js_in",
                    "type": "sensor_msgs/msg/JointState",
                    "direction": "ros_to_ln",
                    "capacities": {"name": 4},
                },
            ]
        },
        wait=["bridging topic bt.js_in"],
    )
    bridge.wait_log(
        r"topic bt.nope: ROS type nope_msgs/msg/Nothing cannot be mapped to LN: unknown ROS message "
        r"type 'nope_msgs/msg/Nothing'.*not bridged"
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.js_in", "--definition", "joint_state", "--count", 3)
    subscriber.wait_event("ready")
    publisher = ros.node.create_publisher(JointState, "/bt/js_in", 10)
    wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the bridge subscribing /bt/js_in")
    too_many = JointState(name=["j%d" % i for i in range(6)])
    for _ in range(5):
        publisher.publish(too_many)
    bridge.wait_log(
        r"ROS topic /bt/js_in -> LN bt.js_in: dropped \d+ messages?: .*name: sequence of 6 elements "
        r"does not fit the LN capacity 4 .*capacities",
        20,
    )
    received = publish_until(publisher, lambda i: JointState(name=["a", "b"], position=[float(i), 1.0]), subscriber, 3)
    assert received[-1]["names"] == ["a", "b"]
    assert bridge.running()


def test_a_derived_definition_the_manager_has_otherwise_is_an_error_naming_the_entry(ln, start_bridge):
    """One LN definition per ROS type: a bridge that derives std_msgs/msg/String with another
    capacity than the one the LN manager already has (from another bridge) reports its entry
    and leaves the manager's definition alone."""
    start_bridge(
        {"topics": [{"ln": "bt.text_a", "type": "std_msgs/msg/String"}]},
        name="bridge_a",
        extra_args=["--node-name", "ln_ros2_bridge_a", "--ln-client-name", "ln_ros2_bridge_a"],
        wait=["bridging topic bt.text_a"],
    )
    other = start_bridge(
        {
            "defaults": {"string_capacity": 16},
            "topics": [
                {"ln": "bt.text_b", "type": "std_msgs/msg/String"},
                {"ln": "bt.twist_b", "type": "geometry_msgs/msg/Twist"},
            ],
        },
        name="bridge_b",
        extra_args=["--node-name", "ln_ros2_bridge_b", "--ln-client-name", "ln_ros2_bridge_b"],
        wait=["bridging topic bt.twist_b"],
    )
    other.wait_log(
        r"topic bt.text_b \(ln_to_ros, ROS /bt/text_b\): cannot bridge: the LN manager has another "
        r"definition of ros2/std_msgs/msg/String .*use the same capacities",
        20,
    )
    assert other.running()
