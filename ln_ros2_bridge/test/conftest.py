"""Test set-up for ln_ros2_bridge.

Before any test runs, this file (1) builds the ROS interfaces of the test LN
definitions (test/msgdefs, the elevator) once into a cached colcon workspace,
(2) puts them on the paths, and (3) re-runs pytest inside netns-run (a private
network namespace with only loopback), so no DDS packet leaves the machine
however pytest was started. Where no namespace can be made it falls back to
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a loopback-only CYCLONEDDS_URI.

Fixtures: `ln` (an LN manager; parametrized over LN 2.9 and ln_core, skipped
when one is not available), `start_bridge`, `ln_peer`, `ros` (an in-process
rclpy node with a spinning executor), `bridge_loops` (waits for the bridges'
own progress before checking that something did not happen).
"""

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
PACKAGE_ROOT = HERE.parent
REPO_ROOT = PACKAGE_ROOT.parent
ELEVATOR_MSGDEFS = REPO_ROOT / "ln_core" / "examples" / "elevator" / "msgdefs"
MD_DIRS = [HERE / "msgdefs", ELEVATOR_MSGDEFS]
MANAGER_MD_DIRS = MD_DIRS + [HERE / "msgdefs_unmapped"]

sys.path.insert(0, str(PACKAGE_ROOT))
sys.path.insert(0, str(REPO_ROOT / "tests" / "support"))
import ln_testing  # noqa: E402
import ros_testing  # noqa: E402


def _prepare_and_reexec():
    env = dict(os.environ)
    install = ros_testing.build_interfaces(MD_DIRS, "test", log=str(ln_testing.CACHE / "ln_ros2_bridge-test-build.log"))
    env = ros_testing.interface_env(install, env)
    env.update(ros_testing.loopback_dds_env())
    env["PYTHONPATH"] = os.pathsep.join([str(PACKAGE_ROOT), env.get("PYTHONPATH", "")])
    env["LN_ROS2_BRIDGE_TEST_ENV"] = "1"
    argv = [sys.executable] + sys.orig_argv[1:]
    netns = ros_testing.netns_run()
    if (
        not ros_testing.network_is_isolated()
        and netns
        and subprocess.run([netns, "true"], capture_output=True, timeout=30).returncode == 0
    ):
        env["LN_ROS2_BRIDGE_NETNS"] = "1"
        os.execve(netns, [netns] + argv, env)
    os.execve(sys.executable, argv, env)  # library paths must be set before the process starts


def pytest_configure(config):
    if os.environ.get("LN_ROS2_BRIDGE_TEST_ENV") != "1":
        # pytest captures stdout/stderr at the fd level by now: give the real ones back first.
        capture = config.pluginmanager.getplugin("capturemanager")
        if capture is not None:
            capture.stop_global_capturing()
        _prepare_and_reexec()


def pytest_report_header(config):
    return "ln_ros2_bridge: network %s" % (
        "isolated (netns-run)" if ros_testing.network_is_isolated() else "NOT isolated: loopback-only DDS settings"
    )


# ---------------------------------------------------------------------------------------------
class Process:
    """A process started by a test: its log, JSON events, and a clean stop."""

    def __init__(self, name, cmd, env, work_dir):
        self.name = name
        self.log_path = Path(work_dir) / ("%s.log" % name)
        self.proc = ln_testing.start(cmd, self.log_path, env=env)

    def text(self):
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def events(self):
        return ln_testing.json_events(self.log_path)

    def wait_event(self, name, timeout=20.0, count=1):
        def found():
            if self.proc.poll() is not None and len([e for e in self.events() if e.get("event") == name]) < count:
                raise AssertionError(
                    "%s exited (%s) without event %r:\n%s"
                    % (self.name, self.proc.returncode, name, ln_testing.tail(self.log_path))
                )
            matching = [e for e in self.events() if e.get("event") == name]
            return matching if len(matching) >= count else None

        return ln_testing.wait_for(found, timeout, "%s: event %s" % (self.name, name))

    def events_named(self, name):
        return [e for e in self.events() if e.get("event") == name]

    def feed_until(self, publish, packets, timeout=20.0):
        """Calls publish() every 20 ms until this subscriber has logged `packets` packet events in
        all, or `timeout` s have passed (the caller then waits for them and fails if they miss)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and len(self.events_named("packet")) < packets:
            publish()
            time.sleep(0.02)

    def wait_log(self, pattern, timeout=20.0):
        return ln_testing.wait_for_log(self.log_path, pattern, timeout, self.proc)

    def running(self):
        return self.proc.poll() is None

    def stop(self, timeout=10.0):
        return ln_testing.stop(self.proc, timeout)


@pytest.fixture
def work_dir(tmp_path):
    return tmp_path


@pytest.fixture(params=["ln29", "ln_core"])
def ln(request, tmp_path):
    try:
        system = ln_testing.ln_system(request.param, tmp_path / request.param)
    except ln_testing.Unavailable as error:
        pytest.skip(str(error))
    system.start([str(d) for d in MANAGER_MD_DIRS])
    yield system
    system.stop()


@pytest.fixture
def processes():
    started = []
    yield started
    for p in reversed(started):
        p.stop()
    ln_testing.remove_ln_segments(p.proc.pid for p in started)


@pytest.fixture
def start_bridge(ln, tmp_path, processes):
    """start_bridge(config_dict, name="bridge") -> Process; waits until the first pass is done."""
    import yaml

    def start(config, name="bridge", wait=None, extra_args=(), env=None):
        path = tmp_path / ("%s.yaml" % name)
        path.write_text(yaml.safe_dump(config))
        cmd = [
            sys.executable,
            "-m",
            "ln_ros2_bridge",
            "--config",
            path,
            "--ln-manager",
            ln.address,
            "--log-level",
            "debug",
            *extra_args,
        ]
        proc = Process(name, cmd, ln.env(env), tmp_path)
        processes.append(proc)
        for pattern in ["connected to the LN manager"] + list(wait or ()):
            proc.wait_log(pattern, 30)
        return proc

    return start


@pytest.fixture
def ln_peer(ln, tmp_path, processes):
    """ln_peer(name, *args) -> Process running helpers/ln_peer.py on the LN system's package."""
    counter = [0]

    def start(name, *args):
        counter[0] += 1
        cmd = [ln.peer_python(), HERE / "helpers" / "ln_peer.py", *map(str, args), "--client-name", name]
        proc = Process("%s-%d" % (name, counter[0]), cmd, ln.env(), tmp_path)
        processes.append(proc)
        return proc

    return start


class RosPeer:
    """An rclpy node spinning in a background thread, for the test's ROS side."""

    def __init__(self, name):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, client, request, timeout=10.0):
        future = client.call_async(request)
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            client.remove_pending_request(future)
            raise TimeoutError("no response from %s within %.1f s" % (client.srv_name, timeout))
        return future.result()

    def close(self):
        self._stop.set()
        self._thread.join(timeout=5)
        self.executor.shutdown(timeout_sec=2)
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)


@pytest.fixture
def ros():
    peer = RosPeer("test_peer_%d" % os.getpid())
    yield peer
    peer.close()


def wait_until(predicate, timeout, what):
    return ln_testing.wait_for(predicate, timeout, what, interval=0.02)


class BridgeLoops:
    """Watches /diagnostics, which each bridge publishes once a second from its
    reconciliation thread, between passes: for checks that something does NOT happen,
    wait_passes() waits until the bridges have run long enough for it to have happened
    (their own progress, not a guess of wall-clock time on a loaded machine)."""

    def __init__(self, ros):
        from diagnostic_msgs.msg import DiagnosticArray

        self._lock = threading.Lock()
        self._seen = []  # node names, one per /diagnostics message
        ros.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_array, 50)

    def _on_array(self, array):
        suffix = ": LN connection"
        with self._lock:
            self._seen += [s.name[: -len(suffix)] for s in array.status if s.name.endswith(suffix)]

    def wait_passes(self, node_names, reports=3, timeout=60):
        """Returns once each bridge in `node_names` has published `reports` more
        diagnostics (so ran at least `reports` - 1 seconds with reconciliation passes
        in between) than when called."""
        with self._lock:
            start = len(self._seen)

        def done():
            with self._lock:
                later = self._seen[start:]
            return all(later.count(name) >= reports for name in node_names)

        wait_until(done, timeout, "%d diagnostics reports from each of %s" % (reports, ", ".join(node_names)))


@pytest.fixture
def bridge_loops(ros):
    return BridgeLoops(ros)


def ln_snapshot(ln):
    """(topics, services) the LN manager knows now, as the bridge reads them; the probe's
    client name matches the bridges' pattern, so bridges ignore it."""
    from ln_ros2_bridge.ln_introspection import Ln29Introspection, LnCoreIntrospection

    if ln.kind == "ln29":
        intro = Ln29Introspection(ln.address)
        try:
            return intro.snapshot()
        finally:
            intro.close()
    client = ln_core_probe(ln)
    try:
        intro = LnCoreIntrospection(client)
        return intro.topics(), intro.services()
    finally:
        client.close()


def ln_core_probe(ln):
    """An ln_core links_and_nodes client of the test's manager (close it)."""
    if ln.python_path() not in sys.path:
        sys.path.insert(0, ln.python_path())
    import links_and_nodes

    return links_and_nodes.client("ln_ros2_bridge_test_probe", ln.address)
