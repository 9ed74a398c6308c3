"""Rules: LN definitions mapped onto existing ROS types (constants, unit scaling, time), validated."""

import os
import struct

import pytest
from msg_mapping.rules import compile_rules, load_rules

import msg_mapping

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "ln_corpus")
RULES = os.path.join(HERE, "data", "rules", "robot_pose.yaml")

serialization = pytest.importorskip("rclpy.serialization")
if not msg_mapping.ros_share_dirs():
    pytest.skip("no ROS share directories (AMENT_PREFIX_PATH)", allow_module_level=True)

# mmtest2/robot_pose: double time; int64_t time_ns; double pos_mm[3]; double quat[4]; char frame[16];
#                     float cov[36]; int32_t counter
POSE = struct.Struct("<dq3d4d16s36fi")


def pose_bytes(
    time=12.25,
    time_ns=3_500_000_001,
    pos=(1000.0, -2500.0, 42.0),
    quat=(0.0, 0.0, 0.6, 0.8),
    frame=b"base",
    cov=None,
    counter=7,
):
    cov = cov or [float(i) for i in range(36)]
    return POSE.pack(time, time_ns, *pos, *quat, frame, *cov, counter)


@pytest.fixture(scope="module")
def codecs():
    library = msg_mapping.Library([CORPUS])
    ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
    return {c.ros_name: c for c in compile_rules(load_rules(RULES), library, ros)}


def test_pose_stamped(codecs):
    from geometry_msgs.msg import PoseStamped

    codec = codecs["geometry_msgs/msg/PoseStamped"]
    msg = serialization.deserialize_message(codec.ln_to_cdr(pose_bytes()), PoseStamped)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (12, 250_000_000)
    assert msg.header.frame_id == "map"  # constant
    assert (msg.pose.position.x, msg.pose.position.y, msg.pose.position.z) == pytest.approx((1.0, -2.5, 0.042))
    assert (msg.pose.orientation.z, msg.pose.orientation.w) == (0.6, 0.8)
    # and back: scaled inversely, constants dropped, unmapped LN fields zero
    msg.pose.position.x = 3.5
    fields = POSE.unpack(codec.cdr_to_ln(serialization.serialize_message(msg)))
    assert fields[0] == 12.25 and fields[2] == pytest.approx(3500.0) and fields[8] == 0.8
    assert fields[1] == 0 and fields[9] == b"\0" * 16


def test_covariance_frame_and_nanoseconds(codecs):
    from geometry_msgs.msg import PoseWithCovarianceStamped

    codec = codecs["geometry_msgs/msg/PoseWithCovarianceStamped"]
    msg = serialization.deserialize_message(codec.ln_to_cdr(pose_bytes()), PoseWithCovarianceStamped)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (3, 500_000_001)
    assert msg.header.frame_id == "base"
    assert list(msg.pose.covariance) == [float(i) for i in range(36)]
    back = POSE.unpack(codec.cdr_to_ln(serialization.serialize_message(msg)))
    assert back[1] == 3_500_000_001 and back[9].rstrip(b"\0") == b"base" and back[10:46] == tuple(range(36))


def test_array_to_sequence(codecs):
    from sensor_msgs.msg import JointState

    codec = codecs["sensor_msgs/msg/JointState"]
    msg = serialization.deserialize_message(codec.ln_to_cdr(pose_bytes()), JointState)
    assert list(msg.position) == pytest.approx([1.0, -2.5, 0.042])
    msg.position = [1.0, 2.0, 3.0, 4.0]
    with pytest.raises(msg_mapping.CodecError, match="4 elements do not fit LN field 'pos_mm'"):
        codec.cdr_to_ln(serialization.serialize_message(msg))
    msg.position = [1.0]
    assert POSE.unpack(codec.cdr_to_ln(serialization.serialize_message(msg)))[2:5] == (1000.0, 0.0, 0.0)


def test_out_of_range_values_are_errors():
    library = msg_mapping.Library([CORPUS])
    ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
    rule = {
        "ln": "mmtest2/robot_pose",
        "ros": "std_msgs/msg/Int8",
        "fields": [{"ros": "data", "from": "counter", "lossy": "true"}],
    }
    (codec,) = compile_rules([rule], library, ros)
    assert codec.ln_to_cdr(pose_bytes(counter=-5))[4] == 0xFB
    with pytest.raises(msg_mapping.CodecError, match="data: value 300 is out of range"):
        codec.ln_to_cdr(pose_bytes(counter=300))


# An arm's joints as an LN array of a sub-type: one ROS array per field of it (rules for string arrays).
ARM_SOURCES = {
    "mmrules/joint": "char name[12]\ndouble position\nfloat effort\n",
    "mmrules/arm_state": 'define joint as "mmrules/joint"\ndouble time\njoint joints[3]\n',
}
JOINT = struct.Struct("<12sdf")
JOINT_STATE_RULE = {
    "ln": "mmrules/arm_state",
    "ros": "sensor_msgs/msg/JointState",
    "fields": [
        {"ros": "header.stamp", "from": "time", "convert": "seconds_to_time"},
        {"ros": "name", "from": "joints.name"},
        {"ros": "position", "from": "joints.position"},
        {"ros": "effort", "from": "joints.effort"},
    ],
}


def arm_library():
    library = msg_mapping.Library([])
    for name, text in ARM_SOURCES.items():
        library.add_source(name, text)
    return library


def arm_bytes(time, joints):
    return struct.pack("<d", time) + b"".join(JOINT.pack(*joint) for joint in joints)


def test_arrays_of_strings_and_per_element_fields():
    """sensor_msgs/msg/JointState keeps its joint names: ROS string[] <- the char array of each
    element of an LN array, position/effort <- a number of each element."""
    from sensor_msgs.msg import JointState

    (codec,) = compile_rules([JOINT_STATE_RULE], arm_library(), msg_mapping.RosToLn(msg_mapping.ros_share_dirs()))
    joints = [(b"shoulder", 0.5, 1.5), (b"elbow_joint1", -1.25, 0.0), (b"", 2.0, -3.0)]  # 12 bytes: no NUL
    msg = serialization.deserialize_message(codec.ln_to_cdr(arm_bytes(4.5, joints)), JointState)
    assert list(msg.name) == ["shoulder", "elbow_joint1", ""]
    assert list(msg.position) == [0.5, -1.25, 2.0] and list(msg.effort) == [1.5, 0.0, -3.0]
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (4, 500_000_000) and list(msg.velocity) == []

    msg.name, msg.position, msg.effort = ["wrist", "hand"], [7.0, 8.0], [0.25, 0.5]
    back = codec.cdr_to_ln(serialization.serialize_message(msg))
    assert [JOINT.unpack_from(back, 8 + i * JOINT.size) for i in range(3)] == [
        (b"wrist".ljust(12, b"\0"), 7.0, 0.25),
        (b"hand".ljust(12, b"\0"), 8.0, 0.5),
        (b"\0" * 12, 0.0, 0.0),
    ]
    msg.name = ["a_name_of_13_"]
    with pytest.raises(
        msg_mapping.CodecError,
        match=r"name\[0\]: a string of 13 bytes does not fit LN field "
        r"'joints.name' \(12 bytes\)",
    ):
        codec.cdr_to_ln(serialization.serialize_message(msg))
    msg.name = ["a", "b", "c", "d"]
    with pytest.raises(msg_mapping.CodecError, match=r"name: 4 strings do not fit LN field 'joints.name' \(3\)"):
        codec.cdr_to_ln(serialization.serialize_message(msg))


@pytest.mark.parametrize(
    "ros_field,ln_field,message",
    [
        ("name", "joints[0].name", r"an array of strings takes one LN char array per element: 'from: names.text'"),
        ("name", "joints.position", r"a string needs an LN char array, 'joints.position' is double"),
        (
            "header.frame_id",
            "joints.name",
            r"'joints.name' has one value per element of an LN array: it fits a ROS "
            r"array, not string",
        ),
        (
            "position",
            "joints.name",
            r"'joints.name' is char\[12\] per element; float64\[\] takes one number per element",
        ),
    ],
)
def test_bad_per_element_rules(ros_field, ln_field, message):
    rule = {
        "ln": "mmrules/arm_state",
        "ros": "sensor_msgs/msg/JointState",
        "fields": [{"ros": ros_field, "from": ln_field}],
    }
    with pytest.raises(msg_mapping.MappingError, match=message):
        compile_rules([rule], arm_library(), msg_mapping.RosToLn(msg_mapping.ros_share_dirs()))


BAD_RULES = [
    (
        {"pose.postion.x": {"from": "pos_mm[0]"}},
        r"ROS field 'pose.postion.x' does not exist \('postion' is not a field of geometry_msgs/msg/Pose, which has: "
        r"position, orientation\)",
    ),
    ({"pose.position.x": {"from": "pos_cm[0]"}}, r"LN field 'pos_cm\[0\]' does not exist in 'mmtest2/robot_pose'"),
    ({"pose.position.x": {"from": "pos_mm[3]"}}, r"index 3 is out of range \(3 element"),
    ({"pose.position.x": {"from": "pos_mm"}}, r"it is a single float64, but LN field 'pos_mm' is an array of 3"),
    ({"pose.position": {"from": "pos_mm"}}, r"it is a geometry_msgs/Point message; map its fields"),
    ({"header.frame_id": {"from": "time"}}, r"a string needs an LN char array, 'time' is double"),
    ({"header.stamp.sec": {"from": "time"}}, r"LN field 'time' \(double\) does not fit ROS int32 without loss"),
    ({"header.stamp.sec": {"from": "time_ns"}}, r"\(int64_t\) does not fit ROS int32 without loss"),
    ({"pose.position.x": {"from": "time", "value": "1"}}, r"exactly one of 'from'"),
    ({"pose.position.x": {"value": "north"}}, r"constant 'north' is not a number"),
    ({"header.stamp": {"from": "pos_mm[0]", "convert": "days"}}, r"unknown convert 'days'"),
    ({"pose.position.x": {"from": "time", "convert": "seconds_to_time"}}, r"needs a builtin_interfaces/Time"),
    ({"pose.position.x": {"from": "time", "scale": "0"}}, r"scale 0 cannot be inverted"),
    ({"pose.position.x": "time", "pose.position": {"from": "time"}}, r"overlaps the rule for 'pose.position.x'"),
]


@pytest.mark.parametrize("fields,message", BAD_RULES)
def test_bad_rules(tmp_path, fields, message):
    library = msg_mapping.Library([CORPUS])
    ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
    rule = {
        "ln": "mmtest2/robot_pose",
        "ros": "geometry_msgs/msg/PoseStamped",
        "fields": [{"ros": k, **({"from": v} if isinstance(v, str) else v)} for k, v in fields.items()],
    }
    with pytest.raises(msg_mapping.MappingError, match=message) as info:
        compile_rules([rule], library, ros)
    assert "mmtest2/robot_pose -> geometry_msgs/msg/PoseStamped" in str(info.value)


def test_bad_rule_targets_and_files(tmp_path):
    library = msg_mapping.Library([CORPUS])
    ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
    with pytest.raises(msg_mapping.MappingError, match="unknown ROS message type 'geometry_msgs/msg/Posture'"):
        compile_rules([{"ln": "mmtest2/robot_pose", "ros": "geometry_msgs/msg/Posture", "fields": []}], library, ros)
    with pytest.raises(msg_mapping.MappingError, match="rules need a plain LN definition without dynamic fields"):
        compile_rules([{"ln": "mmtest/dynamic_plain", "ros": "std_msgs/msg/Empty", "fields": []}], library, ros)
    with pytest.raises(msg_mapping.MappingError, match="JointState, ROS field 'effort': it is an array"):
        compile_rules(
            [
                {
                    "ln": "mmtest2/robot_pose",
                    "ros": "sensor_msgs/msg/JointState",
                    "fields": [{"ros": "effort", "from": "counter"}],
                }
            ],
            library,
            ros,
        )
    with pytest.raises(msg_mapping.MappingError, match=r"has 36 elements, LN field 'pos_mm' has 3"):
        compile_rules(
            [
                {
                    "ln": "mmtest2/robot_pose",
                    "ros": "geometry_msgs/msg/PoseWithCovariance",
                    "fields": [{"ros": "covariance", "from": "pos_mm"}],
                }
            ],
            library,
            ros,
        )
    path = tmp_path / "r.yaml"
    path.write_text("mappings:\n  - ln: a/b\n    ros: std_msgs/msg/Empty\n    field: {}\n")
    with pytest.raises(msg_mapping.MappingError, match=r"unknown key\(s\) \['field'\]"):
        load_rules(str(path))
    path.write_text("mappings:\n  - ln: a/b\n    ros: std_msgs/msg/Int8\n    fields: {data: {from: x, unit: mm}}\n")
    with pytest.raises(msg_mapping.MappingError, match=r"field data: unknown key\(s\) \['unit'\]"):
        load_rules(str(path))
    path.write_text("mappings: [\n")
    with pytest.raises(msg_mapping.MappingError, match="cannot read the rule file"):
        load_rules(str(path))


def test_generator_validates_rules(tmp_path, capsys):
    from msg_mapping import cli

    assert (
        cli.main(["--md-dir", CORPUS, "--rules", RULES, "--out", str(tmp_path), "mmtest2/robot_pose", "mmtest/point"])
        == 0
    )
    assert not (tmp_path / "mmtest2_ln_msgs").exists()  # rule-mapped: no generated type
    assert (tmp_path / "mmtest_ln_msgs" / "msg" / "Point.msg").exists()
    assert "geometry_msgs/msg/PoseStamped" in (tmp_path / "ln_rules_mapping.json").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "mappings:\n  - ln: mmtest2/robot_pose\n    ros: geometry_msgs/msg/PoseStamped\n"
        "    fields:\n      pose.position.w: quat[3]\n"
    )
    assert cli.main(["--md-dir", CORPUS, "--rules", str(bad), "--out", str(tmp_path / "o"), "mmtest/point"]) == 1
    assert "ROS field 'pose.position.w' does not exist" in capsys.readouterr().err
