"""`ln ros`: the ROS 2 inspection commands of the `ln` command line (the PyPI ROS 2
has no `ros2`), run as a user runs them, against rclpy peers of the test. Here
because this suite is the one that runs inside netns-run; `ln ros` without
rclpy is tested with the rest of `ln` (ln_core/python/tests/cli)."""

import json
import subprocess
import sys
import time

import pytest
from conftest import wait_until


def run_ln(*args, timeout=60):
    return subprocess.run(
        [sys.executable, "-m", "links_and_nodes.cli", "ros", *args], capture_output=True, text=True, timeout=timeout
    )


def ok(result):
    assert result.returncode == 0 and "Traceback" not in result.stderr, result
    return result.stdout


def one_line_error(result, *words):
    assert result.returncode != 0 and "Traceback" not in result.stderr + result.stdout, result
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ln: error: "), result.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def talker(ros):
    """/clitest/chatter (std_msgs/String, 20 Hz) and /clitest/enable (std_srvs/SetBool) of a ROS node."""
    from std_msgs.msg import String
    from std_srvs.srv import SetBool

    publisher = ros.node.create_publisher(String, "/clitest/chatter", 10)
    calls = []

    def set_bool(request, response):
        calls.append(request.data)
        response.success, response.message = request.data, "enabled" if request.data else "refused"
        return response

    ros.node.create_service(SetBool, "/clitest/enable", set_bool)
    timer = ros.node.create_timer(0.05, lambda: publisher.publish(String(data="hello %d" % len(calls))))
    yield calls
    ros.node.destroy_timer(timer)


def until(command, check, what, timeout=45):
    """Runs an `ln ros` list/info command until its JSON answer passes `check` (discovery of
    the test's node takes seconds on a busy machine, and each run is a newcomer)."""
    answers = []

    def passes():
        result = run_ln(*command, "--json")
        if result.returncode != 0 and "unknown ROS" in result.stderr:
            return False  # not discovered yet by this newcomer
        answers.append(json.loads(ok(result)))
        return check(answers[-1])

    wait_until(passes, timeout, what)
    return answers[-1]


def test_graph_commands(ros, talker):
    own = "/" + ros.node.get_name()
    nodes = until(["node", "list"], lambda nodes: own in nodes, "the test's node in 'ln ros node list'")
    assert not [n for n in nodes if n.rsplit("/", 1)[-1].startswith("_")], "hidden nodes listed"

    chatter = {"name": "/clitest/chatter", "types": ["std_msgs/msg/String"], "publishers": 1}

    def lists_chatter(topics):
        return any({key: t.get(key) for key in chatter} == chatter for t in topics)

    topics = until(["topic", "list"], lists_chatter, "/clitest/chatter with its publisher in 'ln ros topic list'")
    assert lists_chatter(topics)
    wait_until(
        lambda: any(
            line.split()[:2] == ["/clitest/chatter", "std_msgs/msg/String"]
            for line in ok(run_ln("topic", "list", "--spin-time", "5")).splitlines()
        ),
        45,
        "/clitest/chatter and its type in the text of 'ln ros topic list'",
    )

    # A newcomer may see an endpoint before the ROS discovery info that names its node: wait for both.
    talker_info = [{"node": own, "type": "std_msgs/msg/String", "reliability": "reliable", "durability": "volatile"}]
    info = until(
        ["topic", "info", "/clitest/chatter"],
        lambda info: info["publishers"] == talker_info,
        "the talker with its node in 'topic info'",
    )
    assert info["publishers"] == talker_info

    enable = {"name": "/clitest/enable", "types": ["std_srvs/srv/SetBool"], "servers": [own]}
    services = until(
        ["service", "list"], lambda services: enable in services, "/clitest/enable in 'ln ros service list'"
    )
    assert enable in services
    assert own + "/get_parameters" not in {s["name"] for s in services}
    everything = until(
        ["service", "list", "--all"],
        lambda everything: own + "/get_parameters" in {s["name"] for s in everything},
        "the node's parameter services in 'ln ros service list --all'",
    )
    assert enable in everything


def test_echo_and_hz(ros, talker):
    lines = ok(run_ln("topic", "echo", "/clitest/chatter", "--count", "3", "--json", "--timeout", "20")).splitlines()
    assert len(lines) == 3 and all(json.loads(line)["data"].startswith("hello ") for line in lines)
    text = ok(run_ln("topic", "echo", "clitest/chatter", "--once", "--timeout", "20"))
    assert text.startswith('data: "hello ') and text.rstrip().endswith("---")

    (report,) = [
        json.loads(line)
        for line in ok(run_ln("topic", "hz", "/clitest/chatter", "--duration", "3", "--json")).splitlines()
    ]
    assert report["topic"] == "/clitest/chatter" and 10 < report["rate"] < 40, report  # published at 20 Hz
    assert "lost" not in report


def test_service_call(ros, talker):
    response = json.loads(ok(run_ln("service", "call", "/clitest/enable", "data: true", "--json", "--timeout", "30")))
    assert response == {"success": True, "message": "enabled"} and talker == [True]
    text = ok(run_ln("service", "call", "/clitest/enable", "data: true"))
    assert text.splitlines() == ["success: true", 'message: "enabled"']
    refused = run_ln("service", "call", "/clitest/enable", "data: false")
    assert 'message: "refused"' in refused.stdout
    one_line_error(refused, "answered success: false: refused")


def test_errors_are_one_line(ros, talker):
    one_line_error(
        run_ln("topic", "echo", "/clitest/none", "--spin-time", "0.5"),
        "unknown ROS topic '/clitest/none'",
        "ln ros topic list",
    )
    one_line_error(
        run_ln("service", "call", "/clitest/enable", "enabled: true"),
        "'std_srvs/srv/SetBool_Request' has no field 'enabled'; fields: data",
    )
    one_line_error(run_ln("service", "call", "/clitest/enable", "data: maybe"), "expects true or false")
    one_line_error(
        run_ln("service", "call", "/clitest/nothing", "--type", "std_srvs/srv/Trigger", "--timeout", "1"),
        "no server for ROS service '/clitest/nothing' within 1 s",
    )
    one_line_error(
        run_ln("topic", "echo", "/clitest/chatter", "--type", "nope_msgs/msg/X"),
        "ROS type 'nope_msgs/msg/X' is not installed here",
    )
    start = time.monotonic()
    one_line_error(
        run_ln("topic", "echo", "/clitest/silent", "--type", "std_msgs/msg/String", "--timeout", "1"),
        "no message on ROS topic '/clitest/silent' for 1 s",
    )
    assert time.monotonic() - start < 30


def test_bridge_is_visible_with_ln_ros(ln, start_bridge, ln_peer):
    """What the bridge README tells users to check, with commands the set-up provides."""
    start_bridge({"topics": [{"ln": "bt.sample", "type": "bridgetest/sample"}]}, wait=["bridging topic bt.sample"])
    ln_peer("lnpub", "publish", "bt.sample", "--count", 100000, "--rate", 50)
    until(["node", "list"], lambda nodes: "/ln_ros2_bridge" in nodes, "the bridge node")
    info = until(["topic", "info", "/bt/sample"], lambda info: info["publishers"], "the bridge publishing /bt/sample")
    assert [p["node"] for p in info["publishers"]] == ["/ln_ros2_bridge"]
    assert info["types"] == ["bridgetest_ln_msgs/msg/Sample"]
    (message,) = [
        json.loads(line)
        for line in ok(run_ln("topic", "echo", "/bt/sample", "--once", "--json", "--timeout", "20")).splitlines()
    ]
    assert message["vec"][1:] == [-1.25, 3.0]
