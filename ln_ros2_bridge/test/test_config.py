"""Configuration parsing and name mapping (no LN, no DDS)."""

import pytest

from ln_ros2_bridge.config import (AutoSettings, ConfigError, RemapRule, ln_to_ros_name, parse_config,
                                   ros_name_problem, ros_to_ln_name)


def test_defaults_and_presets():
    config = parse_config({"topics": [{"ln": "robot.arm.state", "qos": "latched"},
                                      {"ln": "robot.cam", "qos": {"preset": "sensor_data", "depth": 2},
                                       "ln_port": {"rate": 10}}],
                           "services": [{"ln": "robot.move", "timeout": 30}]})
    arm, cam = config.topics
    assert (arm.ros, arm.direction, arm.qos.durability, arm.qos.depth) == ("/robot/arm/state", "ln_to_ros",
                                                                           "transient_local", 1)
    assert (cam.qos.reliability, cam.qos.depth, cam.ln_port.rate, cam.ln_port.buffers) == ("best_effort", 2, 10.0, 4)
    assert config.services[0].timeout == 30.0 and config.services[0].ros == "/robot/move"
    assert config.is_bridge_name("ln_ros2_bridge") and config.is_bridge_name("/ns/ln_ros2_bridge_2")
    assert not config.is_bridge_name("controller")


def test_errors_name_the_entry():
    with pytest.raises(ConfigError, match=r"cfg.yaml: topic robot.x: 'ros': invalid ROS name '/a//b'"):
        parse_config({"topics": [{"ln": "robot.x", "ros": "/a//b"}]}, "cfg.yaml")
    with pytest.raises(ConfigError, match=r"auto.remap\[0\]: needs 'ln'"):
        parse_config({"auto": {"enabled": True, "remap": [{"ros": "/x/"}]}})
    with pytest.raises(ConfigError, match=r"'reliability' must be one of reliable, best_effort, best_available"):
        parse_config({"defaults": {"qos": {"reliability": "sometimes"}}, "topics": [{"ln": "a"}]})


def test_name_mapping_round_trip_and_sanitizing():
    auto = AutoSettings(remap=(RemapRule("robot1.", "/r1/"),), ros_namespace="")
    assert ln_to_ros_name("robot1.arm.pose", auto) == "/r1/arm/pose"
    assert ros_to_ln_name("/r1/arm/pose", auto) == "robot1.arm.pose"
    assert ln_to_ros_name("a.b.c", auto) == "/a/b/c" and ros_to_ln_name("/a/b/c", auto) == "a.b.c"
    assert ln_to_ros_name("cam-2.3d", auto) == "/cam_2/ln_3d"
    assert ros_name_problem(ln_to_ros_name("x y.z", auto)) is None
    spaced = AutoSettings(ros_namespace="/lab")
    assert ln_to_ros_name("a.b", spaced) == "/lab/a/b" and ros_to_ln_name("/lab/a/b", spaced) == "a.b"
