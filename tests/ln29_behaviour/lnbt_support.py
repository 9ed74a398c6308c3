"""Support of the LN 2.9 behaviour tests: finding both systems, building the
LN 2.9-style programs against each, running a manager per system and the
programs against it, and cleaning up everything that was started.

"System" is either the LN 2.9 reference (its ln_manager, ln_generate, headers
and libln.so from the reference venv) or ln_core (its ln_manager, ln_generate,
headers and libln.so). The programs in programs/ are compiled once per system
from the same source; each pair runs against its own system's manager.

Nothing here asserts; the tests do. Standard library only.
"""

from __future__ import annotations

import concurrent.futures
import glob
import os
import queue
import re
import shutil
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
import ln_testing

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
PROGRAMS_DIR = HERE / "programs"
MSGDEFS_DIR = HERE / "msgdefs"
OUR_SOURCE_INCLUDE_DIR = REPO_ROOT / "ln_core" / "include"
PROGRAMS = (
    "lnbt_probe",
    "lnbt_publisher",
    "lnbt_subscriber",
    "lnbt_services",
    "lnbt_parameters",
    "lnbt_logger",
    "lnbt_dsa",
    "lnbt_shm",
    "lnbt_events",
    "lnbt_service_logger",
)
MESSAGES = (
    "lnbt/counter",
    "lnbt/other",
    "lnbt/echo",
    "ln/parameters/query",
    "ln/parameters/query_dict",
    "ln/resource_event",
    "ln/event/call",
    "ln/log_service",
)


#: Documented differences the tests observed; conftest prints them at the end.
DIFFERENCES: list[str] = []

COMPILE_TIMEOUT = 180
MANAGER_START_TIMEOUT = 30
PROGRAM_TIMEOUT = 20


MissingPrerequisite = ln_testing.Unavailable
require = ln_testing.require
free_port = ln_testing.free_port


# ------------------------------------------------------------------ systems


@dataclass
class System:
    """One LN implementation: where its tools, headers and library are."""

    label: str  # "ln29" or "ln_core"
    ln_manager: Path
    ln_generate: Path
    include_dir: Path
    lib_dir: Path
    is_reference: bool
    #: filled by build()
    programs: dict[str, Path] = field(default_factory=dict)

    def __str__(self) -> str:
        return self.label


def _is_elf(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(4) == b"\x7fELF"
    except OSError:
        return False


def find_reference() -> System | MissingPrerequisite:
    venv_text = os.environ.get("LN_CORE_LN29_VENV") or str(Path.home() / ".cache" / "ln_core" / "venv-ln29")
    venv = Path(venv_text)
    packages = sorted(glob.glob(str(venv / "lib" / "python3*" / "site-packages" / "liblinks_and_nodes")))
    manager, generate = venv / "bin" / "ln_manager", venv / "bin" / "ln_generate"
    if not packages or not manager.is_file() or not generate.is_file():
        origin = "LN_CORE_LN29_VENV" if os.environ.get("LN_CORE_LN29_VENV") else "the default"
        return MissingPrerequisite(
            f"no LN 2.9 reference at {venv} ({origin}): expected bin/ln_manager, bin/ln_generate and "
            "lib/python3*/site-packages/liblinks_and_nodes; set LN_CORE_LN29_VENV "
            "(launchless_scripts/env.sh does; launchless_scripts/setup.sh installs it)"
        )
    package = Path(packages[-1])
    if not (package / "include" / "ln" / "ln.h").is_file() or not (package / "lib" / "libln.so").exists():
        return MissingPrerequisite(f"LN 2.9 at {venv} lacks include/ln/ln.h or lib/libln.so")
    return System("ln29", manager, generate, package / "include", package / "lib", True)


def find_ours() -> System | MissingPrerequisite:
    """ln_core from LN_CORE_BUILD_DIR (a cmake build tree) or, failing that,
    from PATH (an install prefix, as after `. launchless_scripts/env.sh`)."""
    build = os.environ.get("LN_CORE_BUILD_DIR")
    if build:
        base = Path(build)
        manager, generate, lib = base / "ln_manager", base / "ln_generate", base / "libln.so"
        if manager.is_file() and generate.is_file() and lib.exists():
            return System("ln_core", manager, generate, OUR_SOURCE_INCLUDE_DIR, base, False)
        return MissingPrerequisite(
            f"LN_CORE_BUILD_DIR={build} lacks ln_manager, ln_generate or libln.so (build ln_core there first)"
        )
    for directory in os.environ.get("PATH", "").split(os.pathsep):
        manager = Path(directory or ".") / "ln_manager"
        if not manager.is_file() or not _is_elf(manager):
            continue  # LN 2.9's ln_manager is a Python script
        prefix = manager.resolve().parent.parent
        generate = manager.parent / "ln_generate"
        include, lib = prefix / "include", prefix / "lib"
        if (
            generate.is_file()
            and _is_elf(generate)
            and (include / "ln" / "ln.h").is_file()
            and (lib / "libln.so").exists()
        ):
            return System("ln_core", manager, generate, include, lib, False)
    return MissingPrerequisite(
        "ln_core not found: set LN_CORE_BUILD_DIR to its cmake build directory or put an installed "
        "ln_core (bin/ln_manager, bin/ln_generate, lib/libln.so, include/ln) on PATH "
        "(. launchless_scripts/env.sh)"
    )


# ------------------------------------------------------------- processes


class Started:
    """Every process this run started (for cleanup and /dev/shm sweeping)."""

    pids: set[int] = set()
    lock = threading.Lock()

    @classmethod
    def add(cls, pid: int) -> None:
        with cls.lock:
            cls.pids.add(pid)


def base_environment(home: Path, tmp: Path) -> dict[str, str]:
    """The environment of every manager and program: a private HOME and
    TMPDIR, no LN_* variables of the caller."""
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith("LN_") and k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "LD_LIBRARY_PATH")
    }
    env.update(HOME=str(home), TMPDIR=str(tmp), LC_ALL="C.UTF-8", PYTHONUNBUFFERED="1")
    return env


class Program:
    """A started program: stdout lines collected by a thread; bounded waits."""

    def __init__(self, argv, env, stdin_pipe=False, cwd=None):
        self.argv = [str(a) for a in argv]
        self.proc = subprocess.Popen(
            self.argv,
            env=env,
            cwd=cwd,
            stdin=subprocess.PIPE if stdin_pipe else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        Started.add(self.proc.pid)
        self.lines: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._stderr: list[str] = []
        self._out_thread = threading.Thread(target=self._pump, args=(self.proc.stdout, True), daemon=True)
        self._err_thread = threading.Thread(target=self._pump, args=(self.proc.stderr, False), daemon=True)
        self._out_thread.start()
        self._err_thread.start()
        self.returncode: int | None = None

    def _pump(self, stream, is_stdout):
        for raw in stream:
            line = raw.decode("utf-8", "replace").rstrip("\n")
            if is_stdout:
                self.lines.append(line)
                self._queue.put(line)
            else:
                self._stderr.append(line)
        if is_stdout:
            self._queue.put(None)

    @property
    def stderr(self) -> str:
        return "\n".join(self._stderr)

    def wait_for_line(self, prefix: str, timeout: float) -> str | None:
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                line = self._queue.get(timeout=left)
            except queue.Empty:
                return None
            if line is None:
                return None
            if line.startswith(prefix):
                return line

    def tell(self, line: str) -> None:
        """Writes `line` to the program's stdin (started with stdin_pipe=True)."""
        self.proc.stdin.write(line.encode() + b"\n")
        self.proc.stdin.flush()

    def finish(self, timeout: float = PROGRAM_TIMEOUT) -> int:
        """Closes stdin, waits at most `timeout` s, kills it after that."""
        if self.proc.stdin:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
        try:
            self.returncode = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            self.returncode = -9
        self._out_thread.join(5)
        self._err_thread.join(5)
        return self.returncode

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def describe(self) -> str:
        return (
            f"$ {' '.join(self.argv)}\nexit status {self.returncode}\n--- stdout ---\n"
            + "\n".join(self.lines[:200])
            + f"\n--- stderr ---\n{self.stderr[-3000:]}"
        )


def run(argv, env, timeout=PROGRAM_TIMEOUT, cwd=None) -> Program:
    program = Program(argv, env, cwd=cwd)
    program.finish(timeout)
    return program


def python_for(system: System) -> tuple[list[str], dict[str, str]] | MissingPrerequisite:
    """How to run a Python script against `system`: (interpreter argv,
    environment additions) - LN 2.9's venv python, or this interpreter with
    ln_core's links_and_nodes (next to its libln.so) on PYTHONPATH."""
    if system.is_reference:
        python = system.ln_manager.parent / "python"
        if not python.exists():
            return MissingPrerequisite(f"no python next to {system.ln_manager}")
        return [str(python)], {}
    candidates = [system.lib_dir / "python"] + sorted(
        Path(p) for p in glob.glob(str(system.lib_dir / "python3*" / "site-packages"))
    )
    for directory in candidates:
        if (directory / "links_and_nodes" / "__init__.py").is_file():
            return [sys.executable], {"PYTHONPATH": str(directory)}
    return MissingPrerequisite(f"ln_core's links_and_nodes not found below {system.lib_dir}")


# --------------------------------------------------------------- building


def build(system: System, out_dir: Path, env: dict[str, str]) -> System | MissingPrerequisite:
    """ln_generate (the system's own) + g++ for every program."""
    out_dir.mkdir(parents=True, exist_ok=True)
    header = out_dir / "ln_messages.h"
    gen = subprocess.run(
        [str(system.ln_generate), "--md-dir", str(MSGDEFS_DIR), "-f", "-o", str(header), *MESSAGES],
        env=env,
        capture_output=True,
        timeout=COMPILE_TIMEOUT,
    )
    if gen.returncode != 0 or not header.is_file():
        return MissingPrerequisite(f"{system}: ln_generate failed:\n{gen.stderr.decode(errors='replace')}")
    cxx = shutil.which("g++") or shutil.which("c++")
    if not cxx:
        return MissingPrerequisite("no C++ compiler (g++)")

    def compile_one(name: str):
        target = out_dir / name
        argv = [
            cxx,
            "-std=c++17",
            "-O1",
            "-g0",
            "-w",
            f"-I{out_dir}",
            f"-I{system.include_dir}",
            f"-I{REPO_ROOT / 'ln_core' / 'src'}",  # (last) for testing/wait.hpp
            str(PROGRAMS_DIR / f"{name}.cpp"),
            "-o",
            str(target),
            f"-L{system.lib_dir}",
            f"-Wl,-rpath,{system.lib_dir}",
            "-lln",
            "-lpthread",
        ]
        p = subprocess.run(argv, env=env, capture_output=True, timeout=COMPILE_TIMEOUT)
        return name, target, p

    programs = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, min(3, os.cpu_count() or 1))) as pool:
        for name, target, p in pool.map(compile_one, PROGRAMS):
            if p.returncode != 0:
                return MissingPrerequisite(
                    f"{system}: compiling {name} failed:\n$ {' '.join(p.args)}\n{p.stderr.decode(errors='replace')[-4000:]}"
                )
            programs[name] = target
    # Each program must load its own system's libln.so.1 (same SONAME in both).
    ldd = subprocess.run(["ldd", str(programs["lnbt_probe"])], env=env, capture_output=True, text=True, timeout=30)
    m = re.search(r"libln\.so\.1 => (\S+)", ldd.stdout)
    if ldd.returncode == 0 and (not m or Path(m.group(1)).resolve().parent != system.lib_dir.resolve()):
        return MissingPrerequisite(
            f"{system}: lnbt_probe does not load libln.so.1 from {system.lib_dir}:\n{ldd.stdout}"
        )
    system.programs = programs
    return system


# --------------------------------------------------------------- managers


@dataclass
class Manager:
    """A system's running manager (started through tests/support/ln_testing.py)."""

    system: System
    server: ln_testing.LnSystem

    @property
    def address(self) -> str:
        return self.server.address

    def log_tail(self, n=4000) -> str:
        return ln_testing.read_text(self.server.log_path)[-n:]


def start_manager(
    system: System, work: Path, env: dict[str, str], md_dir: Path = MSGDEFS_DIR
) -> Manager | MissingPrerequisite:
    """Starts the system's manager with `md_dir` (default msgdefs/) on its
    search path; returns once it listens. LN 2.9 runs in --isolated-test mode
    (free port, private ln_daemon); ln_core on 127.0.0.1, a free port."""
    options = dict(base_env=env, home=Path(env["HOME"]))
    if system.is_reference:
        server = ln_testing.Ln29(work, venv=system.ln_manager.parent.parent, **options)
    else:
        server = ln_testing.LnCore(work, manager_exe=system.ln_manager, **options)
    try:
        server.start([md_dir], timeout=MANAGER_START_TIMEOUT)
    except (RuntimeError, TimeoutError) as error:
        server.stop()
        return MissingPrerequisite(f"{system}: the manager did not start listening: {error}\n{server.log_tail()}")
    finally:
        if server.process is not None:
            Started.add(server.process.pid)
    return Manager(system, server)


def stop_manager(manager: Manager) -> None:
    """Ends the manager and, for LN 2.9, the daemons it started."""
    manager.server.stop()


def sweep_dev_shm() -> list[str]:
    """Removes /dev/shm/<pid>_* segments of processes this run started (LN
    2.9 names its segments after the publisher's PID; see README P4) once
    those processes are gone. Returns the names removed."""
    return ln_testing.remove_ln_segments(Started.pids)


# ------------------------------------------------------------- scenarios


@dataclass
class Session:
    """Both systems, built, each with a running manager."""

    work: Path
    env: dict[str, str]
    managers: dict[str, Manager]

    def systems(self) -> list[System]:
        return [m.system for m in self.managers.values()]

    def client_env(self, system: System, **extra: str | None) -> dict[str, str]:
        """Environment of a program of `system`: LN_MANAGER = its manager,
        plus `extra` (a value of None removes the variable)."""
        env = dict(self.env)
        env["LN_MANAGER"] = self.managers[system.label].address
        return ln_testing.overridden(env, extra)

    def address(self, system: System) -> str:
        return self.managers[system.label].address
