"""ln client list, ln manager status, completion, usage errors, and the
installed `ln` launcher (which hands coreutils' usage to the system's ln)."""

import os
import re
import socket
import subprocess
import time
import types
import uuid

import links_and_nodes as ln
import pytest
from cli_helpers import Providers, no_manager_env, ok, ok_json, one_line_error, run_ln, table  # noqa: F401
from conftest import MSGDEFS
from links_and_nodes.cli import OWN_FIRST_ARGUMENTS

LAUNCHER = os.environ.get("LN_CORE_LN")
needs_launcher = pytest.mark.skipif(not LAUNCHER, reason="LN_CORE_LN (the generated `ln` launcher) not set")


@pytest.fixture(scope="module")
def live(manager):
    unique = uuid.uuid4().hex[:8]
    system = types.SimpleNamespace(topic="cli.misc.%s" % unique, service="cli.misc_svc.%s" % unique)

    def respond(request, req, resp):
        return request.respond() or 0

    with (
        ln.client("cli_misc_publisher") as system.publisher,
        ln.client("cli_misc_subscriber") as system.subscriber,
        Providers.serving("cli_misc_provider", (system.service, "pytest/sleep", respond)) as system.providers,
    ):
        system.port = system.publisher.publish(system.topic, "counter/count_message")
        system.sub_port = system.subscriber.subscribe(system.topic, "counter/count_message")
        yield system


# ---------------------------------------------------------------- clients


def test_client_list(manager, live):
    clients = {c["name"]: c for c in ok_json(run_ln(manager, "client", "list", "--json"))}
    assert not any(name.startswith("ln_cli") for name in clients)  # not the command itself
    publisher = clients["cli_misc_publisher"]
    assert publisher["pid"] == os.getpid() and publisher["host"] == socket.gethostname()
    assert publisher["published"] == [live.topic] and publisher["subscribed"] == [] and publisher["services"] == []
    assert clients["cli_misc_subscriber"]["subscribed"] == [live.topic]
    assert clients["cli_misc_provider"]["services"] == [live.service]
    assert isinstance(publisher["id"], int) and publisher["host_id"]

    rows = table(ok(run_ln(manager, "client", "list")))
    assert rows[0] == ["CLIENT", "PID", "HOST", "PUBLISHES", "SUBSCRIBES", "SERVICES"]
    row = next(r for r in rows if r[0] == "cli_misc_provider")
    assert row == ["cli_misc_provider", str(os.getpid()), socket.gethostname(), "-", "-", live.service]


def test_manager_status(manager, live):
    status = ok_json(run_ln(manager, "manager", "status", "--json"))
    assert status["pid"] == manager.process.pid and status["address"] == manager.address
    assert status["clients"] >= 4 and status["topics"] >= 1 and status["services"] >= 1  # this command included
    assert 0 < status["uptime"] < 3600 and status["version"]
    assert MSGDEFS in status["message_definition_dirs"]
    text = ok(run_ln(manager, "manager", "status"))
    assert re.search(r"^address +%s$" % re.escape(manager.address), text, re.M)
    assert "message definition dirs:\n" in text and "  " + MSGDEFS in text


def test_no_manager(manager, no_manager_env):
    for args in (["client", "list"], ["manager", "status", "--json"]):
        one_line_error(run_ln(None, *args, env=no_manager_env), "cannot reach the ln_manager")


# ------------------------------------------------------------- completion


def complete(manager, line, word=None, **env):
    args = ["__complete", line] + ([word] if word is not None else [])
    return ok(run_ln(manager, *args, **env)).split()


def test_completion_script(manager):
    script = ok(run_ln(manager, "completion", "bash"))
    assert "complete -o bashdefault -o default -F _ln_complete ln" in script
    assert "__complete" in script and "timeout" in script
    one_line_error(run_ln(manager, "completion", "tcsh"), "invalid choice")


def test_completion_of_commands_and_options(manager):
    assert complete(manager, "ln ") == [
        "bag",
        "client",
        "completion",
        "group",
        "manager",
        "md",
        "param",
        "play",
        "process",
        "record",
        "ros",
        "service",
        "state",
        "topic",
    ]
    import importlib.util

    if importlib.util.find_spec("ln_bag") is not None:  # recordings come from the ln_bag package
        assert complete(manager, "ln bag ") == ["convert", "info"]
        assert complete(manager, "ln record --e") == ["--exclude"]
    else:
        one_line_error(run_ln(manager, "record", "a.b"), "recordings need the ln_bag package", "colcon build")
        one_line_error(run_ln(manager, "bag", "convert", "a", "b", "--overwrite"), "recordings need the ln_bag package")
    assert complete(manager, "ln ros ") == ["node", "service", "topic"]
    assert complete(manager, "ln ros topic ") == ["echo", "hz", "info", "list"]
    assert complete(manager, "ln to") == ["topic"]
    assert complete(manager, "ln topic ") == ["bw", "echo", "hz", "info", "list", "pub"]
    assert complete(manager, "ln topic echo --c") == ["--color", "--count", "--csv"]
    assert complete(manager, "ln --color ") == ["always", "auto", "never"]
    assert complete(manager, "ln completion ") == ["bash"]
    assert complete(manager, "ln -s ") == []  # the system's ln: bash completes files
    assert complete(manager, "ln md generate ") == []


def test_completion_of_live_names(manager, live):
    assert live.topic in complete(manager, "ln topic echo cli.misc")
    assert complete(manager, "ln topic hz --buffers 2 %s" % live.topic[:-2]) == [live.topic]
    assert complete(manager, "ln service call cli.misc_s") == [live.service]
    assert "pytest/all_types" in complete(manager, "ln md show pytest/")
    assert complete(manager, "ln topic pub x -t counter/") == ["counter/count_message"]
    # bash splits at ':' (COMP_WORDBREAKS); the answer completes bash's current word
    assert complete(manager, "ln md show area_service/c", "area_service/c") == ["area_service/circle_area"]


def test_completion_without_a_manager_is_quick_and_empty(manager, no_manager_env):
    start = time.monotonic()
    result = run_ln(None, "__complete", "ln topic echo ", env=no_manager_env)
    assert ok(result) == "" and time.monotonic() - start < 10


@needs_launcher
def test_bash_uses_the_script(manager, live, tmp_path):
    env = manager.env(PATH=os.path.dirname(LAUNCHER) + os.pathsep + os.environ["PATH"])
    line = "ln topic info cli.misc"
    script = (
        'source <(ln completion bash)\n'
        'COMP_LINE="%s"; COMP_POINT=${#COMP_LINE}; COMP_WORDS=(ln topic info cli.misc); COMP_CWORD=3\n'
        '_ln_complete; printf "%%s\\n" "${COMPREPLY[@]}"\n' % line
    )
    result = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True, timeout=30)
    assert live.topic in result.stdout.split(), result.stderr


# ----------------------------------------------------------------- usage


def test_usage(manager):
    result = run_ln(manager)
    assert result.returncode == 2 and "usage: ln" in result.stdout and "topic" in result.stdout
    result = run_ln(manager, "topic")
    assert result.returncode == 2 and "usage: ln topic" in result.stdout and "echo" in result.stdout
    assert "usage: ln topic echo" in ok(run_ln(manager, "topic", "echo", "--help"))
    one_line_error(run_ln(manager, "topic", "echo"), "TOPIC", "ln topic echo --help")
    one_line_error(run_ln(manager, "topic", "list", "--bogus"), "unrecognized arguments: --bogus")
    one_line_error(run_ln(manager, "topic", "nope"), "invalid choice")
    one_line_error(run_ln(manager, "topic", "hz", "x", "--window", "-3"), "--window")


def test_anything_else_is_the_system_ln(tmp_path):
    target = tmp_path / "target"
    target.write_text("x")
    result = run_ln(None, "-s", str(target), str(tmp_path / "symlink"))
    assert result.returncode == 0, result.stderr
    assert os.readlink(tmp_path / "symlink") == str(target)
    assert run_ln(None, str(target), str(tmp_path / "hardlink")).returncode == 0
    assert os.stat(tmp_path / "hardlink").st_ino == os.stat(target).st_ino
    assert run_ln(None, str(tmp_path / "missing"), str(tmp_path / "x")).returncode != 0


@needs_launcher
def test_launcher(manager, live, tmp_path):
    def launch(*args):
        return subprocess.run(
            [LAUNCHER, *args], env=manager.env(), capture_output=True, text=True, timeout=30, cwd=str(tmp_path)
        )

    assert "usage: ln" in ok(launch("--help"))
    assert any(c["name"] == "cli_misc_publisher" for c in ok_json(launch("client", "list", "--json")))
    (tmp_path / "target").write_text("x")
    assert launch("-sf", "target", "link").returncode == 0 and os.readlink(tmp_path / "link") == "target"
    assert "coreutils" in launch("--version").stdout.lower()


@needs_launcher
def test_launcher_routes_the_same_words_as_the_package():
    with open(LAUNCHER) as f:
        case_line = next(line for line in f if line.strip().startswith('""|'))
    words = {w.rstrip("*").rstrip("=") for w in case_line.strip().rstrip(") ;").split("|") if w not in ('""',)}
    assert words == set(OWN_FIRST_ARGUMENTS)


def test_ln_ros_without_rclpy_is_one_clear_line():
    """`ln` never needs ROS; `ln ros ...` needs rclpy only when run, and says so when it is missing
    (the rest of `ln ros` runs against ROS peers in ln_ros2_bridge/test/test_ln_ros_cli.py)."""
    import sys

    code = (
        "import sys; sys.modules['rclpy'] = None\n"  # as if rclpy were not installed
        "import links_and_nodes.cli as cli\n"
        "cli.build_parser()\n"
        "assert not [m for m in sys.modules if m.startswith('rclpy') and sys.modules[m] is not None]\n"
        "sys.exit(cli.main(sys.argv[1:]))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code, "ros", "topic", "list"], capture_output=True, text=True, timeout=60
    )
    one_line_error(result, "'ln ros' needs ROS 2 Jazzy's Python packages (rclpy)", "source launchless_scripts/env.sh")
    helped = subprocess.run([sys.executable, "-c", code, "ros", "--help"], capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0 and "node" in helped.stdout and "service" in helped.stdout
