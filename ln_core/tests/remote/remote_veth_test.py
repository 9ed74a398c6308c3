#!/usr/bin/env python3
"""Topic data between two hosts, for real: two network namespaces joined by a
veth pair. Namespace A runs ln_manager (--listen on A's veth address) and the
publisher; namespace B runs the subscriber, which reaches the manager across
the veth. The two clients therefore have different host ids (ln_core's host
id includes the network namespace), so the data goes over the network:

  * UDP by default, TCP with need_reliable_transport -- checked with the
    kernel's per-namespace counters (/proc/net/snmp of B: UDP datagrams in,
    TCP connections accepted);
  * 4 KiB packets (IP-fragmented) and 150 kB packets (several datagrams);
  * in order, with correct payloads (every byte checked), no holes over TCP;
  * publisher restart: the first publisher exits (or is SIGKILLed mid-stream)
    and a second one takes over the topic; the same subscription gets its
    data without re-subscribing;
  * joining a running stream (UDP and TCP): the subscriber's first packet is
    the first one the publisher wrote after it counted the subscriber
    (has_subscriber() turned true after packet N: the first packet is at
    most N + 1, and its sequence minus its `lost` says where the
    subscription started, at most N), and every later one arrives or is
    counted in `lost`: received + lost == last sequence - start;
  * network loss, duplicates and reordering (UDP): this kernel has no netem,
    so the publisher's client drops every 5th datagram, duplicates every 7th
    and swaps every 11th with the next one (LN_CORE_TEST_UDP_FAULTS, a test
    hook compiled into test builds only); the subscriber sees the
    publisher's sequence numbers, increasing, each packet once, and its
    summed `lost` plus received equals the publisher's count.

Needs root (ip netns, veth). Without it: exit 77 (ctest skip), or exit 1 when
CI is set. Everything it creates (namespaces with the veth pair, processes,
a temporary HOME) is removed on every path; names are unique per run.

usage: remote_veth_test.py --manager PATH --publisher PATH --subscriber PATH --md-dir DIR
"""

from __future__ import annotations

import argparse
import os
import queue
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

SKIP = 77
TOTAL_LIMIT_S = 140  # ctest's TIMEOUT is 190: we stop (and clean up) first
NS_PREFIX = "ln_remote_"


class TestFailure(Exception):
    pass


class Abort(BaseException):
    """A signal or the overall time limit: stop everything, clean up."""


class Unavailable(Exception):
    """The namespaces cannot be created here (not root, no iproute2...)."""


def log(text: str) -> None:
    print(f"[remote_veth] {text}", flush=True)


def sh(*argv: str, timeout: float = 10, check: bool = True) -> subprocess.CompletedProcess:
    p = subprocess.run(list(argv), capture_output=True, text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise subprocess.CalledProcessError(p.returncode, argv, p.stdout, p.stderr)
    return p


# ------------------------------------------------------------- namespaces


class Network:
    """Namespaces A and B, veth pair A <-> B, addresses 10.x.y.1 and .2/24."""

    def __init__(self) -> None:
        tag = f"{os.getpid()}_{secrets.token_hex(3)}"
        self.ns_a, self.ns_b = f"{NS_PREFIX}{tag}_a", f"{NS_PREFIX}{tag}_b"
        short = secrets.token_hex(3)
        self.veth_a, self.veth_b = f"lnr{short}a", f"lnr{short}b"  # <= 15 characters
        octet2, octet3 = 200 + secrets.randbelow(50), secrets.randbelow(250)
        self.ip_a, self.ip_b = f"10.{octet2}.{octet3}.1", f"10.{octet2}.{octet3}.2"
        self.created: list[str] = []

    def create(self) -> None:
        if os.geteuid() != 0:
            raise Unavailable("not running as root")
        if not shutil.which("ip"):
            raise Unavailable("no `ip` command (iproute2)")
        try:
            for ns in (self.ns_a, self.ns_b):
                sh("ip", "netns", "add", ns)
                self.created.append(ns)
            sh(
                "ip",
                "link",
                "add",
                self.veth_a,
                "netns",
                self.ns_a,
                "type",
                "veth",
                "peer",
                "name",
                self.veth_b,
                "netns",
                self.ns_b,
            )
            for ns, dev, ip in ((self.ns_a, self.veth_a, self.ip_a), (self.ns_b, self.veth_b, self.ip_b)):
                sh("ip", "-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
                sh("ip", "-n", ns, "link", "set", dev, "up")
                sh("ip", "-n", ns, "link", "set", "lo", "up")
        except (subprocess.CalledProcessError, OSError) as e:
            detail = getattr(e, "stderr", "") or str(e)
            raise Unavailable(
                f"creating namespaces/veth failed: {' '.join(map(str, getattr(e, 'cmd', [])))}: {detail.strip()}"
            ) from e
        # Wait until the link is up on both ends (carrier).
        if not shutil.which("ping"):
            deadline = time.monotonic() + 10
            ends = ((self.ns_a, self.veth_a), (self.ns_b, self.veth_b))
            while time.monotonic() < deadline:
                shown = [sh("ip", "-n", ns, "link", "show", "dev", dev, check=False).stdout for ns, dev in ends]
                if all("LOWER_UP" in text for text in shown):
                    return
                time.sleep(0.05)
            raise TestFailure(f"the veth pair {self.veth_a} - {self.veth_b} did not come up")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            if (
                sh("ip", "netns", "exec", self.ns_a, "ping", "-c", "1", "-W", "1", self.ip_b, check=False).returncode
                == 0
            ):
                return
            time.sleep(0.1)
        raise TestFailure(f"no connectivity {self.ip_a} -> {self.ip_b} over the veth pair")

    def destroy(self) -> None:
        for ns in reversed(self.created):
            sh("ip", "netns", "del", ns, check=False)  # takes the veth pair with it
        self.created.clear()

    def snmp(self, ns: str) -> dict[tuple[str, str], int]:
        """The namespace's /proc/net/snmp counters, {("Udp", "InDatagrams"): n}."""
        text = sh("ip", "netns", "exec", ns, "cat", "/proc/net/snmp").stdout.splitlines()
        counters = {}
        for header, values in zip(text[0::2], text[1::2]):
            proto, names = header.split(":", 1)
            for name, value in zip(names.split(), values.split(":", 1)[1].split()):
                counters[(proto, name)] = int(value)
        return counters


def remove_stale_namespaces() -> None:
    """Namespaces of earlier runs of this test whose process is gone (a run
    killed by SIGKILL could not clean up)."""
    listing = sh("ip", "netns", "list", check=False).stdout
    for line in listing.splitlines():
        name = line.split()[0] if line.split() else ""
        m = re.fullmatch(rf"{NS_PREFIX}(\d+)_[0-9a-f]+_[ab]", name)
        if m and not os.path.exists(f"/proc/{m.group(1)}"):
            log(f"removing stale namespace {name}")
            sh("ip", "netns", "del", name, check=False)


# -------------------------------------------------------------- processes


class Program:
    """A program started in a namespace; stdout lines collected by a thread."""

    all: list[Program] = []

    def __init__(self, ns: str, argv: list[str], env: dict[str, str], label: str) -> None:
        self.label = label
        self.argv = ["ip", "netns", "exec", ns, *argv]  # ip execs the program: same PID
        self.proc = subprocess.Popen(
            self.argv, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        Program.all.append(self)
        self.lines: list[str] = []
        self.err: list[str] = []
        self.queue: queue.Queue[str | None] = queue.Queue()
        self.pumps = [
            threading.Thread(target=self._pump, args=(self.proc.stdout, self.lines, True), daemon=True),
            threading.Thread(target=self._pump, args=(self.proc.stderr, self.err, False), daemon=True),
        ]
        for pump in self.pumps:
            pump.start()

    def _pump(self, stream, sink, to_queue):
        for raw in stream:
            line = raw.decode("utf-8", "replace").rstrip("\n")
            sink.append(line)
            if to_queue:
                self.queue.put(line)
        if to_queue:
            self.queue.put(None)

    def wait_for_line(self, pattern: str, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            try:
                line = self.queue.get(timeout=left)
            except queue.Empty:
                break
            if line is None:
                break
            if re.match(pattern, line):
                return line
        raise TestFailure(f"{self.label}: no line matching {pattern!r} within {timeout} s\n{self.describe()}")

    def wait(self, timeout: float) -> int:
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise TestFailure(f"{self.label} did not exit within {timeout} s\n{self.describe()}") from None

    def kill(self, sig: int = signal.SIGKILL) -> None:
        if self.proc.poll() is None:
            try:
                os.kill(self.proc.pid, sig)
            except ProcessLookupError:
                pass
            if sig == signal.SIGKILL:
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    pass

    def describe(self) -> str:
        if self.proc.poll() is not None:  # all it wrote, once the reader threads reach the end
            for pump in self.pumps:
                pump.join(5)
        return (
            f"--- {self.label}: {' '.join(self.argv)} (exit {self.proc.poll()})\n"
            + "\n".join(self.lines[-40:])
            + "\n--- stderr\n"
            + "\n".join(self.err[-40:])
        )


def stop_all() -> None:
    for program in Program.all:
        program.kill(signal.SIGTERM)
    deadline = time.monotonic() + 5
    for program in Program.all:
        try:
            program.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            program.kill(signal.SIGKILL)


# ------------------------------------------------------------------ checks

STATS = re.compile(r"epoch (\d+) first (\d+) last (\d+) received (\d+) missing (\d+) disorder (\d+) bad (\d+)")


def epoch_stats(subscriber: Program) -> dict[int, dict[str, int]]:
    stats = {}
    for line in subscriber.lines:
        m = STATS.fullmatch(line)
        if m:
            e, first, last, received, missing, disorder, bad = map(int, m.groups())
            stats[e] = dict(first=first, last=last, received=received, missing=missing, disorder=disorder, bad=bad)
    return stats


def run_case(
    net: Network, tools, env, manager_address: str, transport: str, kind: str, count: int, period: float, restart: str
) -> str:
    """One subscriber in B; publisher epoch 1 in A (exits normally or is
    SIGKILLed mid-stream per `restart`), then publisher epoch 2."""
    reliable = transport == "tcp"
    topic = f"remote.{kind}.{transport}.{restart}"
    env = dict(env, LN_MANAGER=manager_address)
    before = net.snmp(net.ns_b)
    subscriber = Program(
        net.ns_b,
        [tools.subscriber, topic, kind, "2", str(count), "40"] + (["reliable"] if reliable else []),
        env,
        f"subscriber[{transport},{kind}]",
    )
    subscriber.wait_for_line(r"subscribed$", 10)
    publisher_args = [
        kind,
        "{epoch}",
        str(count),
        str(period),
        "--wait-subscriber",
        "5",
        "--settle",
        "0.5",
        "--linger",
        "0.5",
    ]

    def publisher(epoch: int) -> Program:
        args = [tools.publisher, topic] + [a.format(epoch=epoch) for a in publisher_args]
        return Program(net.ns_a, args, env, f"publisher{epoch}[{transport},{kind}]")

    first = publisher(1)
    first.wait_for_line(r"subscriber seen$", 10)
    subscriber.wait_for_line(r"epoch 1 first \d+$", 10)
    if restart == "kill":
        first.wait_for_line(rf"wrote {count // 20 * 10}$", 30)
        first.kill(signal.SIGKILL)
    else:
        first.wait_for_line(rf"published {count}$", 30)
        if first.wait(10) != 0:
            raise TestFailure(f"publisher 1 failed\n{first.describe()}")
    second = publisher(2)
    second.wait_for_line(r"subscriber seen$", 10)
    rc = subscriber.wait(45)
    second.wait(10)
    after = net.snmp(net.ns_b)

    stats = epoch_stats(subscriber)
    problems = []
    if rc != 0 or subscriber.lines[-1:] != ["done"]:
        problems.append(f"subscriber exit {rc}, did not get packet {count} of epoch 2")
    # Over UDP a datagram may be dropped under load: allow a few holes; none over TCP.
    allowed_missing = 0 if reliable else max(2, count // 50)
    for epoch in (1, 2):
        s = stats.get(epoch)
        if not s or s["received"] == 0:
            problems.append(f"epoch {epoch}: nothing received")
            continue
        if s["bad"] or s["disorder"]:
            problems.append(f"epoch {epoch}: {s['bad']} wrong payloads, {s['disorder']} out of order")
        if s["missing"] > allowed_missing:
            problems.append(f"epoch {epoch}: {s['missing']} packets missing between {s['first']} and {s['last']}")
        if s["first"] > max(3, count // 10):
            problems.append(f"epoch {epoch}: data started only at packet {s['first']}")
    if 2 in stats and stats[2]["last"] != count:
        problems.append(f"epoch 2 ended at {stats[2]['last']} of {count}")
    if restart == "exit" and 1 in stats and stats[1]["last"] < count - allowed_missing:
        problems.append(f"epoch 1 ended at {stats[1]['last']} of {count}")
    # Which transport carried the data: B's kernel counters.
    udp_in = after[("Udp", "InDatagrams")] - before[("Udp", "InDatagrams")]
    accepted = after[("Tcp", "PassiveOpens")] - before[("Tcp", "PassiveOpens")]
    received = sum(s["received"] for s in stats.values())
    if reliable:
        if udp_in > 10 or accepted < 2:
            problems.append(f"expected TCP: {udp_in} UDP datagrams in, {accepted} TCP connections accepted in B")
    else:
        if udp_in < received or accepted != 0:
            problems.append(
                f"expected UDP: {udp_in} UDP datagrams in for {received} packets, "
                f"{accepted} TCP connections accepted in B"
            )
    summary = (
        f"{transport} {kind} restart={restart}: "
        + ", ".join(
            f"epoch {e} {s['first']}..{s['last']} received {s['received']} missing {s['missing']}"
            for e, s in sorted(stats.items())
        )
        + f"; B saw {udp_in} UDP datagrams, {accepted} TCP accepts"
    )
    if problems:
        raise TestFailure(
            summary
            + "\n  "
            + "\n  ".join(problems)
            + "\n"
            + subscriber.describe()
            + "\n"
            + first.describe()
            + "\n"
            + second.describe()
        )
    return summary


INFO = re.compile(r"info (\d+) mismatch (\d+) lost (\d+) received (\d+) last_sequence (\d+)")
FIRST_INFO = re.compile(r"first_info (\d+) seq (\d+) sequence (\d+) lost (\d+)")


def sample_info(subscriber: Program) -> tuple[dict[int, dict[str, int]], dict[int, dict[str, int]]]:
    """The subscriber's info lines: per epoch totals, and its first packet."""
    totals, first = {}, {}
    for line in subscriber.lines:
        if m := INFO.fullmatch(line):
            e, mismatch, lost, received, last = map(int, m.groups())
            totals[e] = dict(mismatch=mismatch, lost=lost, received=received, last=last)
        elif m := FIRST_INFO.fullmatch(line):
            e, seq, sequence, lost = map(int, m.groups())
            first[e] = dict(seq=seq, sequence=sequence, lost=lost)
    return totals, first


def run_late_join(net: Network, tools, env, manager_address: str, transport: str) -> str:
    """The publisher streams; a subscriber joins in the middle."""
    reliable = transport == "tcp"
    topic = f"remote.latejoin.{transport}"
    env = dict(env, LN_MANAGER=manager_address)
    count, period, joined_after_at_least = 4000, 0.0005, 200
    publisher = Program(
        net.ns_a,
        [tools.publisher, topic, "packet", "1", str(count), str(period)],
        env,
        f"publisher[late join,{transport}]",
    )
    publisher.wait_for_line(rf"wrote {joined_after_at_least}$", 10)
    subscriber = Program(
        net.ns_b,
        [tools.subscriber, topic, "packet", "1", str(count), "30"] + (["reliable"] if reliable else []),
        env,
        f"subscriber[late join,{transport}]",
    )
    counted = int(publisher.wait_for_line(r"subscriber counted after \d+$", 10).split()[-1])
    publisher.wait_for_line(rf"published {count}$", 30)
    subscriber.wait(30)
    publisher.wait(10)
    totals, first = sample_info(subscriber)
    stats = epoch_stats(subscriber)
    problems = []
    if 1 not in totals or 1 not in first or 1 not in stats:
        raise TestFailure(
            f"late join {transport}: subscriber got nothing\n{subscriber.describe()}\n{publisher.describe()}"
        )
    t, f, s = totals[1], first[1], stats[1]
    start = f["sequence"] - f["lost"] - 1  # the last packet that was not the subscription's
    if f["sequence"] != f["seq"] or t["mismatch"]:
        problems.append(
            f"sequence numbers are not the publisher's: first packet {f['seq']} reported as "
            f"{f['sequence']}, {t['mismatch']} mismatches"
        )
    if f["seq"] > counted + 1 or start > counted:
        problems.append(
            f"the publisher counted the subscriber after packet {counted}, but its first packet is "
            f"{f['seq']} (lost {f['lost']}: subscription started after {start})"
        )
    if start < joined_after_at_least:
        problems.append(f"subscription started after packet {start}, before the subscriber existed")
    if reliable and (f["lost"] or t["lost"] or s["missing"]):
        problems.append(f"TCP lost packets: first lost {f['lost']}, total lost {t['lost']}, holes {s['missing']}")
    if t["received"] + t["lost"] != t["last"] - start:
        problems.append(
            f"received {t['received']} + lost {t['lost']} != {t['last'] - start} packets {start + 1}..{t['last']}"
        )
    if s["disorder"] or s["bad"]:
        problems.append(f"{s['disorder']} out of order, {s['bad']} wrong payloads")
    if t["last"] < count - 5:
        problems.append(f"ended at {t['last']} of {count}")
    summary = (
        f"late join {transport}: publisher counted the subscriber after {counted}, first packet {f['seq']} "
        f"(sequence {f['sequence']}, lost {f['lost']}), received {t['received']} + lost {t['lost']} of "
        f"{start + 1}..{t['last']}"
    )
    if problems:
        raise TestFailure(
            summary + "\n  " + "\n  ".join(problems) + "\n" + subscriber.describe() + "\n" + publisher.describe()
        )
    return summary


def run_faults(net: Network, tools, env, manager_address: str, kind: str, count: int, period: float) -> str:
    """UDP datagrams lost, duplicated and reordered on the way."""
    topic = f"remote.faults.{kind}"
    env = dict(env, LN_MANAGER=manager_address)
    subscriber = Program(
        net.ns_b, [tools.subscriber, topic, kind, "1", str(count), "30"], env, f"subscriber[faults,{kind}]"
    )
    subscriber.wait_for_line(r"subscribed$", 10)
    faulty = dict(env, LN_CORE_TEST_UDP_FAULTS="drop=5,duplicate=7,reorder=11")
    publisher = Program(
        net.ns_a,
        [tools.publisher, topic, kind, "1", str(count), str(period), "--wait-subscriber", "5"],
        faulty,
        f"publisher[faults,{kind}]",
    )
    publisher.wait_for_line(r"subscriber seen$", 10)
    publisher.wait_for_line(rf"published {count}$", 30)
    subscriber.wait(30)
    publisher.wait(10)
    totals, first = sample_info(subscriber)
    stats = epoch_stats(subscriber)
    if 1 not in totals or 1 not in stats:
        raise TestFailure(f"faults {kind}: subscriber got nothing\n{subscriber.describe()}\n{publisher.describe()}")
    t, f, s = totals[1], first[1], stats[1]
    problems = []
    if t["mismatch"]:
        problems.append(f"{t['mismatch']} packets reported with another sequence than the publisher's")
    if s["disorder"] or s["bad"]:
        problems.append(f"{s['disorder']} duplicated or out of order, {s['bad']} wrong payloads")
    # The subscriber was counted before packet 1: every packet is its own.
    if f["sequence"] - f["lost"] != 1:
        problems.append(f"first packet {f['sequence']} with lost {f['lost']}: not counted from packet 1")
    if t["received"] + t["lost"] != t["last"]:
        problems.append(f"received {t['received']} + lost {t['lost']} != {t['last']} packets written")
    if t["last"] < count - 5:
        problems.append(f"ended at {t['last']} of {count}")
    if t["lost"] < count // 10:
        problems.append(
            f"only {t['lost']} of {count} packets lost: the fault injection "
            f"(LN_CORE_TEST_UDP_FAULTS, test builds) did not work"
        )
    summary = (
        f"faults udp {kind}: received {t['received']} + lost {t['lost']} = {t['last']} written, holes {s['missing']}"
    )
    if problems:
        raise TestFailure(
            summary + "\n  " + "\n  ".join(problems) + "\n" + subscriber.describe() + "\n" + publisher.describe()
        )
    return summary


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--manager", required=True)
    parser.add_argument("--publisher", required=True)
    parser.add_argument("--subscriber", required=True)
    parser.add_argument("--md-dir", required=True)
    tools = parser.parse_args()
    in_ci = bool(os.environ.get("CI"))

    def on_signal(signum, _frame):
        raise Abort(
            f"interrupted by signal {signum}"
            if signum != signal.SIGALRM
            else f"overall time limit of {TOTAL_LIMIT_S} s reached"
        )

    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGALRM):
        signal.signal(sig, on_signal)
    signal.alarm(TOTAL_LIMIT_S)

    net = Network()
    home = tempfile.mkdtemp(prefix="ln_remote_home_")
    status = 1
    try:
        if os.geteuid() == 0 and shutil.which("ip"):
            remove_stale_namespaces()
        try:
            net.create()
        except Unavailable as e:
            message = f"cannot create network namespaces joined by a veth pair ({e}); this test needs root and iproute2"
            if in_ci:
                log(f"FAIL: {message} (CI is set, so this is a failure, not a skip)")
                return 1
            log(f"SKIP: {message}")
            return SKIP
        log(f"namespaces {net.ns_a} ({net.ip_a}) and {net.ns_b} ({net.ip_b}) joined by {net.veth_a}/{net.veth_b}")
        env = {k: v for k, v in os.environ.items() if not k.startswith("LN_")}
        env["HOME"] = home
        config = os.path.join(home, "remote.lnc")
        with open(config, "w") as f:
            f.write(
                f"instance\nname: ln_remote_test_{os.getpid()}\nmanager: :54414\n"
                f"add_message_definition_dir: {tools.md_dir}\n"
            )
        manager = Program(net.ns_a, [tools.manager, "-c", config, "--listen", f"{net.ip_a}:0"], env, "ln_manager")
        line = manager.wait_for_line(r"ln_manager: listening on \d+\.\d+\.\d+\.\d+:\d+$", 30)
        address = line.rsplit(" ", 1)[-1]
        log(f"ln_manager in {net.ns_a} listens on {address}")

        cases = [
            ("udp", "packet", 300, 0.002, "exit"),
            ("tcp", "packet", 300, 0.002, "kill"),
            ("udp", "big", 60, 0.01, "kill"),
            ("tcp", "big", 60, 0.01, "exit"),
        ]
        runs = [lambda case=case: run_case(net, tools, env, address, *case) for case in cases]
        runs += [
            lambda transport=transport: run_late_join(net, tools, env, address, transport)
            for transport in ("udp", "tcp")
        ]
        runs += [
            lambda: run_faults(net, tools, env, address, "packet", 600, 0.001),
            lambda: run_faults(net, tools, env, address, "big", 80, 0.01),
        ]
        failures = []
        for run in runs:
            try:
                log("ok: " + run())
            except TestFailure as e:
                failures.append(str(e))
                log(f"FAILED: {e}")
        if manager.proc.poll() is not None:
            failures.append(f"ln_manager died\n{manager.describe()}")
        status = 1 if failures else 0
        log("PASS" if status == 0 else f"FAIL: {len(failures)} of {len(runs)} cases failed")
        return status
    except (TestFailure, Abort) as e:
        log(f"FAIL: {e}")
        return 1
    finally:
        signal.alarm(0)
        stop_all()
        net.destroy()
        shutil.rmtree(home, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
