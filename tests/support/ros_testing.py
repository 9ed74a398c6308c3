"""ROS 2 side of the Python tests, benchmarks and the demo: keeping DDS on this machine
(a private network namespace, or loopback-only settings) and colcon-built interface
workspaces for LN definitions. Not installed with any package (see ln_testing.py).
"""

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

from ln_testing import CACHE, REPO_ROOT


# isolation
def network_is_isolated():
    """True inside a network namespace with nothing but loopback (netns-run).
    (/sys/class/net would show the namespace of whoever mounted /sys.)"""
    import socket

    try:
        return [name for _, name in socket.if_nameindex()] == ["lo"]
    except OSError:
        return False


def netns_run():
    for candidate in (
        os.environ.get("LN_NETNS_RUN"),
        "/work/shared/tools/netns-run",
        str(REPO_ROOT / "shared" / "tools" / "netns-run"),
    ):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return shutil.which("netns-run")


LOOPBACK_CYCLONEDDS_URI = (
    "<CycloneDDS><Domain><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
    "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>"
)


def loopback_dds_env():
    """Environment that keeps DDS on loopback even outside a namespace."""
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "CYCLONEDDS_URI": LOOPBACK_CYCLONEDDS_URI}


# interface workspaces
def _digest(paths):
    h = hashlib.sha256()
    for root in paths:
        for f in sorted(Path(root).rglob("*")):
            if f.is_file():
                h.update(str(f.relative_to(root)).encode())
                h.update(f.read_bytes())
    return h.hexdigest()[:16]


def build_interfaces(md_dirs, name, log=None, timeout=900):
    """A colcon workspace with the ROS interfaces ln_ros2_gen makes for every LN
    definition under `md_dirs`; rebuilt only when a definition changed.
    Returns its install/ directory."""
    md_dirs = [str(Path(d).resolve()) for d in md_dirs]
    ws = CACHE / "ln_ros2_bridge" / ("%s-%s" % (name, _digest(md_dirs)))
    install = ws / "install"
    stamp = ws / "built.stamp"
    if stamp.exists():
        return install
    if ws.exists():
        shutil.rmtree(ws)
    (ws / "src").mkdir(parents=True)
    out = open(log or os.devnull, "ab")
    gen = [
        sys.executable,
        "-c",
        "import sys; from msg_mapping.cli import main; sys.exit(main())",
        "--out",
        str(ws / "src"),
    ]
    for d in md_dirs:
        gen += ["--recursive", d]
    for cmd in (
        gen,
        [
            "colcon",
            "build",
            "--event-handlers",
            "console_direct-",
            "desktop_notification-",
            "--cmake-args",
            "-DBUILD_TESTING=OFF",
        ],
    ):
        result = subprocess.run(cmd, cwd=ws, stdout=out, stderr=subprocess.STDOUT, timeout=timeout)
        if result.returncode != 0:
            raise RuntimeError(
                "building the interface workspace %s failed: %s (see %s)" % (ws, " ".join(cmd[:3]), log or "its output")
            )
    stamp.write_text("ok\n")
    for old in ws.parent.glob("%s-*" % name):  # workspaces of earlier versions of the definitions
        if old != ws:
            shutil.rmtree(old, ignore_errors=True)
    return install


def interface_env(install, base=None):
    """Environment entries that make the packages in `install` usable (what setup.bash adds)."""
    env = dict(os.environ if base is None else base)
    for pkg in sorted(Path(install).iterdir()):
        if not pkg.is_dir():
            continue
        env["AMENT_PREFIX_PATH"] = os.pathsep.join([str(pkg)] + [p for p in [env.get("AMENT_PREFIX_PATH")] if p])
        env["LD_LIBRARY_PATH"] = os.pathsep.join([str(pkg / "lib")] + [p for p in [env.get("LD_LIBRARY_PATH")] if p])
        for site in pkg.glob("lib/python3*/site-packages"):
            env["PYTHONPATH"] = os.pathsep.join([str(site)] + [p for p in [env.get("PYTHONPATH")] if p])
    return env
