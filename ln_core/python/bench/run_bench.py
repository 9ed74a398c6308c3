#!/usr/bin/env python3
"""Side-by-side Python benchmarks: ln_core's links_and_nodes vs LN 2.9's.

    PYTHONPATH=<build>/python python run_bench.py [--reps 3] [--n 10000]

Starts one ln_core manager and one LN 2.9 manager (private HOME and arbiter
port; its daemons are ended afterwards), then runs bench_py.py for both with
the same pinning (same core: both on CPU 1; split: CPUs 1 and 0) and prints
the median of the per-run medians. Every process runs under a timeout.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

from conftest import Manager  # noqa: E402
from test_quickstart import LN29_VENV, Ln29Manager  # noqa: E402

BENCH = os.path.join(HERE, "bench_py.py")


def run_pair(python, env, server_args, client_args, server_cpu, client_cpu, wait_ready=False):
    server = subprocess.Popen(
        ["taskset", "-c", str(server_cpu), "timeout", "300", python, BENCH, *server_args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        if wait_ready:
            line = server.stdout.readline().strip()
            if line != "ready":
                raise RuntimeError("server: %s %s" % (line, server.stderr.read()))
        else:
            time.sleep(1.0)
        out = subprocess.run(
            ["taskset", "-c", str(client_cpu), "timeout", "300", python, BENCH, *client_args],
            env=env,
            capture_output=True,
            text=True,
        )
        if out.returncode != 0:
            raise RuntimeError(out.stderr)
        return json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        server.terminate()  # `timeout` passes SIGTERM on to the benchmark process
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--n", type=int, default=10000)
    args = parser.parse_args()
    ln29_python = os.path.join(LN29_VENV, "bin", "python")
    with tempfile.TemporaryDirectory() as core_home, tempfile.TemporaryDirectory() as ln29_home:
        core = Manager(core_home)
        ln29 = Ln29Manager(ln29_home)
        systems = {"ln_core": (sys.executable, core.env()), "LN 2.9": (ln29_python, ln29.env())}
        results = {}
        try:
            for rep in range(args.reps):
                for placement, (a, b) in {"same core": (1, 1), "split cores": (1, 0)}.items():
                    for name, (python, env) in systems.items():
                        tag = "r%d%s" % (rep, placement[:2])
                        r = run_pair(python, env, ["pong", tag], ["ping", tag, str(args.n)], a, b)
                        results.setdefault(("pub/sub RTT 64 B", placement, name), []).append(r)
                        try:
                            r = run_pair(
                                python,
                                env,
                                ["provide", "bench.srv." + tag],
                                ["call", "bench.srv." + tag, str(args.n)],
                                a,
                                b,
                                wait_ready=True,
                            )
                            results.setdefault(("service RTT small", placement, name), []).append(r)
                        except RuntimeError as error:
                            print("%s service benchmark failed: %s" % (name, str(error).strip()[-200:]))
        finally:
            core.stop()
            ln29.stop()
    print("| test | placement | system | median us | p99 us |")
    print("|---|---|---|---|---|")
    for (test, placement, name), runs in sorted(results.items()):
        print(
            "| %s | %s | %s | %.1f | %.1f |"
            % (
                test,
                placement,
                name,
                statistics.median(r["median_us"] for r in runs),
                statistics.median(r["p99_us"] for r in runs),
            )
        )


if __name__ == "__main__":
    main()
