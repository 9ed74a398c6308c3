"""The one helper of the Python tests and benchmarks: an LN manager of either kind
(ln_core's or LN 2.9's) started and stopped, readiness waits with deadlines (also for a
thread to block in the call under test), free ports, processes started and ended by
PID, and skipping (failing under CI) when a prerequisite is missing.

It is not installed with any package: test and benchmark code puts this directory
on sys.path (conftest.py files, bench/ln/harness.py, the demo):

    sys.path.insert(0, str(REPO_ROOT / "tests" / "support"))
    import ln_testing

Standard library only (pytest is imported where a skip needs it).

    system = ln_testing.ln_system("ln_core", tmp_path)      # or "ln29"; Unavailable if missing
    system.start([md_dir])                                  # returns once it accepts clients
    subprocess.run([...], env=system.env())                 # LN_MANAGER, HOME, PYTHONPATH
    system.stop()
"""

from __future__ import annotations

import glob
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TypeVar

REPO_ROOT = Path(__file__).resolve().parents[2]
CACHE = Path(os.environ.get("LN_CORE_CACHE", Path.home() / ".cache" / "ln_core"))
#: Under CI a missing prerequisite is an error, not a skip.
IN_CI = bool(os.environ.get("CI"))
#: Time a manager gets to start listening (LN 2.9's, a Python program, needs seconds on a loaded machine).
MANAGER_START_TIMEOUT = 60.0

T = TypeVar("T")


class Unavailable(Exception):
    """A prerequisite (a manager, the LN 2.9 reference, a tool) is not available here."""


def require(thing: T, what: str = "") -> T:
    """`thing`, unless it is None or an Unavailable: then skips the test with the
    reason (fails it when CI is set)."""
    if thing is None or isinstance(thing, Unavailable):
        skip(str(thing) if thing is not None else what)
    return thing


def skip(reason: str):
    """Skips the current test naming `reason`; under CI fails it instead."""
    import pytest

    if IN_CI:
        pytest.fail(f"{reason} (CI is set, so this is an error, not a skip)", pytrace=False)
    pytest.skip(reason)


# ---------------------------------------------------------------------------------------------
# waiting, ports, processes
def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nobody listens on right now."""
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def wait_for(predicate: Callable[[], T], timeout: float, what: str, interval: float = 0.02) -> T:
    """Polls `predicate` until it returns something true and returns that; raises
    TimeoutError naming `what` after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise TimeoutError("timed out after %.1f s waiting for %s" % (timeout, what))
        time.sleep(interval)


def wait_asleep(tid: int, timeout: float, what: str, pid: int | str = "self", looks: int = 3) -> None:
    """Waits until thread `tid` of process `pid` (a threading.Thread's native_id; a
    process's PID for its main thread) sleeps in the kernel -- in the blocking call it
    was started for -- on `looks` looks in a row 20 ms apart (a Python thread may sleep
    on the GIL for a moment; between our looks the GIL is free). Linux: reads
    /proc/PID/task/TID/stat; raises TimeoutError naming `what`."""
    stat = Path("/proc", str(pid), "task", str(tid), "stat")
    in_a_row = [0]

    def asleep():
        text = read_text(stat)
        state = text[text.rfind(")") + 2 : text.rfind(")") + 3] if ")" in text else ""
        in_a_row[0] = in_a_row[0] + 1 if state == "S" else 0
        return in_a_row[0] >= looks

    wait_for(asleep, timeout, what)


def wait_for_log(path, pattern: str, timeout: float, proc: subprocess.Popen | None = None) -> re.Match:
    """Waits until `pattern` appears in the file `path`; raises RuntimeError when
    `proc` exits first, TimeoutError after `timeout` seconds."""
    rx = re.compile(pattern)

    def found():
        if proc is not None and proc.poll() is not None:
            # the process may have written the line just before it ended
            match = rx.search(read_text(path))
            if match:
                return match
            raise RuntimeError(
                "%s exited (%s) before '%s' appeared:\n%s" % (path, proc.returncode, pattern, tail(path))
            )
        return rx.search(read_text(path))

    return wait_for(found, timeout, "'%s' in %s" % (pattern, path))


def overridden(env: dict[str, str], extra: Mapping[str, str | None]) -> dict[str, str]:
    """`env` with the variables of `extra` set, or removed where their value is None."""
    for key, value in extra.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    return env


def read_text(path) -> str:
    try:
        return Path(path).read_text(errors="replace")
    except FileNotFoundError:
        return ""


def tail(path, lines: int = 25) -> str:
    try:
        return "\n".join(Path(path).read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return "(no %s)" % path


def json_events(path) -> list:
    """The JSON objects a process printed to its log, one per line. Only whole lines: the
    process may be in the middle of writing a long one."""
    text = read_text(path)
    return [json.loads(line) for line in text[: text.rfind("\n") + 1].splitlines() if line.startswith("{")]


def start(cmd, log_path, env: Mapping[str, str] | None = None, cwd=None) -> subprocess.Popen:
    """Starts a process in its own session (so its whole group can be ended), its
    stdout and stderr appended to `log_path`."""
    with open(log_path, "ab") as log:  # the child keeps its own copy of the descriptor
        return subprocess.Popen(
            [str(c) for c in cmd],
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            env=env,
            cwd=cwd,
            start_new_session=True,
        )


def stop(
    proc: subprocess.Popen | None, timeout: float = 10.0, sig: int = signal.SIGINT, group: bool = True
) -> int | None:
    """Ends a process started by start(): `sig` to its group (to it alone unless
    `group`), SIGKILL to the group after `timeout`. Returns its exit status."""
    if proc is None:
        return None
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, sig) if group else proc.send_signal(sig)
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


def remove_ln_segments(pids: Iterable[int]) -> list[str]:
    """Removes LN 2.9 shared-memory segments (/dev/shm/<publisher pid>_...) left behind by
    processes we started and that have ended (LN 2.9 sometimes leaves them). Returns
    the names removed."""
    pids = {int(p) for p in pids}
    removed = []
    try:
        entries = list(Path("/dev/shm").iterdir())
    except OSError:
        return removed
    for entry in entries:
        pid = entry.name.split("_", 1)[0]
        if "_" in entry.name and pid.isdigit() and int(pid) in pids and not Path("/proc", pid).exists():
            try:
                entry.unlink()
                removed.append(entry.name)
            except OSError:
                pass
    return removed


def marked_processes(exe_prefix, mark: str) -> list[int]:
    """PIDs whose executable lies below `exe_prefix` and whose environment holds the
    entry `mark` ("NAME=value"): processes we started that detached (LN 2.9's daemons)."""
    found = []
    prefix = str(Path(exe_prefix).resolve())
    entry = mark.encode()
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            if os.readlink(proc / "exe").startswith(prefix) and entry in (proc / "environ").read_bytes().split(b"\0"):
                found.append(int(proc.name))
        except (OSError, ValueError):
            continue
    return found


# ---------------------------------------------------------------------------------------------
# locating ln_core and LN 2.9
def _is_elf(path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(4) == b"\x7fELF"
    except OSError:
        return False


def _prefix_roots() -> list[Path]:
    # colcon puts plain CMake packages (ln_core) on CMAKE_PREFIX_PATH, not AMENT_PREFIX_PATH.
    return [
        Path(p)
        for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH")
        for p in os.environ.get(var, "").split(os.pathsep)
        if p
    ]


def ln_core_manager() -> str:
    """ln_core's ln_manager: LN_CORE_MANAGER, LN_CORE_BUILD_DIR/ln_manager, the one on
    PATH (LN 2.9's is a Python script, not it), or the colcon install. Raises Unavailable."""
    given = os.environ.get("LN_CORE_MANAGER")
    if given:
        if not os.path.isfile(given):
            raise Unavailable("LN_CORE_MANAGER=%s does not exist" % given)
        return given
    build = os.environ.get("LN_CORE_BUILD_DIR")
    candidates = [Path(build) / "ln_manager"] if build else []
    candidates += [Path(d or ".") / "ln_manager" for d in os.environ.get("PATH", "").split(os.pathsep)]
    candidates += [root / "bin" / "ln_manager" for root in _prefix_roots()]
    for candidate in candidates:
        if candidate.is_file() and _is_elf(candidate):
            return str(candidate)
    raise Unavailable("ln_core's ln_manager not found (set LN_CORE_MANAGER, or . launchless_scripts/env.sh)")


def ln_core_python_path() -> str:
    """The directory holding ln_core's links_and_nodes package: LN_CORE_PYTHONPATH, an
    entry of PYTHONPATH, or the colcon install. Raises Unavailable."""

    def holds_package(directory) -> bool:
        return bool(directory) and (Path(directory) / "links_and_nodes" / "_client.py").exists()

    given = os.environ.get("LN_CORE_PYTHONPATH")
    if given:
        if not holds_package(given):
            raise Unavailable("LN_CORE_PYTHONPATH=%s holds no links_and_nodes package" % given)
        return given
    candidates = os.environ.get("PYTHONPATH", "").split(os.pathsep)
    candidates += [
        site for root in _prefix_roots() for site in sorted(glob.glob(str(root / "lib" / "python3*" / "site-packages")))
    ]
    for candidate in candidates:
        if holds_package(candidate):
            return candidate
    raise Unavailable(
        "ln_core's links_and_nodes package not found (set LN_CORE_PYTHONPATH, or . launchless_scripts/env.sh)"
    )


def ln29_venv() -> Path:
    """The LN 2.9 reference venv: LN_CORE_LN29_VENV, else <cache>/venv-ln29, else
    /tmp/ref/ln29. Raises Unavailable."""
    given = os.environ.get("LN_CORE_LN29_VENV")
    candidates = [Path(given)] if given else [CACHE / "venv-ln29", Path("/tmp/ref/ln29")]
    for venv in candidates:
        if (venv / "bin" / "ln_manager").is_file() and glob.glob(str(venv / "lib" / "python3*" / "site-packages")):
            return venv.resolve()
    raise Unavailable(
        "no LN 2.9 reference venv at %s (set LN_CORE_LN29_VENV; launchless_scripts/setup.sh "
        "installs it)" % " or ".join(map(str, candidates))
    )


def ln29_site_packages(venv: Path) -> Path:
    return Path(sorted(glob.glob(str(venv / "lib" / "python3*" / "site-packages")))[-1])


#: Variables that would make LN 2.9's manager (a Python program) or a program linked with a
#: RUNPATH load ln_core's code, as `. launchless_scripts/env.sh` sets them.
FOREIGN_CODE_VARIABLES = ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "LD_LIBRARY_PATH", "LD_PRELOAD")


# ---------------------------------------------------------------------------------------------
# managers
class LnSystem:
    """An LN manager of one kind plus what its clients need (env, Python path).

    start(md_dirs) waits until the manager accepts clients; `address` is then
    "127.0.0.1:PORT". stop() ends it and whatever it started. Restart on the same
    address with start(md_dirs, port=system.port).

    `base_env` (default os.environ) is the environment of the manager and, through
    env(), of its clients; `home` (default <work_dir>/home) their HOME: both managers
    keep generated definitions and keys there."""

    kind = ""

    def __init__(self, work_dir, base_env: Mapping[str, str] | None = None, home=None):
        self.work_dir = Path(work_dir)
        self.work_dir.mkdir(parents=True, exist_ok=True)
        self.home = Path(home) if home is not None else self.work_dir / "home"
        self.home.mkdir(parents=True, exist_ok=True)
        self.base_env = dict(os.environ if base_env is None else base_env)
        self.log_path = self.work_dir / "manager.log"
        self.address = ""
        self.manager: subprocess.Popen | None = None
        self.port = 0

    @property
    def process(self) -> subprocess.Popen | None:
        return self.manager

    def python_path(self) -> str:
        """PYTHONPATH entry that makes `import links_and_nodes` this system's package."""
        raise NotImplementedError

    def peer_python(self) -> str:
        """The interpreter for LN-only helper programs of this system."""
        return sys.executable

    def env(self, base: Mapping[str, str] | None = None, **extra: str | None) -> dict[str, str]:
        """Environment of a client of this manager: `base` (default base_env) with
        LN_MANAGER, HOME and this system's Python package first on PYTHONPATH, then
        `extra` (a value of None removes the variable)."""
        env = dict(self.base_env if base is None else base)
        env["LN_MANAGER"] = self.address
        env["HOME"] = str(self.home)
        env["PYTHONPATH"] = os.pathsep.join(p for p in [self.python_path(), env.get("PYTHONPATH", "")] if p)
        return overridden(env, extra)

    def write_config(self, md_dirs, port: int = 0, extra_config: str = "") -> Path:
        config = self.work_dir / "manager.lnc"
        lines = [
            "instance",
            "name: test_%s_%d_%s" % (self.kind, os.getpid(), uuid.uuid4().hex[:6]),
            "manager: 127.0.0.1:%d" % port,
        ]
        lines += ["add_message_definition_dir: %s" % d for d in md_dirs]
        config.write_text("\n".join(lines) + "\n" + extra_config)
        return config

    def start(
        self,
        md_dirs=(),
        port: int = 0,
        extra_config: str = "",
        timeout: float = MANAGER_START_TIMEOUT,
        config=None,
        args=(),
    ):
        """Starts the manager with `md_dirs` on its search path and `extra_config`
        (more .lnc text) on `port` (0: a free one), or with the .lnc file `config`,
        and more ln_manager options `args`; returns self once it accepts clients."""
        raise NotImplementedError

    def stop(self, keep_daemons: bool = False, timeout: float = 10.0) -> int | None:
        """SIGTERM to the manager, SIGKILL after `timeout`; returns its exit status."""
        started = [self.manager.pid] if self.manager is not None else []
        # The manager alone: it stops the processes it runs itself, in order.
        code = stop(self.manager, timeout, signal.SIGTERM, group=False)
        self.manager = None
        remove_ln_segments(started)
        return code

    def log_tail(self, lines: int = 40) -> str:
        return tail(self.log_path, lines)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
        return False


class Ln29(LnSystem):
    """The released LN 2.9: its ln_manager and its links_and_nodes package.

    Without a port, the manager runs with --isolated-test (a free port, a private
    ln_daemon that ends with the manager); with one, LN's ordinary daemon on a free
    arbiter port (LN_ARBITER_PORT). Every process of the venv that carries this
    system's mark in its environment is ended by PID in stop()."""

    kind = "ln29"

    def __init__(self, work_dir, base_env=None, home=None, venv=None):
        super().__init__(work_dir, base_env, home)
        self.venv = Path(venv) if venv is not None else ln29_venv()
        self.site = ln29_site_packages(self.venv)
        self.mark = "LN_TESTING_MARK=%s" % uuid.uuid4().hex

    @property
    def ln_manager(self) -> Path:
        return self.venv / "bin" / "ln_manager"

    def python_path(self) -> str:
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

    def peer_python(self) -> str:
        return str(self.venv / "bin" / "python")

    def env(self, base=None, **extra):
        env = super().env(base, **extra)  # (LN 2.9 also writes keys into $HOME)
        env.setdefault("TMPDIR", str(self.work_dir))
        return env

    def manager_env(self) -> dict[str, str]:
        env = {k: v for k, v in self.base_env.items() if k not in FOREIGN_CODE_VARIABLES and k != "LN_MANAGER"}
        env.update(HOME=str(self.home), TMPDIR=env.get("TMPDIR", str(self.work_dir)))
        name, _, value = self.mark.partition("=")
        env[name] = value
        return env

    def start(self, md_dirs=(), port=0, extra_config="", timeout=MANAGER_START_TIMEOUT, config=None, args=()):
        """`args`: more ln_manager options."""
        config = config or self.write_config(md_dirs, port, extra_config)
        self.log_path.write_text("")
        env = self.manager_env()
        if port:
            env["LN_ARBITER_PORT"] = str(free_port())
        options = ["--isolated-test"] if not port else []
        self.manager = start(
            [self.ln_manager, "-c", config, "--without-gui", *options, "--log-level", "info", *args],
            self.log_path,
            env=env,
            cwd=self.work_dir,
        )
        found = wait_for_log(self.log_path, r"listening on '[^']*:(\d+)' for ln-clients", timeout, self.manager)
        self.port = int(found.group(1))
        self.address = "127.0.0.1:%d" % self.port
        return self

    def stop(self, keep_daemons=False, timeout=10.0):
        code = super().stop(timeout=timeout)
        if not keep_daemons:
            # The private daemon ends with an --isolated-test manager, normally.
            try:
                wait_for(lambda: not marked_processes(self.venv, self.mark), 3, "LN 2.9's daemons to end", 0.1)
            except TimeoutError:
                for sig in (signal.SIGTERM, signal.SIGKILL):
                    for pid in marked_processes(self.venv, self.mark):
                        try:
                            os.kill(pid, sig)
                        except ProcessLookupError:
                            pass
                    if sig == signal.SIGTERM:
                        try:
                            wait_for(lambda: not marked_processes(self.venv, self.mark), 2, "LN 2.9's daemons", 0.05)
                        except TimeoutError:
                            pass
        return code


class LnCore(LnSystem):
    """ln_core: its ln_manager and its links_and_nodes package (see ln_core_manager()
    and ln_core_python_path() for where they are looked for)."""

    kind = "ln_core"

    def __init__(self, work_dir, base_env=None, home=None, manager_exe=None, package_dir=None):
        super().__init__(work_dir, base_env, home)
        self.manager_exe = str(manager_exe) if manager_exe else ln_core_manager()
        self._package_dir = str(package_dir) if package_dir else None

    @staticmethod
    def locate() -> tuple[str, str]:
        """(ln_manager, directory holding links_and_nodes); raises Unavailable."""
        return ln_core_manager(), ln_core_python_path()

    @property
    def package_dir(self) -> str:
        if self._package_dir is None:
            self._package_dir = ln_core_python_path()
        return self._package_dir

    def python_path(self) -> str:
        return self.package_dir

    def start(self, md_dirs=(), port=0, extra_config="", timeout=MANAGER_START_TIMEOUT, config=None, args=()):
        config = config or self.write_config(md_dirs, port, extra_config)
        self.log_path.write_text("")
        env = dict(self.base_env, HOME=str(self.home))
        env.pop("LN_MANAGER", None)
        self.manager = start(
            [self.manager_exe, "-c", config, "--listen", "127.0.0.1:%d" % port, *args],
            self.log_path,
            env=env,
            cwd=self.work_dir,
        )
        found = wait_for_log(self.log_path, r"ln_manager: listening on (\S+):(\d+)", timeout, self.manager)
        self.port = int(found.group(2))
        self.address = "%s:%d" % (found.group(1), self.port)
        return self


def ln_system(kind: str, work_dir, **options) -> LnSystem:
    """LnSystem of `kind` ("ln29" or "ln_core"), not started yet; raises Unavailable."""
    return {"ln29": Ln29, "ln_core": LnCore}[kind](work_dir, **options)
