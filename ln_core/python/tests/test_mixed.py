"""Python with C++ (tests/cpp/*.cpp, built here with ln_generate + g++
against ln_core's headers and libln): topics both ways, services both ways."""

import os
import subprocess
import threading
import time

import links_and_nodes as ln
import numpy as np
import pytest
from conftest import LN_CORE, MSGDEFS, build_cpp_programs, which_compiler

CPP = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cpp")
PROGRAMS = ("topic_sub", "topic_pub", "echo_provider", "echo_caller")


def _tool(env, default):
    value = os.environ.get(env, default)
    return value if value and os.path.exists(value) else None


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    generate = _tool("LN_CORE_GENERATE", "/tmp/build-py/ln_core/ln_generate")
    lib = _tool("LN_CORE_LIB", "/tmp/build-py/ln_core/libln.so")
    include = os.environ.get("LN_CORE_INCLUDE_DIR", os.path.join(LN_CORE, "include"))
    compiler = which_compiler()
    if not (generate and lib and compiler):
        pytest.skip("needs ln_generate, libln (LN_CORE_GENERATE, LN_CORE_LIB) and g++")
    out = tmp_path_factory.mktemp("cpp")
    subprocess.run(
        [
            generate,
            "-f",
            "--md-dir",
            MSGDEFS,
            "-o",
            str(out / "test_messages.h"),
            "pytest/all_types",
            "pytest/echo",
            "pytest/point",
        ],
        check=True,
        capture_output=True,
    )
    return build_cpp_programs(compiler, lib, [out, include], PROGRAMS, out)


def test_python_publisher_cpp_subscriber(manager, clnt, programs, unique):
    topic = "mixed.py2cpp." + unique
    port = clnt.publish(topic, "pytest/all_types")
    sub = subprocess.Popen([programs["topic_sub"], topic, "3"], env=manager.env(), stdout=subprocess.PIPE, text=True)
    try:
        assert sub.stdout.readline().strip() == "subscribed"
        done = threading.Event()
        lines = []

        def collect():
            lines.extend(sub.stdout.read().splitlines())
            done.set()

        threading.Thread(target=collect, daemon=True).start()
        i = 0
        while not done.is_set() and i < 400:
            i += 1
            port.packet.u32 = i
            port.packet.d = 1.5
            port.packet.vec = [1, 2, i]
            port.packet.name = "py%d" % i
            port.packet.corners[1].x = -2.0
            port.packet.i8 = -7
            port.write()
            time.sleep(0.02)
        assert sub.wait(10) == 0
    finally:
        if sub.poll() is None:
            sub.kill()
    assert len(lines) == 3
    first = int(lines[0].split()[0].split("=")[1])
    for k, line in enumerate(lines):
        j = first + k
        assert line == "u32=%d d=1.5 vec=1,2,%d name=py%d corner1.x=-2 i8=-7" % (j, j, j)


def test_cpp_publisher_python_subscriber(manager, clnt, programs, unique):
    topic = "mixed.cpp2py." + unique
    port = clnt.subscribe(topic, "pytest/all_types", buffers=16)
    pub = subprocess.Popen([programs["topic_pub"], topic, "60"], env=manager.env())
    try:
        seen = []
        deadline = time.time() + 20
        while len(seen) < 5 and time.time() < deadline:
            packet = port.read(1.0)
            if packet is None:
                continue
            seen.append(packet.u32)
            assert packet.d == packet.u32 * 0.5
            assert list(packet.vec) == [0, 0, -packet.u32]
            assert packet.name == "cpp%d" % packet.u32
            assert packet.corners[1].y == 3.25
            assert port.timestamp == 100.0 + packet.u32
        assert len(seen) == 5 and seen == list(range(seen[0], seen[0] + 5))
    finally:
        pub.kill()
        pub.wait()


def python_echo_handler(request, req, resp):
    resp.counter = req.counter + 1
    resp.sum = float(np.sum(req.values)) + req.origin.x
    resp.values = req.values * 2
    resp.text = "cpp: " + req.text
    resp.points = [{"x": p.x, "y": p.y} for p in reversed(req.points)]
    request.respond()
    return 0


def call_echo(svc):
    svc.call(
        counter=41,
        vec=[0, 2, 0],
        values=[1, 2, 3.5],
        text="hello from C++",
        origin={"x": 0.5},
        points=[{"x": 1, "y": 2}, {"x": 3, "y": 4}],
    )
    r = svc.resp
    return "counter=%d sum=%g values=%s text=%s points=%s" % (
        r.counter,
        r.sum,
        ",".join("%g" % v for v in r.values),
        r.text,
        ",".join("(%g,%g)" % (p.x, p.y) for p in r.points),
    )


EXPECTED_ECHO = "counter=42 sum=7 values=2,4,7 text=cpp: hello from C++ points=(3,4),(1,2)"


def test_cpp_provider_python_caller(manager, clnt, programs, unique):
    name = "mixed.cpp_echo." + unique
    provider = subprocess.Popen(
        [programs["echo_provider"], name], env=manager.env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        line = provider.stdout.readline().strip()
        if line != "ready":
            provider.wait(5)
            err = provider.stderr.read()
            pytest.fail("provider failed: %s" % err)
        svc = clnt.get_service(name, "pytest/echo")
        assert call_echo(svc) == EXPECTED_ECHO
        svc2 = clnt.get_service(name)  # interface asked from the manager
        assert call_echo(svc2) == EXPECTED_ECHO
    finally:
        provider.kill()
        provider.wait()


def test_python_provider_cpp_caller(manager, clnt, programs, unique):
    name = "mixed.py_echo." + unique
    svc = clnt.get_service_provider(name, "pytest/echo")
    svc.set_handler(python_echo_handler)
    svc.do_register()
    result = {}

    def run_caller():
        result["out"] = subprocess.run(
            [programs["echo_caller"], name], env=manager.env(), capture_output=True, text=True, timeout=30
        )

    caller = threading.Thread(target=run_caller)
    caller.start()
    deadline = time.time() + 30
    while caller.is_alive() and time.time() < deadline:
        clnt.wait_and_handle_service_group_requests(None, 0.1)
    caller.join()
    out = result["out"]
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == EXPECTED_ECHO


def test_python_provider_python_caller(clnt, unique):
    name = "mixed.py_py." + unique
    svc = clnt.get_service_provider(name, "pytest/echo")
    svc.set_handler(python_echo_handler)
    svc.do_register(group_name="pool_group")
    clnt.handle_service_group_in_thread_pool("pool_group", "pool")
    caller = ln.client("py_caller").get_service(name, "pytest/echo")
    assert call_echo(caller) == EXPECTED_ECHO
