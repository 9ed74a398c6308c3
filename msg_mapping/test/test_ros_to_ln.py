"""ROS 2 -> LN: std_msgs, geometry_msgs, sensor_msgs, std_srvs types from the installed wheels.

Every type is mapped (fixed variant for topics, dynamic variant, services), the generated LN
text is loaded by ln_core's model, and random messages round-trip byte-identically:
CDR (rclpy) -> LN == the independent LN encoder's bytes, LN -> CDR == rclpy's bytes (same
length; only uninitialized padding may differ) and rclpy reads it back equal.
"""

import json

import mm_oracle
import pytest

import msg_mapping

PACKAGES = ("std_msgs", "geometry_msgs", "sensor_msgs", "std_srvs")
TRIALS = 6

rclpy_serialization = pytest.importorskip("rclpy.serialization")


@pytest.fixture(scope="module")
def ros():
    # Big enough for the random messages of the test (and shows per-field capacities).
    return msg_mapping.RosToLn(msg_mapping.ros_share_dirs(), capacities={"sensor_msgs/msg/Image.data": 4096})


def all_types(ros):
    types = []
    for package in PACKAGES:
        types += ros.package_types(package, "msg") + ros.package_types(package, "srv")
    return types


def test_every_type_maps(ros):
    types = all_types(ros)
    assert len(types) > 80
    for ros_type in types:
        interface = ros.add(ros_type)
        if "/msg/" in ros_type:
            ros.add(ros_type, True)
        assert interface["ln_name"].startswith("ros2/")
    library = msg_mapping.Library()
    for name, text in ros.definitions().items():
        library.add_source(name, text)
    for name in ros.definitions():
        library.load(name)  # ln_core's parser accepts every generated text


def test_generated_text(ros):
    ros.add("sensor_msgs/msg/Image")
    ros.add("std_srvs/srv/SetBool")
    ros.add("std_msgs/msg/Empty")
    ros.add("sensor_msgs/msg/JointState", True)
    defs = ros.definitions()
    image = defs["ros2/sensor_msgs/msg/Image"]
    assert 'define std_msgs__header as "ros2/std_msgs/msg/Header"' in image
    assert "uint32_t encoding_len\nchar encoding[255]\n" in image  # default string capacity
    assert "uint32_t data_len\nuint8_t data[4096]\n" in image  # configured capacity
    assert "# is_bigendian: ROS uint8" not in image
    header = defs["ros2/std_msgs/msg/Header"]
    assert 'define builtin_interfaces__time as "ros2/builtin_interfaces/msg/Time"' in header
    set_bool = defs["ros2/std_srvs/srv/SetBool"]
    assert "service\n" in set_bool and "request\n" in set_bool and "char* message" in set_bool
    assert "uint8_t data" in set_bool and "# data: ROS bool" in set_bool
    assert "uint8_t structure_needs_at_least_one_member" in defs["ros2/std_msgs/msg/Empty"]
    joint = defs["ros2/sensor_msgs/msg/JointState_dynamic"]
    assert 'define dynamic_string as "ros2/msg_mapping/string"' in joint
    assert "dynamic_string* name" in joint and "double* position" in joint
    # constants become comments
    ros.add("sensor_msgs/msg/PointField")
    assert "# constant uint8 FLOAT64=8" in ros.definitions()["ros2/sensor_msgs/msg/PointField"]


def test_round_trip_against_rclpy(ros):
    types = all_types(ros)
    for ros_type in types:
        ros.add(ros_type)
        if "/msg/" in ros_type:
            ros.add(ros_type, True)
    pairing = mm_oracle.Pairing([json.loads(ros.mapping_json())])
    checked, failures = 0, []
    for ros_type in types:
        variants = (False, True) if "/msg/" in ros_type else (True,)
        parts = ("message",) if "/msg/" in ros_type else ("request", "response")
        for dynamic in variants:
            for part in parts:
                codec = ros.codec(ros_type, dynamic, part)
                part_type = (
                    ros_type if part == "message" else ros_type + ("_Request" if part == "request" else "_Response")
                )
                cls = mm_oracle.message_class(part_type)
                for trial in range(TRIALS):
                    msg = mm_oracle.random_message(mm_oracle.rng_for(part_type, trial), cls)
                    cdr = rclpy_serialization.serialize_message(msg)
                    oracle, _ = mm_oracle.cdr_encode(msg)
                    expected_ln = pairing.ln_encode(msg, codec.ln_name)
                    ln = codec.cdr_to_ln(cdr)
                    back = codec.ln_to_cdr(ln)
                    checked += 1
                    if (
                        ln != expected_ln
                        or back[: len(oracle)] != oracle
                        or len(back) != len(cdr)
                        or any(back[len(oracle) :])
                        or rclpy_serialization.deserialize_message(back, cls) != msg
                    ):
                        failures.append(f"{part_type} dynamic={dynamic} trial {trial}")
    assert not failures, failures[:10]
    assert checked > 500


def test_bounded_types_and_bool_normalization(ros, tmp_path):
    share = tmp_path / "share"
    (share / "bounded_msgs" / "msg").mkdir(parents=True)
    (share / "bounded_msgs" / "msg" / "Bounded.msg").write_text(
        "string<=5 name\nint32[<=3] values\nbool[2] flags\nstring<=4[<=2] tags\n"
    )
    r = msg_mapping.RosToLn([str(share)] + msg_mapping.ros_share_dirs())
    r.add("bounded_msgs/msg/Bounded")
    text = r.definitions()["ros2/bounded_msgs/msg/Bounded"]
    assert "uint32_t name_len\nchar name[5]\n" in text  # the ROS bound is the LN capacity
    assert "uint32_t values_len\nint32_t values[3]\n" in text
    assert 'define bounded_string4 as "ros2/msg_mapping/string4"' in text
    codec = r.codec("bounded_msgs/msg/Bounded")
    import struct

    ln = (
        struct.pack("<I", 2)
        + b"ab\0\0\0"
        + struct.pack("<I3i", 1, 7, 0, 0)
        + bytes([0, 5])
        + struct.pack("<I", 0)
        + bytes(2 * 8)
    )
    cdr = codec.ln_to_cdr(ln)
    assert cdr[4:].startswith(struct.pack("<I", 3) + b"ab\0")
    assert bytes([0, 1]) in cdr  # bool 5 -> 1
    too_long = struct.pack("<I", 6) + b"abcdef"[:5]
    with pytest.raises(msg_mapping.CodecError, match="exceeds the capacity 5"):
        codec.ln_to_cdr(too_long + ln[9:])
    # a ROS value above the bound / capacity is an error, not a truncation
    with pytest.raises(msg_mapping.CodecError, match="name"):
        codec.cdr_to_ln(b"\x00\x01\x00\x00" + struct.pack("<I", 8) + b"abcdefg\0" + bytes(32))


def test_overflow_of_default_capacity_is_an_error(ros):
    from std_msgs.msg import String

    ros.add("std_msgs/msg/String")
    ros.add("std_msgs/msg/String", True)
    cdr = rclpy_serialization.serialize_message(String(data="x" * 300))
    with pytest.raises(
        msg_mapping.CodecError,
        match=r"std_msgs/msg/String: data: string of 300 bytes does not fit "
        r"the LN capacity 255",
    ):
        ros.codec("std_msgs/msg/String").cdr_to_ln(cdr)
    # the dynamic (service) variant has no capacity
    assert ros.codec("std_msgs/msg/String", True).cdr_to_ln(cdr)[:4] == (300).to_bytes(4, "little")


def test_ros_errors(tmp_path):
    share = tmp_path / "share"
    (share / "bad_msgs" / "msg").mkdir(parents=True)
    (share / "bad_msgs" / "msg" / "Wide.msg").write_text("wstring text\n")
    (share / "bad_msgs" / "msg" / "Clash.msg").write_text("uint8 items_len\nfloat64[] items\n")
    (share / "bad_msgs" / "msg" / "Syntax.msg").write_text("float64\n")
    r = msg_mapping.RosToLn([str(share)])
    with pytest.raises(msg_mapping.MappingError, match="Wide, field 'text': wstring has no LN counterpart"):
        r.add("bad_msgs/msg/Wide")
    with pytest.raises(msg_mapping.MappingError, match="'items_len' is needed twice"):
        r.add("bad_msgs/msg/Clash")
    with pytest.raises(msg_mapping.MappingError, match="Syntax:1: expected 'TYPE NAME'"):
        r.add("bad_msgs/msg/Syntax")
    with pytest.raises(msg_mapping.MappingError, match="unknown ROS message type 'bad_msgs/msg/Missing'"):
        r.add("bad_msgs/msg/Missing")
    with pytest.raises(msg_mapping.MappingError, match="capacity of 'bad_msgs/msg/Clash.items' must be at least 1"):
        msg_mapping.RosToLn([str(share)], capacities={"bad_msgs/msg/Clash.items": 0}).add("bad_msgs/msg/Clash")
