"""Configuration parsing and name mapping (no LN, no DDS)."""

import pytest

from ln_ros2_bridge.config import (
    AutoSettings,
    ConfigError,
    RemapRule,
    ln_to_ros_name,
    parse_config,
    ros_name_problem,
    ros_to_ln_name,
)


def test_defaults_and_presets():
    config = parse_config(
        {
            "topics": [
                {"ln": "robot.arm.state", "qos": "latched"},
                {"ln": "robot.cam", "qos": {"preset": "sensor_data", "depth": 2}, "ln_port": {"rate": 10}},
            ],
            "services": [{"ln": "robot.move", "timeout": 30}],
        }
    )
    arm, cam = config.topics
    assert (arm.ros, arm.direction, arm.qos.durability, arm.qos.depth) == (
        "/robot/arm/state",
        "ln_to_ros",
        "transient_local",
        1,
    )
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


def test_the_command_is_on_path_after_env_sh():
    """The README's `ln_ros2_bridge --config ...` works after `. launchless_scripts/env.sh`."""
    import subprocess
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    if not (repo / "install" / "ln_ros2_bridge").is_dir():
        pytest.skip("the workspace is not built with colcon here (no install/ln_ros2_bridge)")
    example = repo / "ln_ros2_bridge" / "config" / "example.yaml"
    result = subprocess.run(
        [
            "bash",
            "-c",
            '. "$1" >/dev/null && command -v ln_ros2_bridge && ln_ros2_bridge --config "$2" --check',
            "_",
            str(repo / "launchless_scripts" / "env.sh"),
            str(example),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result
    command, checked = result.stdout.splitlines()[:2]
    assert command == str(repo / "install" / "ln_ros2_bridge" / "lib" / "ln_ros2_bridge" / "ln_ros2_bridge")
    assert "example.yaml is valid" in checked


def test_ros_types_and_capacities():
    """`type` names an LN definition or a ROS type (pkg/msg/Type); capacities of derived
    definitions per entry (relative to its type) or in defaults, merged into one table."""
    config = parse_config(
        {
            "defaults": {"string_capacity": 64, "capacities": {"std_msgs/msg/Header.frame_id": 32}},
            "topics": [
                {"ln": "robot.cmd", "type": "geometry_msgs/msg/Twist", "direction": "ros_to_ln"},
                {"ln": "robot.joints", "type": "sensor_msgs/msg/JointState", "capacities": {"name": 12, "name[]": 24}},
                {"ln": "robot.joints2", "ros_type": "sensor_msgs/msg/JointState", "capacities": {"name": 12}},
                {"ln": "robot.state", "type": "robot/state"},
            ],
            "services": [{"ln": "robot.reset", "type": "std_srvs/srv/Trigger", "direction": "ros_to_ln"}],
        }
    )
    cmd, joints, joints2, state = config.topics
    assert (cmd.ln_type, cmd.ros_type) == (None, "geometry_msgs/msg/Twist")
    assert (joints2.ln_type, joints2.ros_type) == (None, "sensor_msgs/msg/JointState")
    assert (state.ln_type, state.ros_type) == ("robot/state", None)
    assert (config.services[0].ln_type, config.services[0].ros_type) == (None, "std_srvs/srv/Trigger")
    assert (config.string_capacity, config.sequence_capacity) == (64, 64)
    assert config.capacities == {
        "std_msgs/msg/Header.frame_id": 32,
        "sensor_msgs/msg/JointState.name": 12,
        "sensor_msgs/msg/JointState.name[]": 24,
    }
