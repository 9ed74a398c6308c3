"""Recordings made by LN 2.9's own tools, for the conversion tests: one LN 2.9
session (its manager in --isolated-test mode, managed by
tests/ln29_behaviour/lnbt_support.py) in which lnrecorder records a topic and
a service into a pcap log and an lnrdb directory at the same time, and a
logger logs the topic and saves it as .pcap and .pickle.

    python ln29_recordings.py DIR     # (re)makes data/ln29/ from a fresh session

Topic `ln29.pose` (bagtest/pose, counter 0..N-1 at 100 Hz), service
`ln29.add` (bagtest/add, 5 calls). LN 2.9's own reading of every file
(ln29_programs.py decode) is what the converted files are compared with.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "tests" / "ln29_behaviour"))

import lnbt_support as support  # noqa: E402

MSGDEFS = HERE / "msgdefs"
PROGRAMS = HERE / "ln29_programs.py"
TOPIC, SERVICE = "ln29.pose", "ln29.add"
PACKETS, CALLS = 60, 5
FILES = ("recorder.pcap", "recorder_lnrdb", "logger.pcap", "logger.pickle")


def reference():
    """LN 2.9 (support.System), or MissingPrerequisite."""
    return support.find_reference()


def python_of(system):
    return str(system.ln_manager.parent / "python")


def _stop(program, signum=signal.SIGINT, timeout=10):
    """Ends a program that stops on a signal (lnrecorder sometimes hangs after it: killed then)."""
    if program.proc.poll() is None:
        program.proc.send_signal(signum)
        try:
            program.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            program.proc.kill()
            program.proc.wait()
    return program.finish(5)


def make(system, work, out_dir):
    """Runs the LN 2.9 sessions in `work`; the files go to out_dir (FILES)."""
    work, out_dir = Path(work), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    # One tool per session: two lnrecorders at once record each other's services and sometimes nothing
    # else, and LN 2.9's logger client corrupts its heap next to lnrecorder and services.
    _session(system, work / "pcap", recording=out_dir / "recorder.pcap")
    _session(system, work / "lnrdb", recording=out_dir / "recorder_lnrdb")
    _session(system, work / "logger", logger_prefix=out_dir / "logger")
    missing = [f for f in FILES if not (out_dir / f).exists()]
    if missing:
        raise RuntimeError("LN 2.9 did not write %s" % ", ".join(missing))
    return {f: out_dir / f for f in FILES}


def _session(system, work, recording=None, logger_prefix=None):
    """An LN 2.9 manager, then lnrecorder recording to `recording` (with a service
    provider and caller) or a logger saving to logger_prefix.*, and the publisher."""
    (work / "home").mkdir(parents=True, exist_ok=True)
    (work / "tmp").mkdir(exist_ok=True)
    env = support.base_environment(work / "home", work / "tmp")
    manager = support.start_manager(system, work / "manager", env, md_dir=MSGDEFS)
    if isinstance(manager, support.MissingPrerequisite):
        raise RuntimeError(str(manager))
    env = dict(env, LN_MANAGER=manager.address)
    python = python_of(system)
    # line-buffered, so its "ready" arrives when it is (a pipe would hold it back until exit)
    recorder_argv = (
        [
            shutil.which("stdbuf") or "stdbuf",
            "-oL",
            str(system.ln_manager.parent / "lnrecorder"),
            "record",
            str(recording),
        ]
        if recording
        else None
    )
    started = []

    def start(argv, stdin=False):
        program = support.Program(argv, env, stdin_pipe=stdin, cwd=str(work))
        started.append(program)
        return program

    def expect(program, line, timeout=30):
        if program.wait_for_line(line, timeout) is None:
            raise RuntimeError(
                "LN 2.9: no %r from\n%s\n--- manager ---\n%s" % (line, program.describe(), manager.log_tail(3000))
            )

    try:
        if logger_prefix:
            logger = start([python, PROGRAMS, "logger", TOPIC, str(logger_prefix), PACKETS, 100])
            line = logger.wait_for_line("publisher ", 30)
            if line:
                support.Started.add(int(line.split()[1]))
            expect(logger, "saved")
            return
        provider = start([python, PROGRAMS, "provide", SERVICE], stdin=True)
        expect(provider, "providing")
        recorder = start(recorder_argv)
        expect(recorder, "ready")
        publisher = start([python, PROGRAMS, "publish", TOPIC, PACKETS, 100], stdin=True)
        expect(publisher, "ready")
        publisher.proc.stdin.write(b"go\n")  # it writes once the recorder subscribed
        publisher.proc.stdin.flush()
        caller = start([python, PROGRAMS, "call", SERVICE, CALLS])
        expect(caller, "called")
        expect(publisher, "published")
        # lnrecorder shows nothing of how far it has read: a margin for the last packets
        time.sleep(0.5)
        _stop(recorder)
    except (OSError, RuntimeError) as error:
        raise RuntimeError(
            "LN 2.9 session for %s failed: %s\n%s" % (recording, error, "\n".join(p.describe() for p in started))
        ) from None
    finally:
        for program in started:
            program.finish(10) if program.proc.stdin else _stop(program)
        support.stop_manager(manager)
        support.sweep_dev_shm()


def decode(system, kind, path):
    """What LN 2.9's own code reads from a recording: [{kind, name, log_time, publish_time, data}]."""
    env = support.base_environment(Path(path).parent, Path(path).parent)
    out = subprocess.run(
        [python_of(system), str(PROGRAMS), "decode", kind, str(path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    if out.returncode != 0:
        raise RuntimeError("LN 2.9 cannot read %s:\n%s" % (path, out.stderr[-3000:]))
    return [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]


if __name__ == "__main__":
    target = Path(sys.argv[1])
    system = reference()
    if isinstance(system, support.MissingPrerequisite):
        sys.exit(str(system))
    scratch = Path(os.environ.get("TMPDIR", "/tmp")) / ("ln29_recordings_%d" % os.getpid())
    try:
        files = make(system, scratch, scratch / "out")
        target.mkdir(parents=True, exist_ok=True)
        for name, path in files.items():
            destination = target / name
            if destination.is_dir():
                shutil.rmtree(destination)
            (shutil.copytree if path.is_dir() else shutil.copy)(path, destination)
        print("wrote", ", ".join(str(target / f) for f in FILES))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
