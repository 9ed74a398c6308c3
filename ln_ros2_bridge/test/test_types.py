"""Type resolution against the generated test interfaces (no LN, no DDS)."""

import json
import os

import pytest
from conftest import MD_DIRS
from ln_ros2_bridge.services import fill_error_fields
from ln_ros2_bridge.types import RosCapacities, TypeRegistry, UnknownType


@pytest.fixture
def registry():
    return TypeRegistry([str(d) for d in MD_DIRS])


def test_generated_types_and_codecs(registry):
    from bridgetest_ln_msgs.msg import Sample
    from rclpy.serialization import deserialize_message, serialize_message

    topic = registry.topic_type("bridgetest/sample")
    assert topic.ros_type == "bridgetest_ln_msgs/msg/Sample" and topic.msg_class is Sample
    message = Sample(seq=7, stamp=2.5, vec=[1.0, 2.0, 3.0], small=-4, flags=200, label=list(b"hello") + [0] * 11)
    ln_bytes = topic.codec.cdr_to_ln(serialize_message(message))
    assert len(ln_bytes) == topic.ln_size
    assert deserialize_message(topic.codec.ln_to_cdr(ln_bytes), Sample) == message
    assert registry.ln_name_for_ros("bridgetest_ln_msgs/msg/Sample") == "bridgetest/sample"
    service = registry.service_type("bridgetest/compute")
    assert service.ros_type == "bridgetest_ln_msgs/srv/Compute"


def test_unknown_and_stale_types(registry, tmp_path):
    with pytest.raises(UnknownType, match="cannot be loaded"):
        registry.topic_type("bridgetest/nope")
    with pytest.raises(UnknownType, match="is a service, not a message"):
        registry.topic_type("bridgetest/compute")
    with pytest.raises(UnknownType, match="ROS type nope_msgs/msg/X cannot be mapped to LN: unknown ROS message type"):
        registry.topic_type(ros_type="nope_msgs/msg/X")
    with pytest.raises(UnknownType, match="std_srvs/srv/Trigger is a ROS service type, a topic needs a message type"):
        registry.topic_type("ros2/std_srvs/srv/Trigger")
    # an interface generated from an older version of the definition
    share = tmp_path / "share" / "bridgetest_ln_msgs"
    share.mkdir(parents=True)
    original = next(
        p
        for p in os.environ["AMENT_PREFIX_PATH"].split(os.pathsep)
        if os.path.exists(os.path.join(p, "share", "bridgetest_ln_msgs", "ln_mapping.json"))
    )
    mapping = json.load(open(os.path.join(original, "share", "bridgetest_ln_msgs", "ln_mapping.json")))
    for entry in mapping["interfaces"]:
        entry["ln_hash"] = "0" * 64
    (share / "ln_mapping.json").write_text(json.dumps(mapping))
    stale = TypeRegistry([str(d) for d in MD_DIRS], share_dirs=[str(tmp_path / "share")])
    with pytest.raises(UnknownType, match="generated from another version.*regenerate"):
        stale.topic_type("bridgetest/sample")


def test_types_derived_from_ros_types():
    """Any installed ROS type has an LN counterpart: the definition msg_mapping derives,
    with the configured capacities, and the definitions it uses for the LN manager."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    registry = TypeRegistry(
        capacities=RosCapacities(string=32, sequence=4, fields={"sensor_msgs/msg/JointState.name[]": 8})
    )
    assert registry.ln_name_for_ros("std_msgs/msg/String") == "ros2/std_msgs/msg/String"
    topic = registry.topic_type(ros_type="sensor_msgs/msg/JointState")
    assert (topic.ln_name, topic.via, topic.msg_class) == ("ros2/sensor_msgs/msg/JointState", "derived", JointState)
    assert [name for name, _, _ in topic.definitions] == [
        "ros2/msg_mapping/string8",
        "ros2/builtin_interfaces/msg/Time",
        "ros2/std_msgs/msg/Header",
        "ros2/sensor_msgs/msg/JointState",
    ]
    assert "char frame_id[32]" in dict((n, t) for n, t, _ in topic.definitions)["ros2/std_msgs/msg/Header"]
    # header (8 + 4 + 32) + names (4 + 4 * (4 + 8)) + three double sequences (3 * (4 + 4 * 8))
    assert topic.ln_size == 44 + 52 + 108
    assert registry.topic_type("ros2/sensor_msgs/msg/JointState").ros_type == "sensor_msgs/msg/JointState"
    packet = topic.codec.cdr_to_ln(serialize_message(JointState(name=["a", "b"], position=[1.0])))
    assert len(packet) == topic.ln_size
    with pytest.raises(ValueError, match="name: sequence of 5 elements does not fit the LN capacity 4"):
        topic.codec.cdr_to_ln(serialize_message(JointState(name=["j"] * 5)))
    service = registry.service_type(ros_type="std_srvs/srv/Trigger")
    assert (service.ln_name, service.via) == ("ros2/std_srvs/srv/Trigger", "derived")


def test_error_fields():
    from bridgetest_ln_msgs.srv import Compute, Plain

    response = Compute.Response()
    assert fill_error_fields(response, 64, "timed out")
    assert (response.error_code, response.error_message) == (64, "timed out")
    assert not fill_error_fields(Plain.Response(), 64, "timed out")
    from std_srvs.srv import Trigger

    trigger = Trigger.Response(success=True)
    assert fill_error_fields(trigger, 1, "failed") and (trigger.success, trigger.message) == (False, "failed")
