"""The demo's config, ln_core/examples/elevator/elevator.lnc, run by ln_core's
manager: every command it names exists (`ln_manager --check`), and its LN part
(the `elevator` group: simulator, then controller) comes up in order and
serves the floor-request service; the manager stops it all on SIGTERM. (The
bridge and the ROS 2 listener need the ROS 2 interfaces; demo_bridge.sh runs
them.)

Needs ln_core on PATH and its links_and_nodes importable, as after
`. launchless_scripts/env.sh`.
"""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "support"))
import ln_testing  # noqa: E402

CONFIG = ROOT / "ln_core" / "examples" / "elevator" / "elevator.lnc"
TIMEOUT = 30


def ln_core(tool):
    found = shutil.which(tool)
    if not found:
        ln_testing.skip("ln_core's %s is not on PATH (. launchless_scripts/env.sh)" % tool)
    return found


def ln(address, *args):
    return subprocess.run(
        [sys.executable, "-m", "links_and_nodes.cli", *args, "--ln-manager", address],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )


def test_every_command_of_the_demo_exists():
    result = subprocess.run(
        [ln_core("ln_manager"), "-c", str(CONFIG), "--check"], capture_output=True, text=True, timeout=TIMEOUT
    )
    assert result.returncode == 0, result.stdout + result.stderr
    for name in ("elevator_sim", "elevator_control", "ln_ros2_bridge", "ros_listener"):
        assert "process %s (" % name in result.stdout
    assert "group elevator: elevator_control, elevator_sim" in result.stdout


def test_the_elevator_group_comes_up_in_order_and_stops_with_the_manager(tmp_path):
    manager = ln_testing.LnCore(tmp_path, home=tmp_path, manager_exe=ln_core("ln_manager"))
    try:
        address = manager.start(config=CONFIG, args=["--start", "elevator"]).address
        deadline = time.monotonic() + TIMEOUT
        states = {}
        while time.monotonic() < deadline:
            listed = ln(address, "process", "list", "--json")
            states = {p["name"]: p for p in json.loads(listed.stdout)}
            if states["elevator_control"]["state"] == "ready":
                break
            time.sleep(0.05)  # the manager's account of its processes is what there is to watch
        assert states["elevator_sim"]["state"] == "ready", states
        assert states["elevator_control"]["state"] == "ready", manager.log_path.read_text()
        assert states["ros_listener"]["state"] == "stopped", "only the group was asked for"
        call = ln(address, "service", "call", "elevator03.prompt", "target_floor: 2", "--timeout", "20", "--json")
        assert call.returncode == 0, call.stderr
        assert json.loads(call.stdout)["reached_floor"] == 2
        pids = [states[name]["pid"] for name in ("elevator_sim", "elevator_control")]
    finally:
        code = manager.stop(timeout=TIMEOUT)
    log = manager.log_path.read_text()
    assert code == 0, log
    assert log.index("stopped 'elevator_control'") < log.index("stopped 'elevator_sim'"), "dependents first"
    for pid in pids:
        assert not os.path.exists("/proc/%d" % pid) or open("/proc/%d/stat" % pid).read().split(") ")[1][0] == "Z"
