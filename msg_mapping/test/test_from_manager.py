"""ln_ros2_gen --from-manager: packages for what a running ln_core manager knows (the
definition of every topic, the interface of every service), from the manager's texts."""

import filecmp
import json
import os
import subprocess
import sys
import time

import pytest
from msg_mapping.manager import load_fetching, missing_definitions

import msg_mapping
from msg_mapping import cli

sys.path.insert(
    0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "tests", "support")
)
import ln_testing

# Only the manager gets these files: the generator has to take every text from it.
DEFINITIONS = {
    "fmtest/robot/pose": "double position[3]\ndouble orientation[4]\n",
    "fmtest/robot/unit": "uint8_t code\n",
    # relative defines: "pose" next to fmtest/robot/state is fmtest/robot/pose
    "fmtest/robot/state": 'define pose_t as "pose"\ndefine unit_t as "unit"\npose_t tcp\nunit_t units[2]\n'
    "uint32_t counter\n",
    "fmtest/robot/move": 'service\nrequest\ndefine pose_t as "fmtest/robot/pose"\npose_t target\ndouble speed\n'
    "response\nint32_t error_code\nchar* error_message\n",
    "fmtest/idle": "uint16_t seconds\n",  # only subscribed
}


def _ln_core_env():
    """(ln_manager, environment in which child processes import ln_core's links_and_nodes
    and this msg_mapping), or skip."""
    try:
        manager, package = ln_testing.LnCore.locate()
    except ln_testing.Unavailable as error:
        pytest.skip(str(error))
    return manager, dict(
        os.environ,
        PYTHONPATH=os.pathsep.join(
            [package, os.path.dirname(os.path.dirname(msg_mapping.__file__)), os.environ.get("PYTHONPATH", "")]
        ),
    )


# An LN system on the manager: publishes, subscribes, provides; prints the topics' hashes
# as the manager lists them, then stays until its stdin closes. (links_and_nodes is only
# ever imported in child processes: with it loaded, nanobind would turn msg_mapping's
# DefinitionError into its LNError for the other tests of this process.)
SYSTEM = """
import json, signal, sys
import links_and_nodes as ln
signal.alarm(300)
client = ln.client("fm_test_system", sys.argv[1])
ports = [client.publish("robot.state", "fmtest/robot/state"), client.subscribe("robot.idle", "fmtest/idle")]
service = client.get_service_provider("robot.move", "fmtest/robot/move")
service.set_handler(lambda request, req, resp: 0)
service.do_register("fm_test")
print(json.dumps({t.name: t.hash for t in client.list_topics()}), flush=True)
sys.stdin.read()
client.close()
"""


@pytest.fixture(scope="module")
def ln(tmp_path_factory):
    manager_exe, env = _ln_core_env()
    home = tmp_path_factory.mktemp("manager")
    md_dir = home / "defs"
    for name, text in DEFINITIONS.items():
        (md_dir / name).parent.mkdir(parents=True, exist_ok=True)
        (md_dir / name).write_text(text)
    server = ln_testing.LnCore(home, base_env=env, home=home, manager_exe=manager_exe)
    started = []
    try:
        address = server.start([md_dir]).address
        with open(home / "system.log", "w") as log:
            started.append(
                subprocess.Popen(
                    [sys.executable, "-c", SYSTEM, address],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=log,
                    text=True,
                    env=env,
                )
            )
        hashes = _read_until(started[0].stdout, lambda line: line.startswith("{"))
        assert hashes, "the test system did not start: %s" % (home / "system.log").read_text()
        yield {"address": address, "md_dir": str(md_dir), "hashes": json.loads(hashes), "env": env}
    finally:
        for process in reversed(started):
            if process.stdin:
                process.stdin.close()
            else:
                process.terminate()
            try:
                process.wait(5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        server.stop()


def _read_until(stream, accept, timeout=15.0):
    """The first line `accept`s, or None at EOF or after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = stream.readline()
        if not line:
            return None
        if accept(line):
            return line
    return None


def run_cli(env, *argv):
    """ln_ros2_gen in a child process: (exit status, stdout, stderr)."""
    result = subprocess.run(
        [sys.executable, "-c", "import sys; from msg_mapping.cli import main; sys.exit(main())", *map(str, argv)],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    return result.returncode, result.stdout, result.stderr


def test_packages_for_what_the_manager_knows(ln, tmp_path):
    status, listing, _ = run_cli(ln["env"], "--from-manager", ln["address"], "--dry-run")
    assert status == 0
    assert "from the LN manager at %s: 3 definitions" % ln["address"] in listing
    for line in (
        "fmtest/robot/state: topic robot.state",
        "fmtest/idle: topic robot.idle",
        "fmtest/robot/move: service robot.move",
        "package fmtest_ln_msgs",
    ):
        assert line in listing, listing
    assert not os.path.exists(tmp_path / "out")

    assert run_cli(ln["env"], "--from-manager", ln["address"], "--out", tmp_path / "out")[0] == 0
    with open(tmp_path / "out" / "fmtest_ln_msgs" / "ln_mapping.json") as f:
        mapping = {i["ln_name"]: i for i in json.load(f)["interfaces"]}
    assert sorted(mapping) == sorted(
        ["fmtest/robot/state", "fmtest/robot/pose", "fmtest/robot/unit", "fmtest/robot/move", "fmtest/idle"]
    )
    assert mapping["fmtest/robot/move"]["kind"] == "service"
    # the versions the running system uses
    assert mapping["fmtest/robot/state"]["ln_hash"] == ln["hashes"]["robot.state"]
    assert mapping["fmtest/idle"]["ln_hash"] == ln["hashes"]["robot.idle"]

    # the same packages as from the files themselves
    assert cli.main(["--recursive", ln["md_dir"], "--out", str(tmp_path / "files")]) == 0
    compare = filecmp.dircmp(tmp_path / "out", tmp_path / "files")
    for level in (
        [compare]
        + list(compare.subdirs.values())
        + [d for sub in compare.subdirs.values() for d in sub.subdirs.values()]
    ):
        assert not (level.left_only or level.right_only or level.diff_files), level.report_full_closure()


def test_unreachable_manager_is_a_clear_error():
    import socket

    _, env = _ln_core_env()
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    status, _, error = run_cli(env, "--from-manager", "127.0.0.1:%d" % port, "--dry-run")
    assert status == 1
    assert "ln_ros2_gen: error: --from-manager 127.0.0.1:%d: cannot reach the LN manager" % port in error, error


def test_definitions_are_fetched_with_what_they_use():
    library = msg_mapping.Library()
    fetched = []

    def fetch(name):
        fetched.append(name)
        library.add_source(name, DEFINITIONS[name])  # KeyError: the manager does not know it

    assert load_fetching(library.load, "fmtest/robot/state", fetch)["packet_size"] == 7 * 8 + 2 + 4
    assert fetched == ["fmtest/robot/state", "fmtest/robot/pose", "fmtest/robot/unit"]
    with pytest.raises(Exception, match="message definition 'fmtest/none' not found"):
        load_fetching(library.load, "fmtest/none", fetch)


def test_missing_definition_names_follow_ln_resolution():
    assert missing_definitions(Exception("message definition 'a/b' not found in these directories: x")) == ["a/b"]
    assert missing_definitions(
        Exception("<a/b/c>:1: define refers to 'd', which is neither next to this file nor in: x")
    ) == ["a/b/d", "d"]
    assert missing_definitions(
        Exception("/defs/a/b/c:3: define refers to 'x/y', which is neither next to this file nor in: x")
    ) == ["x/y"]
    assert missing_definitions(Exception("a/b:1: unknown type 'foo'")) == []
