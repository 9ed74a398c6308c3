"""Side-by-side LN 2.9 / ln_core benchmarks: builds the programs of bench/ln/ for both systems,
starts and stops each system's manager, and runs server/client program pairs pinned to CPUs.

Used by bench/cases/ln_*.py. The C++ programs are written once against the LN 2.9 C++ API and
compiled twice: with LN 2.9's ln_generate, headers and libln.so (from its venv), and with
ln_core's ln_generate, headers and libln.so (built here). The Python programs run with either
system's `links_and_nodes` package.

Environment:
  LN_CORE_LN29_VENV      LN 2.9 venv (default /root/.cache/ln_core/venv-ln29, then /tmp/ref/ln29)
  LN_BENCH_LN_CORE_BUILD an existing ln_core build dir to use as is (libln.so, ln_manager,
                         ln_generate); default: build ln_core in build-bench/ (Release, no tests)
  LN_CORE_PYTHONPATH     directory holding ln_core's `links_and_nodes` package (default: searched
                         in ln_core/ and the build dir)
  LN_CORE_PYTHON         interpreter for ln_core's Python binding (default: this one)

LN 2.9's manager runs with --isolated-test (random port, private ln_daemon that exits with the
manager) and a temporary HOME/TMPDIR, so its DSA keys, generated files and daemon log stay out of
the real home. Both managers are started and stopped by tests/support/ln_testing.py (which ends
LN 2.9's daemons by PID); /dev/shm segments named after PIDs started here are removed (README P2-P4).
"""

from __future__ import annotations

import hashlib
import json
import os
import queue
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

LN_DIR = Path(__file__).resolve().parent
REPO_ROOT = LN_DIR.parent.parent
sys.path.insert(0, str(REPO_ROOT / "tests" / "support"))
import ln_testing  # noqa: E402

LN_CORE_SRC = REPO_ROOT / "ln_core"
MSGDEFS = LN_DIR / "msgdefs"
MESSAGES = ["lnbench/p64", "lnbench/p4k", "lnbench/p1m", "lnbench/small_srv", "lnbench/blob_srv"]
PROGRAMS = ["pingpong", "rate", "setup", "srv", "logger"]
CXXFLAGS = ["-O2", "-std=c++17", "-Wall", "-Wextra"]


class Unavailable(Exception):
    """The measured side is not there yet (not built, feature not implemented): a skip."""


class MeasureError(Exception):
    """A program failed, timed out, or found a wrong answer: a failure."""


# ---------------------------------------------------------------------------------------------
# helpers
def _measured_environ() -> dict:
    """The environment the measured programs start from: ours without what would make one system
    load the other's code or settings. `. launchless_scripts/env.sh` puts ln_core's Python package
    and libln on PYTHONPATH / LD_LIBRARY_PATH, where LN 2.9's manager (a Python program) and
    programs linked with a RUNPATH would pick them up; LN_* variables (manager address, name
    mappings, definition dirs) would change what is measured. Each system adds what it needs."""
    return {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "LD_PRELOAD") and not k.startswith("LN_")
    }


def _run(cmd, ctx, timeout, env=None, cwd=None) -> subprocess.CompletedProcess:
    ctx.log_text(f"$ {shlex.join(str(c) for c in cmd)}\n")
    try:
        proc = subprocess.run(
            [str(c) for c in cmd],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=None if env is None else {**_measured_environ(), **env},
            cwd=cwd,
        )
    except subprocess.TimeoutExpired as e:
        raise MeasureError(f"{Path(str(cmd[0])).name}: no result within {timeout} s") from e
    ctx.log_text(proc.stdout + proc.stderr)
    return proc


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()


def _tail(text: str, n: int = 4) -> str:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return " / ".join(lines[-n:])


def _first_error(text: str) -> str:
    """The first compiler/linker error line of a build log, else its tail."""
    for line in text.splitlines():
        if re.search(r"(\berror\b|undefined reference|FAILED:)", line) and "ninja: build stopped" not in line:
            if "FAILED:" in line:
                continue  # the next lines name the actual error
            return line.strip()[:300]
    return _tail(text, 3)


def _json_lines(text: str) -> list[dict]:
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                pass
    return out


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


# ---------------------------------------------------------------------------------------------
# systems
class System:
    key = ""
    label = ""

    def __init__(self) -> None:
        self.tmp: Path | None = None
        self.manager: ln_testing.LnSystem | None = None
        self.address = ""
        self.bin_dir: Path | None = None
        self.started_pids: set[int] = set()
        self._unavailable: str | None = None
        self._py_unavailable: str | None = None
        self._tools: tuple | None = None

    # -- to be provided by subclasses
    def _prepare_tools(self, ctx) -> tuple[list[str], list[str], dict]:
        """(ln_generate command prefix, extra g++ args, env for ln_generate); raises Unavailable."""
        raise NotImplementedError

    def _include_digest(self) -> str:
        return ""

    def _manager(self, work: Path) -> ln_testing.LnSystem:
        """This system's manager (not started) working in `work`."""
        raise NotImplementedError

    def python(self) -> tuple[list[str], dict]:
        """Interpreter command and extra env for the Python programs; raises Unavailable."""
        raise NotImplementedError

    # -- common
    def prepare(self, ctx, programs: bool = True) -> None:
        """Builds the system's tools and (unless programs=False) the C++ programs, cached by
        content; raises Unavailable."""
        if self._unavailable:
            raise Unavailable(self._unavailable)
        if self.bin_dir is not None or (not programs and self._tools is not None):
            return
        try:
            if self._tools is None:
                self._tools = self._prepare_tools(ctx)
            if not programs:
                return
            gen_cmd, cxx_args, gen_env = self._tools
            out = ctx.build_dir / "ln" / self.key
            gen = out / "gen"
            gen.mkdir(parents=True, exist_ok=True)
            header = gen / "ln_messages.h"
            md_digest = _digest(*[(MSGDEFS / m).read_bytes() for m in MESSAGES], *gen_cmd)
            stamp = gen / "ln_messages.h.stamp"
            if not header.exists() or not stamp.exists() or stamp.read_text() != md_digest:
                proc = _run(gen_cmd + ["--md-dir", MSGDEFS, "-f", "-o", header] + MESSAGES, ctx, 120, env=gen_env)
                if proc.returncode != 0:
                    raise Unavailable(f"{self.label} ln_generate failed: {_tail(proc.stdout + proc.stderr)}")
                stamp.write_text(md_digest)
            common = (LN_DIR / "common.hpp").read_bytes()
            for name in PROGRAMS:
                src = LN_DIR / f"{name}.cpp"
                exe = out / f"ln_{name}"
                cmd = ["g++", *CXXFLAGS, f"-I{gen}", src, "-o", exe, *cxx_args]
                key = _digest(src.read_bytes(), common, header.read_bytes(), self._include_digest(), *cmd)
                exe_stamp = out / f"ln_{name}.stamp"
                if exe.exists() and exe_stamp.exists() and exe_stamp.read_text() == key:
                    continue
                ctx.log(f"ln bench: compiling {name}.cpp against {self.label}")
                proc = _run(cmd, ctx, 300)
                if proc.returncode != 0:
                    raise Unavailable(
                        f"bench/ln/{name}.cpp does not compile against {self.label}: {_first_error(proc.stderr)}"
                    )
                exe_stamp.write_text(key)
            self.bin_dir = out
        except Unavailable as e:
            self._unavailable = str(e)
            raise

    def program(self, name: str) -> str:
        assert self.bin_dir is not None
        return str(self.bin_dir / f"ln_{name}")

    def env(self) -> dict:
        env = {"LN_MANAGER": self.address}
        if self.tmp is not None:
            env.update(HOME=str(self.tmp / "home"), TMPDIR=str(self.tmp))
        return env

    def start(self, ctx) -> None:
        """Starts this system's manager on a free port (once)."""
        if self.manager is not None:
            return
        self.tmp = Path(tempfile.mkdtemp(prefix=f"lnbench-{self.key}-"))
        self.manager = self._manager(self.tmp)
        try:
            self.manager.start([MSGDEFS], args=self._manager_args())
        except (RuntimeError, TimeoutError) as e:
            raise MeasureError(f"{self.label} manager did not start: {e}: {_tail(self.manager.log_tail())}") from e
        finally:
            if self.manager.process is not None:
                self.started_pids.add(self.manager.process.pid)
        self.address = self.manager.address
        ctx.log(f"ln bench: {self.label} manager at {self.address}")

    def _manager_args(self) -> list[str]:
        return []

    def stop(self, ctx) -> None:
        if self.manager is not None:
            self.manager.stop()
            log = self.manager.log_path
            ctx.log_text(f"--- {self.label} manager log (tail) ---\n{ln_testing.tail(log, 30)}\n")
            self.manager = None
        for name in ln_testing.remove_ln_segments(self.started_pids):
            ctx.log_text(f"removed leftover /dev/shm/{name}\n")
        self.started_pids.clear()
        if self.tmp is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp = None


class LN29(System):
    key = "ln29"
    label = "LN 2.9"

    def __init__(self) -> None:
        super().__init__()
        self.venv = None
        for cand in (os.environ.get("LN_CORE_LN29_VENV"), "/root/.cache/ln_core/venv-ln29", "/tmp/ref/ln29"):
            if cand and (Path(cand) / "bin" / "ln_manager").exists():
                self.venv = Path(cand).resolve()
                break

    @property
    def lib_root(self) -> Path:
        return next((self.venv / "lib").glob("python3*/site-packages/liblinks_and_nodes"))

    def _prepare_tools(self, ctx):
        if self.venv is None:
            raise Unavailable("LN 2.9 venv not found (set LN_CORE_LN29_VENV)")
        root = self.lib_root
        gen_home = ctx.build_dir / "ln" / "ln29-home"  # ln_generate may write into $HOME
        gen_home.mkdir(parents=True, exist_ok=True)
        return (
            [str(self.venv / "bin" / "ln_generate")],
            [f"-I{root / 'include'}", f"-L{root / 'lib'}", f"-Wl,-rpath,{root / 'lib'}", "-lln", "-lpthread"],
            {"HOME": str(gen_home)},
        )

    def _manager(self, work):
        return ln_testing.Ln29(work, base_env=_measured_environ(), venv=self.venv)

    def python(self):
        if self.venv is None:
            raise Unavailable("LN 2.9 venv not found")
        return [str(self.venv / "bin" / "python")], {}


class LnCore(System):
    key = "ln_core"
    label = "ln_core"
    _built: dict = {}
    _python_build_error = ""

    def __init__(self) -> None:
        super().__init__()
        self.build: Path | None = None
        self.lib: Path | None = None
        self.manager_exe: Path | None = None
        self.generate_exe: Path | None = None

    def _find(self, root: Path, name: str) -> Path | None:
        # the newest: a build dir may still hold an older copy from an earlier layout
        hits = [p for p in root.rglob(name) if p.is_file() and "CMakeFiles" not in p.parts]
        return max(hits, key=lambda p: p.stat().st_mtime) if hits else None

    @staticmethod
    def python_interpreter() -> str:
        # env.sh exports LN_BENCH_PYTHON: the project venv's (numpy, nanobind)
        return os.environ.get("LN_CORE_PYTHON") or os.environ.get("LN_BENCH_PYTHON") or sys.executable

    def _build_ln_core(self, ctx) -> Path:
        given = os.environ.get("LN_BENCH_LN_CORE_BUILD")
        if given:
            return Path(given).resolve()
        src, build = LN_CORE_SRC, ctx.build_dir / "ln_core-direct"
        key = str(build)
        if key in LnCore._built:
            if isinstance(LnCore._built[key], str):
                raise Unavailable(LnCore._built[key])
            return LnCore._built[key]
        try:
            if not (build / "build.ninja").exists():
                ctx.log(f"ln bench: configuring ln_core in {build}")
                proc = _run(
                    [
                        "cmake",
                        "-G",
                        "Ninja",
                        "-S",
                        src,
                        "-B",
                        build,
                        "-DCMAKE_BUILD_TYPE=Release",
                        "-DBUILD_TESTING=OFF",
                        "-DLN_WERROR=OFF",
                        f"-DLN_PYTHON_EXECUTABLE={self.python_interpreter()}",
                    ],
                    ctx,
                    300,
                )
                if proc.returncode != 0:
                    raise Unavailable(f"ln_core does not configure: {_first_error(proc.stdout + proc.stderr)}")
            ctx.log("ln bench: building ln_core (ln, ln_manager, ln_generate)")
            proc = _run(["ninja", "-C", build, "ln", "ln_manager", "ln_generate"], ctx, 1200)
            if proc.returncode != 0:
                raise Unavailable(f"ln_core does not build: {_first_error(proc.stdout + proc.stderr)}")
        except (Unavailable, MeasureError) as e:
            LnCore._built[key] = str(e)
            raise Unavailable(str(e)) from e
        # The Python module separately: its failure only takes the Python rows.
        targets = _run(["ninja", "-C", build, "-t", "targets", "all"], ctx, 60).stdout
        if re.search(r"^ln_python:", targets, re.MULTILINE):
            ctx.log("ln bench: building ln_core's Python module")
            proc = _run(["ninja", "-C", build, "ln_python"], ctx, 1200)
            if proc.returncode != 0:
                LnCore._python_build_error = (
                    f"ln_core's Python module does not build: {_first_error(proc.stdout + proc.stderr)}"
                )
        else:
            LnCore._python_build_error = (
                f"ln_core's Python module is not part of the build (no nanobind for {self.python_interpreter()}?)"
            )
        LnCore._built[key] = build
        return build

    def _prepare_tools(self, ctx):
        self.build = self._build_ln_core(ctx)
        self.lib = self._find(self.build, "libln.so")
        self.manager_exe = self._find(self.build, "ln_manager")
        self.generate_exe = self._find(self.build, "ln_generate")
        missing = [
            n
            for n, p in (("libln.so", self.lib), ("ln_manager", self.manager_exe), ("ln_generate", self.generate_exe))
            if p is None
        ]
        if missing:
            raise Unavailable(f"ln_core build in {self.build} lacks {', '.join(missing)}")
        libdir = self.lib.parent
        return (
            [str(self.generate_exe)],
            [f"-I{LN_CORE_SRC / 'include'}", f"-L{libdir}", f"-Wl,-rpath,{libdir}", "-lln", "-lpthread"],
            {},
        )

    def _include_digest(self) -> str:
        return _digest(*[p.read_bytes() for p in sorted((LN_CORE_SRC / "include" / "ln").rglob("*.h"))])

    def _manager(self, work):
        return ln_testing.LnCore(work, base_env=_measured_environ(), manager_exe=self.manager_exe)

    def _manager_args(self):
        return ["--log-level", "warning"]

    def python(self):
        if self._py_unavailable:
            raise Unavailable(self._py_unavailable)
        try:
            pkg_dir = self._python_package()
            interp = self.python_interpreter()
            probe = subprocess.run([interp, "-c", "import numpy"], capture_output=True, timeout=60)
            if probe.returncode != 0:
                raise Unavailable(f"{interp} has no numpy (set LN_CORE_PYTHON)")
        except Unavailable as e:
            self._py_unavailable = str(e)
            raise
        return [interp], {"PYTHONPATH": str(pkg_dir)}

    def _python_package(self) -> Path:
        given = os.environ.get("LN_CORE_PYTHONPATH")
        if given:
            if not (Path(given) / "links_and_nodes" / "__init__.py").exists():
                raise Unavailable(f"LN_CORE_PYTHONPATH={given} holds no links_and_nodes package")
            return Path(given)
        if self.build is not None:
            for init in sorted(self.build.rglob("links_and_nodes/__init__.py")):
                if list(init.parent.glob("_ln*.so")):
                    return init.parent.parent
        if not (LN_CORE_SRC / "python" / "links_and_nodes" / "__init__.py").exists():
            raise Unavailable("ln_core has no Python binding (links_and_nodes package) yet")
        raise Unavailable(LnCore._python_build_error or "ln_core's Python module (_ln) is not built")


# ---------------------------------------------------------------------------------------------
# running programs
def _reader(stream, q: queue.Queue) -> None:
    for line in stream:
        q.put(line)
    q.put(None)


def _drain(q: queue.Queue, sink) -> None:
    """Hands the lines a _reader thread still delivers to sink(line), until its EOF (or 5 s)."""
    while True:
        try:
            line = q.get(timeout=5)
        except queue.Empty:
            return
        if line is None:
            return
        sink(line)


def _spawn(system: System, cmd: list[str], env: dict, read: bool = False):
    """Starts `cmd` in its own process group (stdout and stderr as text, no stdin) and notes its
    PID in `system`; with read=True returns (process, queue of its lines from a _reader thread)."""
    proc = subprocess.Popen(
        cmd,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        process_group=0,
    )
    system.started_pids.add(proc.pid)
    if not read:
        return proc
    q: queue.Queue = queue.Queue()
    threading.Thread(target=_reader, args=(proc.stdout, q), daemon=True).start()
    return proc, q


def _wait_results(
    ctx, system: System, proc: subprocess.Popen, timeout: float, what: str, wait: float | None = None
) -> list[dict]:
    """Waits for `proc` to end (up to `wait`, default `timeout`: the limit the error names; kills
    its group after that), logs its output and returns its ok result lines; raises when it timed
    out, failed or printed no result."""
    try:
        out, _ = proc.communicate(timeout=timeout if wait is None else wait)
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        out, _ = proc.communicate()
        ctx.log_text(out)
        raise MeasureError(f"{system.label} {what}: no result within {timeout:g} s: {_tail(out, 2)}") from None
    ctx.log_text(out)
    results = _check_results(system, what, _json_lines(out), proc.returncode, out)
    if not results:
        raise MeasureError(f"{system.label} {what}: printed no result: {_tail(out)}")
    return results


def _check_results(system: System, what: str, results: list[dict], rc: int | None, text: str) -> list[dict]:
    for r in results:
        if r.get("ok") is False:
            if r.get("not_implemented") and isinstance(system, LnCore):
                raise Unavailable(f"{what}: {r.get('error')}")
            raise MeasureError(f"{system.label} {what}: {r.get('error')}")
    if rc not in (0, None):
        raise MeasureError(f"{system.label} {what}: exit {rc}: {_tail(text, 3)}")
    return [r for r in results if r.get("ok")]


def run_pair(
    ctx,
    system: System,
    server: list,
    client: list,
    *,
    cpus: tuple[int, int],
    timeout: float,
    what: str,
    python: bool = False,
    alongside: list | None = None,
) -> tuple[dict, list[dict]]:
    """Starts `server` pinned to cpus[1], waits for its ready line, runs `client` pinned to
    cpus[0]; returns (the client's result, the server's result lines). Both bounded by `timeout`;
    a failure reported by either side raises. `alongside` (a command, not pinned) starts once the
    server is ready and runs until the client is done (SIGTERM); the client starts after it
    printed {"attacking": true}."""
    env = {**_measured_environ(), **system.env()}
    prefix: list[str] = []
    if python:
        interp, py_env = system.python()
        env.update(py_env)
        prefix = interp
    srv_cmd = ["taskset", "-c", str(cpus[1])] + prefix + [str(c) for c in server]
    cli_cmd = ["taskset", "-c", str(cpus[0])] + prefix + [str(c) for c in client]
    ctx.log_text(f"$ [{system.label}] {shlex.join(srv_cmd)} &\n")
    deadline = time.monotonic() + timeout
    srv, q = _spawn(system, srv_cmd, env, read=True)
    srv_lines: list[str] = []
    cli = None
    other = None
    cli_results: list[dict] = []
    srv_done = False
    try:
        # wait for {"ready": true} (or the server's failure) with a deadline
        ready = False
        while not ready:
            left = deadline - time.monotonic()
            if left <= 0:
                raise MeasureError(
                    f"{system.label} {what}: server not ready within {timeout:g} s: {_tail(''.join(srv_lines))}"
                )
            try:
                line = q.get(timeout=left)
            except queue.Empty:
                continue
            if line is None:
                srv_done = True
                srv.wait(timeout=10)
                text = "".join(srv_lines)
                _check_results(system, what + " (server)", _json_lines(text), srv.returncode, text)
                raise MeasureError(f"{system.label} {what}: server exited before it was ready: {_tail(text)}")
            srv_lines.append(line)
            ready = '"ready": true' in line
        if alongside is not None:
            other = _start_alongside(ctx, system, alongside, env, deadline, what)
        ctx.log_text(f"$ [{system.label}] {shlex.join(cli_cmd)}\n")
        cli = _spawn(system, cli_cmd, env)
        cli_results = _wait_results(ctx, system, cli, timeout, what, wait=max(1.0, deadline - time.monotonic()))
        # the server ends on the client's stop message; give it a few seconds
        try:
            srv.wait(timeout=max(1.0, min(10.0, deadline - time.monotonic())))
        except subprocess.TimeoutExpired:
            pass
    finally:
        if other is not None:
            _stop_alongside(ctx, other)
        if srv.poll() is None:
            _kill_group(srv)
            srv.wait(timeout=10)
        if cli is not None and cli.poll() is None:
            _kill_group(cli)
        if not srv_done:  # the reader thread ends at EOF, which follows the exit
            _drain(q, srv_lines.append)
        ctx.log_text("".join(srv_lines))
    srv_text = "".join(srv_lines)
    srv_results = _check_results(system, what + " (server)", _json_lines(srv_text), None, srv_text)
    return cli_results[-1], srv_results


def pair_commands(program, roles: tuple[str, str], shared: list, client: list = ()) -> tuple[list, list]:
    """The server and client command lines of one of bench/ln's programs: `program server-role
    *shared` and `program client-role *shared *client` (roles = (server role, client role))."""
    return [program, roles[0], *shared], [program, roles[1], *shared, *client]


def _start_alongside(ctx, system: System, cmd: list, env: dict, deadline: float, what: str):
    full = [str(c) for c in cmd]
    ctx.log_text(f"$ [{system.label}] {shlex.join(full)} &\n")
    proc, q = _spawn(system, full, env, read=True)
    while True:
        left = deadline - time.monotonic()
        try:
            line = q.get(timeout=max(0.0, left))
        except queue.Empty:
            line = None
        if line is None:
            _kill_group(proc)
            raise MeasureError(f"{system.label} {what}: {shlex.join(full[:2])} did not start its attack in time")
        ctx.log_text(line)
        if '"attacking": true' in line:
            return proc, q


def _stop_alongside(ctx, started) -> None:
    proc, q = started
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        _kill_group(proc)
        proc.wait(timeout=10)
    _drain(q, ctx.log_text)


def run_single(ctx, system: System, cmd: list, *, cpu: int, timeout: float, what: str) -> dict:
    env = {**_measured_environ(), **system.env()}
    full = ["taskset", "-c", str(cpu)] + [str(c) for c in cmd]
    ctx.log_text(f"$ [{system.label}] {shlex.join(full)}\n")
    return _wait_results(ctx, system, _spawn(system, full, env), timeout, what)[-1]


# ---------------------------------------------------------------------------------------------
# case plumbing
class Comparison:
    """Runs measurements of both systems, keeps going after a failure, and turns the outcome
    into rows and a final status: failures fail the case (rows are kept), ln_core parts that
    are not there yet make it a skip ("not available yet: <reason>")."""

    def __init__(self, ctx, python: bool = False) -> None:
        self.ctx = ctx
        self.ln29 = LN29()
        self.core = LnCore()
        self.systems = [self.ln29, self.core]
        self.python = python
        self.unavailable: dict[str, list[str]] = {}  # system label -> reasons
        self.failures: list[str] = []
        self.ready: dict[str, bool] = {}

    def __enter__(self):
        for s in self.systems:
            self.ready[s.key] = self._bring_up(s)
        return self

    def _bring_up(self, s: System) -> bool:
        try:
            s.prepare(self.ctx, programs=not self.python)
            if self.python:
                s.python()
            s.start(self.ctx)
            return True
        except Unavailable as e:
            self.note_unavailable(s, str(e))
        except MeasureError as e:
            self.failures.append(str(e))
        return False

    def note_unavailable(self, system: System, reason: str) -> None:
        reasons = self.unavailable.setdefault(system.label, [])
        # one entry per distinct final error text, whichever measurement met it first
        if all(r.rsplit(": ", 1)[-1] != reason.rsplit(": ", 1)[-1] for r in reasons):
            reasons.append(reason)

    def __exit__(self, *exc):
        for s in self.systems:
            s.stop(self.ctx)
        return False

    def measure(self, system: System, fn):
        """fn() -> result; None when the system is unavailable or the measurement failed."""
        if not self.ready.get(system.key):
            return None
        try:
            return fn()
        except Unavailable as e:
            self.note_unavailable(system, str(e))
        except MeasureError as e:
            self.failures.append(str(e))
            self.ctx.log(f"FAILED: {e}")
        return None

    def pair(self, system: System, program, roles, shared, client, *, store=None, key=None, whole=False, **kw):
        """measure() of run_pair with pair_commands(program, roles, shared, client) of `system`
        (`program`: a Python script, or with python=False the name of a bench/ln C++ program;
        keywords as run_pair's); returns the client's result (or, whole=True, run_pair's (client
        result, server results)), None when there is none, and adds it to store[key]. A Python
        program must have run `system`'s own links_and_nodes."""

        def go():
            exe = program if self.python else system.program(program)
            server_cmd, client_cmd = pair_commands(exe, roles, shared, client)
            out = run_pair(self.ctx, system, server_cmd, client_cmd, python=self.python, **kw)
            if self.python:
                # ln_core's rows must not silently run LN 2.9's package (or the reverse)
                mod = out[0].get("ln_module", "")
                if (system is self.core) == (self.ln29.venv is not None and str(self.ln29.venv) in mod):
                    raise MeasureError(f"{system.label}: links_and_nodes came from {mod}")
            return out if whole else out[0]

        r = self.measure(system, go)
        if r is not None and store is not None:
            store.setdefault(key, []).append(r)
        return r

    def why_missing(self, system: System) -> str:
        if system.label in self.unavailable:
            return f"not available yet: {' | '.join(self.unavailable[system.label])}"
        return "measurement failed (see the case's error)"

    def finish(self):
        if self.failures:
            more = f" (+{len(self.failures) - 3} more, see run.log)" if len(self.failures) > 3 else ""
            raise RuntimeError("; ".join(self.failures[:3]) + more)
        if self.unavailable:
            self.ctx.skip(
                "; ".join(f"{k} rows not available yet: {' | '.join(v)}" for k, v in self.unavailable.items())
            )


def compare_rows(
    cmp: Comparison,
    group: str,
    name: str,
    ref_name: str,
    ref_runs: list[dict],
    core_runs: list[dict],
    metrics: list[tuple[str, str]],
    unit: str,
    target: float | None,
    *,
    extra=None,
    ref_only: bool = True,
    abs_target: tuple[float, str] | None = None,
):
    """Rows "ln_core <name>" with LN 2.9's figure of the same run as reference (median over the
    runs of each per-run statistic); LN 2.9's figure alone (no reference) when ln_core has no
    result (yet), with the reason in the note. `target` (ratio) and `abs_target` (value, text)
    are checked on the first metric and reported in the note."""
    from benchlib import Row, median, spread_note

    better = "lower" if unit in ("us", "ms") else "higher"
    cmp_word = "<=" if better == "lower" else ">="
    for i, (key, metric) in enumerate(metrics):
        core_vals = [r[key] for r in core_runs]
        ref_vals = [r[key] for r in ref_runs]
        notes = []
        if core_runs:
            value = median(core_vals)
            ref = median(ref_vals) if ref_runs else None
            notes.append(spread_note(core_vals))
            if target is not None and i == 0 and ref:
                met = value / ref <= target if better == "lower" else value / ref >= target
                notes.append(f"target {cmp_word} {target:g}x LN 2.9: {'met' if met else 'NOT met'}")
            if abs_target is not None and i == 0:
                met = value <= abs_target[0] if better == "lower" else value >= abs_target[0]
                notes.append(f"target {abs_target[1]}: {'met' if met else 'NOT met'}")
            if not ref_runs:
                notes.append(f"LN 2.9: {cmp.why_missing(cmp.ln29)}")
            if extra:
                notes.append("ln_core " + extra(core_runs))
                if ref_runs:
                    notes.append("LN 2.9 " + extra(ref_runs))
            yield Row(
                group=group,
                name=f"ln_core {name}",
                metric=metric,
                unit=unit,
                value=value,
                reference_name=ref_name if ref_runs else "",
                reference_value=ref,
                better=better,
                note="; ".join(n for n in notes if n),
            )
        elif ref_runs and ref_only:
            notes.append(spread_note(ref_vals))
            notes.append(f"ln_core: {cmp.why_missing(cmp.core)}")
            if extra:
                notes.append("LN 2.9 " + extra(ref_runs))
            yield Row(
                group=group,
                name=ref_name,
                metric=metric,
                unit=unit,
                value=median(ref_vals),
                better=better,
                note="; ".join(n for n in notes if n),
            )
