"""Running things around the bridge without a launch system: an LN manager of
either kind (LN 2.9 or ln_core), a colcon-built interface workspace for LN
definitions, and the environment a process needs to use them. Used by the
tests, the demo (launchless_scripts/demo_bridge.sh) and the benchmark.

Every process started here is ended here, by PID; every wait has a deadline.
"""

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

CACHE = Path(os.environ.get("LN_CORE_CACHE", Path.home() / ".cache" / "ln_core"))


class Unavailable(Exception):
    """A needed component is not installed/built here (tests skip on it)."""


# ---------------------------------------------------------------------------------------------
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
    for candidate in (os.environ.get("LN_NETNS_RUN"), "/work/shared/tools/netns-run",
                      str(Path(__file__).resolve().parents[2] / "shared" / "tools" / "netns-run")):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return shutil.which("netns-run")


LOOPBACK_CYCLONEDDS_URI = (
    "<CycloneDDS><Domain><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
    "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>")


def loopback_dds_env():
    """Environment that keeps DDS on loopback even outside a namespace."""
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "CYCLONEDDS_URI": LOOPBACK_CYCLONEDDS_URI}


# ---------------------------------------------------------------------------------------------
# processes
def start(cmd, log_path, env=None, cwd=None):
    """Starts a process in its own session (so its whole group can be ended)."""
    with open(log_path, "ab") as log:   # the child keeps its own copy of the descriptor
        return subprocess.Popen([str(c) for c in cmd], stdin=subprocess.DEVNULL, stdout=log,
                                stderr=subprocess.STDOUT, env=env, cwd=cwd, start_new_session=True)


def stop(proc, timeout=10.0, sig=signal.SIGINT):
    """Ends a process we started: `sig`, then SIGKILL after `timeout`. Returns its exit status."""
    if proc is None:
        return None
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait(timeout=10)
    return proc.returncode


def remove_ln_segments(pids):
    """Removes LN 2.9 shared-memory segments (/dev/shm/<publisher pid>_..._src) left behind
    by processes we started and that have ended (LN 2.9 sometimes leaves them)."""
    pids = {int(p) for p in pids}
    for entry in Path("/dev/shm").glob("*_src"):
        pid = entry.name.split("_", 1)[0]
        if pid.isdigit() and int(pid) in pids and not Path("/proc", pid).exists():
            try:
                entry.unlink()
            except OSError:
                pass


def wait_for(predicate, timeout, what, interval=0.02):
    """Polls `predicate` until true; raises TimeoutError naming `what`."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise TimeoutError("timed out after %.1f s waiting for %s" % (timeout, what))
        time.sleep(interval)


def wait_for_log(path, pattern, timeout, proc=None):
    rx = re.compile(pattern)

    def found():
        if proc is not None and proc.poll() is not None:
            raise RuntimeError("%s exited (%s) before '%s' appeared:\n%s"
                               % (path, proc.returncode, pattern, tail(path)))
        try:
            return rx.search(Path(path).read_text(errors="replace"))
        except FileNotFoundError:
            return None
    return wait_for(found, timeout, "'%s' in %s" % (pattern, path))


def json_events(path):
    """The JSON objects a process printed to its log, one per line. Only whole lines: the
    process may be in the middle of writing a long one."""
    try:
        text = Path(path).read_text(errors="replace")
    except FileNotFoundError:
        return []
    return [json.loads(line) for line in text[:text.rfind("\n") + 1].splitlines() if line.startswith("{")]


def tail(path, lines=25):
    try:
        return "\n".join(Path(path).read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return "(no %s)" % path


# ---------------------------------------------------------------------------------------------
# LN systems
class LnSystem:
    """An LN manager of one kind plus what its clients need (env, Python path).
    start(md_dirs, port=0) / stop(); restart with start(md_dirs, port=system.port)."""

    kind = ""

    def __init__(self, work_dir):
        self.work_dir = Path(work_dir)
        self.work_dir.mkdir(parents=True, exist_ok=True)
        # Both managers keep definitions their clients put in $HOME/ln_message_definitions/gen
        # (the bridge puts those it derives from ROS types): a home of its own per system.
        self.home = self.work_dir / "home"
        self.home.mkdir(exist_ok=True)
        self.address = ""
        self.manager = None
        self.port = 0

    def python_path(self):
        """PYTHONPATH entry that makes `import links_and_nodes` this system's package."""
        raise NotImplementedError

    def peer_python(self):
        """The interpreter for LN-only helper programs of this system."""
        return sys.executable

    def env(self, base=None):
        env = dict(os.environ if base is None else base)
        env["LN_MANAGER"] = self.address
        env["HOME"] = str(self.home)
        env["PYTHONPATH"] = os.pathsep.join(p for p in [self.python_path(), env.get("PYTHONPATH", "")] if p)
        return env

    def write_config(self, md_dirs, port=0):
        config = self.work_dir / "manager.lnc"
        lines = ["instance", "name: bridge_%s_%d" % (self.kind, os.getpid()), "manager: 127.0.0.1:%d" % port]
        lines += ["add_message_definition_dir: %s" % d for d in md_dirs]
        config.write_text("\n".join(lines) + "\n")
        return config

    def start(self, md_dirs, port=0):
        raise NotImplementedError

    def stop(self, keep_daemons=False):
        stop(self.manager, sig=signal.SIGTERM)
        self.manager = None


def _free_port():
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Ln29(LnSystem):
    """The released LN 2.9: its ln_manager (--isolated-test: private daemon, exits
    with the manager) and its links_and_nodes package."""

    kind = "ln29"

    def __init__(self, work_dir):
        super().__init__(work_dir)
        venv = Path(os.environ.get("LN_CORE_LN29_VENV", CACHE / "venv-ln29"))
        if not (venv / "bin" / "ln_manager").exists():
            raise Unavailable("LN 2.9 venv not found at %s (LN_CORE_LN29_VENV)" % venv)
        self.venv = venv
        self.site = next((venv / "lib").glob("python3*/site-packages"))

    def python_path(self):
        # Only LN's own packages, not its numpy: the ROS venv has its own.
        shim = CACHE / "ln29-pythonpath"
        shim.mkdir(parents=True, exist_ok=True)
        for name in ("links_and_nodes", "links_and_nodes_base", "liblinks_and_nodes", "libstring_util", "pyutils"):
            link = shim / name
            if not link.exists():
                tmp = shim / (name + ".%d" % os.getpid())
                tmp.symlink_to(self.site / name)
                os.replace(tmp, link)
        return str(shim)

    def peer_python(self):
        return str(self.venv / "bin" / "python")

    def env(self, base=None):
        env = super().env(base)           # (LN 2.9 also writes keys into $HOME)
        env["TMPDIR"] = str(self.work_dir)
        return env

    def start(self, md_dirs, port=0):
        """Without `port`: --isolated-test (a free port, a private ln_daemon that ends
        with the manager). With `port` (to restart on the same address): that port,
        and LN's ordinary daemon, which stop() ends by PID."""
        config = self.write_config(md_dirs, port or 54414)
        log = self.work_dir / "manager.log"
        log.write_text("")
        isolated = ["--isolated-test"] if not port else []
        self.manager = start([self.venv / "bin" / "ln_manager", "-c", config, "--without-gui", *isolated,
                              "--log-level", "info"], log, env=self.env())
        if not port:
            port = int(wait_for_log(log, r"isolated-test mode on manager port (\d+)", 60, self.manager).group(1))
        wait_for_log(log, r"listening on .* for ln-clients", 60, self.manager)
        self.port = port
        self.address = "127.0.0.1:%d" % self.port
        return self

    def stop(self, keep_daemons=False):
        started = [self.manager.pid] if self.manager is not None else []
        super().stop()
        remove_ln_segments(started)
        if keep_daemons:
            return
        # The private daemon ends with an --isolated-test manager; anything still running
        # LN 2.9's binaries with our HOME is ours and ended by PID.
        home = ("HOME=%s" % self.home).encode()
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                if not os.readlink(entry / "exe").startswith(str(self.venv)):
                    continue
                if home in (entry / "environ").read_bytes().split(b"\0"):
                    os.kill(int(entry.name), signal.SIGKILL)
            except (OSError, ValueError):
                continue


class LnCore(LnSystem):
    """ln_core: its ln_manager and its links_and_nodes package, found in the colcon
    install, or given by LN_CORE_MANAGER / LN_CORE_PYTHONPATH."""

    kind = "ln_core"

    def __init__(self, work_dir):
        super().__init__(work_dir)
        self.manager_exe, self.package_dir = self.locate()

    @staticmethod
    def locate():
        manager = os.environ.get("LN_CORE_MANAGER") or shutil.which("ln_manager")
        # colcon puts plain CMake packages (ln_core) on CMAKE_PREFIX_PATH, not AMENT_PREFIX_PATH.
        roots = [Path(p) for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH")
                 for p in os.environ.get(var, "").split(os.pathsep) if p]
        if not manager:
            for root in roots:
                if (root / "bin" / "ln_manager").exists():
                    manager = str(root / "bin" / "ln_manager")
                    break
        package = os.environ.get("LN_CORE_PYTHONPATH")
        if not package:
            for entry in os.environ.get("PYTHONPATH", "").split(os.pathsep):
                if entry and (Path(entry) / "links_and_nodes" / "_client.py").exists():
                    package = entry
                    break
        if not package:
            for root in roots:
                for site in root.glob("lib/python3*/site-packages"):
                    if (site / "links_and_nodes" / "_client.py").exists():
                        package = str(site)
        if not manager or not Path(manager).exists() or "venv-ln29" in manager:
            raise Unavailable("ln_core's ln_manager not found (colcon install or LN_CORE_MANAGER)")
        if not package or not (Path(package) / "links_and_nodes" / "_client.py").exists():
            raise Unavailable("ln_core's links_and_nodes package not found (colcon install or LN_CORE_PYTHONPATH)")
        return manager, package

    def python_path(self):
        return self.package_dir

    def start(self, md_dirs, port=0):
        port = port or _free_port()
        config = self.write_config(md_dirs, port)
        log = self.work_dir / "manager.log"
        self.manager = start([self.manager_exe, "-c", config], log, env=self.env())
        self.address = "127.0.0.1:%d" % port
        self.port = port

        def accepting():
            if self.manager.poll() is not None:
                raise RuntimeError("ln_core manager exited:\n%s" % tail(log))
            import socket
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                return True
            except OSError:
                return False
        wait_for(accepting, 30, "ln_core manager on port %d" % port)
        return self


def ln_system(kind, work_dir):
    """LnSystem of `kind` ("ln29" or "ln_core"); raises Unavailable."""
    return {"ln29": Ln29, "ln_core": LnCore}[kind](work_dir)


# ---------------------------------------------------------------------------------------------
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
    gen = [sys.executable, "-c", "import sys; from msg_mapping.cli import main; sys.exit(main())",
           "--out", str(ws / "src")]
    for d in md_dirs:
        gen += ["--recursive", d]
    for cmd in (gen, ["colcon", "build", "--event-handlers", "console_direct-", "desktop_notification-",
                      "--cmake-args", "-DBUILD_TESTING=OFF"]):
        result = subprocess.run(cmd, cwd=ws, stdout=out, stderr=subprocess.STDOUT, timeout=timeout)
        if result.returncode != 0:
            raise RuntimeError("building the interface workspace %s failed: %s (see %s)"
                               % (ws, " ".join(cmd[:3]), log or "its output"))
    stamp.write_text("ok\n")
    for old in ws.parent.glob("%s-*" % name):   # workspaces of earlier versions of the definitions
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
