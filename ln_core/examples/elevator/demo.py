#!/usr/bin/env python3
"""The LN <-> ROS 2 elevator demo without a launch system (run by demo_bridge.sh,
inside netns-run): an LN manager, the elevator simulator and controller (Python or
C++, any mix), ln_ros2_bridge, and a ROS 2 listener that watches the sensors and
calls the floor-request service.

With ln_core, its ln_manager runs them all from one config, elevator.lnc, in
dependency order and with readiness, and stops them when it stops. With LN 2.9
this script starts them itself. Everything started here is stopped here, by PID.

    demo.py [--ln ln29|ln_core] [--sim py|cpp] [--control py|cpp] [--cpp-dir DIR] [--floor 3]
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent.parent
sys.path.insert(0, str(ROOT / "tests" / "support"))
import ln_testing  # noqa: E402
import ros_testing  # noqa: E402

MSGDEFS = HERE / "msgdefs"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ln", default="ln29", choices=["ln29", "ln_core"])
    parser.add_argument("--sim", default="py", choices=["py", "cpp"])
    parser.add_argument("--control", default="py", choices=["py", "cpp"])
    parser.add_argument("--cpp-dir", help="where build.sh put the C++ programs")
    parser.add_argument("--floor", type=int, default=3)
    parser.add_argument("--keep", action="store_true", help="keep the work directory (logs)")
    args = parser.parse_args()

    work = Path(tempfile.mkdtemp(prefix="elevator-demo-"))
    print(
        "demo: network %s; logs in %s"
        % ("isolated (netns)" if ros_testing.network_is_isolated() else "NOT isolated (LOCALHOST DDS settings)", work)
    )
    print("demo: ROS 2 interfaces for the elevator definitions (ln_ros2_gen + colcon, cached)")
    install = ros_testing.build_interfaces([MSGDEFS], "elevator", log=str(work / "interfaces.log"))
    ros_env = ros_testing.interface_env(install)
    ros_env.update(ros_testing.loopback_dds_env())
    # the bridge from this source tree (the colcon install has the same code once built)
    ros_env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "ln_ros2_bridge"), ros_env.get("PYTHONPATH", "")])

    if args.ln == "ln_core":
        return run_with_lnc(args, work, ros_env)
    system = ln_testing.ln_system(args.ln, work / args.ln)
    processes = []

    def launch(name, cmd, env, ready=None):
        proc = ln_testing.start(cmd, work / ("%s.log" % name), env=env)
        processes.append((name, proc))
        if ready:
            ln_testing.wait_for_log(work / ("%s.log" % name), ready, 60, proc)
        print("demo: started %-16s pid %d" % (name, proc.pid))
        return proc

    status = 1
    try:
        system.start([str(MSGDEFS)])
        print("demo: %s manager at %s" % (args.ln, system.address))
        ln_env = system.env(ros_env)
        for role, lang in (("sim", args.sim), ("control", args.control)):
            if lang == "py":
                cmd = [system.peer_python(), HERE / ("elevator_%s.py" % role)]
            else:
                if not args.cpp_dir:
                    raise SystemExit("demo: --%s cpp needs --cpp-dir (build.sh %s DIR)" % (role, args.ln))
                cmd = [Path(args.cpp_dir) / ("elevator_%s" % role)]
            launch("elevator_%s.%s" % (role, lang), cmd, ln_env, ready="ready")
        launch(
            "ln_ros2_bridge",
            [sys.executable, "-m", "ln_ros2_bridge", "--config", HERE / "bridge.yaml", "--ln-manager", system.address],
            ln_env,
            ready="bridging service elevator03.prompt",
        )
        print("demo: ROS 2 listener (rclpy, no LN) ...")
        listener = launch(
            "ros_listener", [sys.executable, HERE / "ros_listener.py", "--floor", str(args.floor)], ros_env
        )
        try:
            status = listener.wait(timeout=120)
        except Exception:
            print("demo: the listener did not finish within 120 s")
        print(ln_testing.tail(work / "ros_listener.log", 12))
    finally:
        for name, proc in reversed(processes):
            code = ln_testing.stop(proc)
            print("demo: stopped %-16s exit %s" % (name, code))
        ln_testing.remove_ln_segments(proc.pid for _, proc in processes)
        system.stop()
        print("demo: stopped the %s manager" % args.ln)
        if status != 0:
            for name, _ in processes:
                print("---- %s (tail) ----\n%s" % (name, ln_testing.tail(work / ("%s.log" % name), 15)))
        if not args.keep and status == 0:
            import shutil

            shutil.rmtree(work, ignore_errors=True)
    print("demo: %s" % ("PASSED" if status == 0 else "FAILED"))
    return status


def run_with_lnc(args, work, ros_env):
    """ln_core: `ln_manager -c elevator.lnc --start ros_listener` starts the listener and
    what it depends on (the bridge, the controller, the simulator), each once what it
    needs is ready; this shows how the processes come up, the listener's output, and
    stops the manager, which stops them all in reverse order."""
    import signal
    import time

    manager_exe, package = ln_testing.LnCore.locate()
    env = dict(ros_env, ELEVATOR_SIM=args.sim, ELEVATOR_CONTROL=args.control, ELEVATOR_FLOOR=str(args.floor))
    env["PYTHONPATH"] = os.pathsep.join(p for p in [package, env.get("PYTHONPATH", "")] if p)
    if args.cpp_dir:
        env["ELEVATOR_CPP_DIR"] = str(args.cpp_dir)
    log = work / "manager.log"
    command = [manager_exe, "-c", HERE / "elevator.lnc", "-p", "0", "--start", "ros_listener"]
    print("demo: $ %s" % " ".join(str(c) for c in command))
    manager = ln_testing.start(command, log, env=env)
    status = 1
    try:
        found = ln_testing.wait_for_log(log, r"ln_manager: listening on (\S+)", 30, manager)
        address = found.group(1)
        os.environ["PYTHONPATH"] = env["PYTHONPATH"]
        sys.path.insert(0, package)
        import links_and_nodes as ln

        clnt = ln.client("elevator_demo", address)
        try:
            seen = {}
            deadline = time.monotonic() + 180
            listener = None
            while time.monotonic() < deadline:
                for p in clnt.list_processes():
                    shown = (p.state, p.pid)
                    if p.kind == "process" and seen.get(p.name) != shown:
                        seen[p.name] = shown
                        print("demo: %-16s %-9s%s" % (p.name, p.state, " pid %d" % p.pid if p.pid else ""))
                    if p.name == "ros_listener":
                        listener = p
                if listener is not None and listener.state in ("stopped", "failed") and listener.last_exit:
                    break
                time.sleep(0.1)  # watching the manager's account of its processes
            print("demo: ros_listener's output:")
            for line in clnt.get_process_output("ros_listener").lines:
                if not line.startswith("[ln_manager]"):
                    print("  " + line)
            if listener is None or not listener.last_exit:
                print("demo: the listener did not finish within 180 s")
            elif listener.last_exit == "exit status 0":
                status = 0
            else:
                print(
                    "demo: the listener ended with %s%s"
                    % (listener.last_exit, ": " + listener.error if listener.error else "")
                )
        finally:
            clnt.close()
    finally:
        code = ln_testing.stop(manager, sig=signal.SIGTERM, timeout=60)
        print("demo: the manager stopped its processes, dependents first, and exited (%s)" % code)
        stopped = [line.split(": ", 2)[-1] for line in ln_testing.tail(log, 40).splitlines() if "stopped '" in line]
        for line in stopped:
            print("demo:   " + line)
        if status != 0:
            print("---- manager log (tail) ----\n%s" % ln_testing.tail(log, 40))
    print("demo: %s" % ("PASSED" if status == 0 else "FAILED"))
    if status == 0 and not args.keep:
        import shutil

        shutil.rmtree(work, ignore_errors=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
