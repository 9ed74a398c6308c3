#!/usr/bin/env python3
"""The LN <-> ROS 2 elevator demo without a launch system (run by demo_bridge.sh,
inside netns-run): an LN manager, the elevator simulator and controller (Python or
C++, any mix), ln_ros2_bridge, and a ROS 2 listener that watches the sensors and
calls the floor-request service. Everything started here is stopped here, by PID.

    demo.py [--ln ln29|ln_core] [--sim py|cpp] [--control py|cpp] [--cpp-dir DIR] [--floor 3]
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(ROOT / "ln_ros2_bridge"))
from ln_ros2_bridge import support  # noqa: E402

MSGDEFS = ROOT / "ln_core" / "examples" / "elevator" / "msgdefs"


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
    print("demo: network %s; logs in %s" % ("isolated (netns)" if support.network_is_isolated()
                                            else "NOT isolated (LOCALHOST DDS settings)", work))
    print("demo: ROS 2 interfaces for the elevator definitions (ln_ros2_gen + colcon, cached)")
    install = support.build_interfaces([MSGDEFS], "elevator", log=str(work / "interfaces.log"))
    ros_env = support.interface_env(install)
    ros_env.update(support.loopback_dds_env())
    # the bridge from this source tree (the colcon install has the same code once built)
    ros_env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "ln_ros2_bridge"), ros_env.get("PYTHONPATH", "")])

    system = support.ln_system(args.ln, work / args.ln)
    processes = []

    def launch(name, cmd, env, ready=None):
        proc = support.start(cmd, work / ("%s.log" % name), env=env)
        processes.append((name, proc))
        if ready:
            support.wait_for_log(work / ("%s.log" % name), ready, 60, proc)
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
        launch("ln_ros2_bridge", [sys.executable, "-m", "ln_ros2_bridge", "--config", HERE / "bridge.yaml",
                                  "--ln-manager", system.address],
               ln_env, ready="bridging service elevator03.prompt")
        print("demo: ROS 2 listener (rclpy, no LN) ...")
        listener = launch("ros_listener", [sys.executable, HERE / "ros_listener.py", "--floor", str(args.floor)],
                          ros_env)
        try:
            status = listener.wait(timeout=120)
        except Exception:
            print("demo: the listener did not finish within 120 s")
        print(support.tail(work / "ros_listener.log", 12))
    finally:
        for name, proc in reversed(processes):
            code = support.stop(proc)
            print("demo: stopped %-16s exit %s" % (name, code))
        support.remove_ln_segments(proc.pid for _, proc in processes)
        system.stop()
        print("demo: stopped the %s manager" % args.ln)
        if status != 0:
            for name, _ in processes:
                print("---- %s (tail) ----\n%s" % (name, support.tail(work / ("%s.log" % name), 15)))
        if not args.keep and status == 0:
            import shutil
            shutil.rmtree(work, ignore_errors=True)
    print("demo: %s" % ("PASSED" if status == 0 else "FAILED"))
    return status


if __name__ == "__main__":
    sys.exit(main())
