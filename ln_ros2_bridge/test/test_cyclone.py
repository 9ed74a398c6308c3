"""Interop with a plain Cyclone DDS participant (PyPI cyclonedds, no ROS at
all): ROS 2's wire conventions (rt/ topics, pkg::msg::dds_::Type_, XCDR1)
through the bridge in both directions."""

import os
import sys
from pathlib import Path

import pytest
import ros_testing  # tests/support, on sys.path through conftest.py

HELPER = Path(__file__).resolve().parent / "helpers" / "cyclone_peer.py"

pytestmark = pytest.mark.skipif(
    not ros_testing.network_is_isolated(),
    reason="Fast DDS (LOCALHOST range) and Cyclone only meet with multicast discovery: needs netns-run",
)


@pytest.fixture
def dds_env():
    """Inside the private namespace, ordinary multicast discovery (on loopback) is safe
    and is what lets Fast DDS and Cyclone find each other."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET")
    env.pop("CYCLONEDDS_URI", None)
    return env


def cyclone_peer(processes, tmp_path, env, *args):
    from conftest import Process

    proc = Process("cyclone-%s" % args[0], [sys.executable, HELPER, *map(str, args)], env, tmp_path)
    processes.append(proc)
    return proc


def test_ln_to_cyclone(ln, start_bridge, ln_peer, processes, tmp_path, dds_env):
    start_bridge(
        {"topics": [{"ln": "bt.cyc_out", "ros": "/bt/cyc_out", "type": "bridgetest/sample"}]},
        wait=["bridging topic bt.cyc_out"],
        env=dds_env,
    )
    reader = cyclone_peer(processes, tmp_path, dds_env, "sub", "/bt/cyc_out", "--count", 10)
    reader.wait_event("ready")
    ln_peer("lnpub", "publish", "bt.cyc_out", "--count", 100000, "--rate", 50)
    samples = reader.wait_event("sample", 30, count=10)
    last = samples[-1]
    assert last["vec"] == [last["seq"] * 0.5, -1.25, 3.0] and last["small"] == -last["seq"]
    assert last["label"] == "n%d" % last["seq"]


def test_cyclone_to_ln(ln, start_bridge, ln_peer, processes, tmp_path, dds_env):
    start_bridge(
        {"topics": [{"ln": "bt.cyc_in", "ros": "/bt/cyc_in", "type": "bridgetest/sample", "direction": "ros_to_ln"}]},
        wait=["bridging topic bt.cyc_in"],
        env=dds_env,
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.cyc_in", "--count", 10)
    subscriber.wait_event("ready")
    cyclone_peer(processes, tmp_path, dds_env, "pub", "/bt/cyc_in", "--count", 100000, "--rate", 50)
    packets = subscriber.wait_event("packet", 30, count=10)
    last = packets[-1]
    assert last["vec"] == [1.0, 2.0, float(last["seq"])] and last["stamp"] == last["seq"] * 0.25
    assert (last["small"], last["flags"], last["label"]) == (-3, 7, "cyc%d" % last["seq"])


def test_cyclone_publisher_beside_a_bridge_publisher(ln, start_bridge, ln_peer, processes, tmp_path, dds_env):
    """/bt/cyc_mix has two publishers: bridge A (from LN) and a plain Cyclone DDS writer,
    which has no ROS node. Bridge B carries /bt/cyc_mix into LN: the Cyclone writer's
    samples only (held until the writer counts as a non-bridge), none of bridge A's."""
    start_bridge(
        {"topics": [{"ln": "bt.cyc_mix", "ros": "/bt/cyc_mix", "type": "bridgetest/sample"}]},
        name="bridge_a",
        wait=["bridging topic bt.cyc_mix"],
        env=dds_env,
        extra_args=["--node-name", "ln_ros2_bridge_a", "--ln-client-name", "ln_ros2_bridge_a"],
    )
    start_bridge(
        {
            "topics": [
                {"ln": "bt.cyc_back", "ros": "/bt/cyc_mix", "type": "bridgetest/sample", "direction": "ros_to_ln"}
            ]
        },
        name="bridge_b",
        wait=["bridging topic bt.cyc_back"],
        env=dds_env,
        extra_args=["--node-name", "ln_ros2_bridge_b", "--ln-client-name", "ln_ros2_bridge_b"],
    )
    subscriber = ln_peer("lnsub", "subscribe", "bt.cyc_back", "--count", 10)
    subscriber.wait_event("ready")
    ln_peer("lnpub", "publish", "bt.cyc_mix", "--count", 100000, "--rate", 50)
    reader = cyclone_peer(processes, tmp_path, dds_env, "sub", "/bt/cyc_mix", "--count", 10)
    reader.wait_event("sample", 30, count=10)  # bridge A's samples are on the topic
    cyclone_peer(processes, tmp_path, dds_env, "pub", "/bt/cyc_mix", "--count", 100000, "--rate", 50)
    packets = subscriber.wait_event("packet", 30, count=10)
    assert [p["label"] for p in packets if not p["label"].startswith("cyc")] == [], (
        "bridge B forwarded bridge A's samples"
    )
