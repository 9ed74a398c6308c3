"""Services: callers, providers, errors, async calls, the wrapped API."""

import signal
import subprocess
import sys
import textwrap
import threading
import time

import links_and_nodes as ln
import ln_testing  # tests/support, on sys.path through conftest.py
import numpy as np
import pytest
from conftest import AreaCalls, AreaProvider


class Provider:
    """A provider client whose default group is served by a thread."""

    def __init__(self, name, interface, handler):
        self.client = ln.client("pytest_provider")
        self.svc = self.client.get_service_provider(name, interface)
        self.svc.set_handler(handler)
        self.svc.do_register()
        self.calls = 0
        self.running = True
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while self.running:
            self.client.wait_and_handle_service_group_requests(None, 0.05)

    def stop(self):
        self.running = False
        self.thread.join(5)
        self.client.close()


@pytest.fixture
def serve():
    providers = []

    def start(name, interface, handler):
        providers.append(Provider(name, interface, handler))
        return providers[-1]

    yield start
    for p in providers:
        p.stop()


def small_handler(request, req, resp):
    resp.seq = req.seq
    resp.y = req.x * 2
    request.respond()
    return 0


def echo_handler(request, req, resp):
    resp.counter = req.counter + 1
    resp.sum = float(np.sum(req.values))
    resp.values = req.values[::-1]
    resp.text = req.text.upper()
    resp.points = list(req.points) + [req.origin]
    request.respond()
    return 0


def test_fixed_size_call(clnt, serve, unique):
    serve("svc.small." + unique, "pytest/small_srv", small_handler)
    svc = clnt.get_service("svc.small." + unique, "pytest/small_srv")
    assert svc.call(seq=3, x=1.25) is svc
    assert (svc.resp.seq, svc.resp.y) == (3, 2.5)
    svc.req.seq = 4
    svc.call()
    assert svc.resp.seq == 4
    svc.call(5, 2.0)  # positional, in field order
    assert (svc.resp.seq, svc.resp.y) == (5, 4.0)


def test_dynamic_fields_text_and_sub_types(clnt, serve, unique):
    serve("svc.echo." + unique, "pytest/echo", echo_handler)
    svc = clnt.get_service("svc.echo." + unique)  # interface from the manager
    assert svc.interface == "pytest/echo"
    svc.call(
        counter=1,
        values=[1.0, 2.0, 4.0],
        text="grüße",
        origin={"x": 9.0, "y": 8.0},
        points=[svc.req.new_point_t_packet(x=1.0)],
    )
    r = svc.resp
    assert r.counter == 2 and r.sum == 7.0
    assert isinstance(r.values, np.ndarray) and list(r.values) == [4.0, 2.0, 1.0] and r.values_len == 3
    assert r.text == "GRÜSSE"
    assert [(p.x, p.y) for p in r.points] == [(1.0, 0.0), (9.0, 8.0)]
    svc.call(values=np.arange(10000, dtype=np.float64), text="", points=[])
    assert svc.resp.sum == float(np.arange(10000).sum()) and svc.resp.text == ""


def test_bad_input_is_refused_before_sending(clnt, serve, unique):
    calls = []

    def counting(request, req, resp):
        calls.append(req.seq)
        return small_handler(request, req, resp)

    serve("svc.bad." + unique, "pytest/small_srv", counting)
    svc = clnt.get_service("svc.bad." + unique, "pytest/small_srv")
    with pytest.raises(AttributeError, match="seqq"):
        svc.call(seqq=1)
    with pytest.raises(ln.FieldTypeError, match="'x'"):
        svc.call(seq=1, x="one")
    with pytest.raises(ln.FieldValueError, match="'seq'"):
        svc.call(seq=-1, x=1.0)
    assert calls == []
    echo = clnt.get_service("svc.bad." + unique + ".echo", "pytest/echo")
    with pytest.raises(ln.FieldValueError, match="'text'"):
        echo.call(text="\ud800")
    with pytest.raises(ln.FieldTypeError, match="'values'"):
        echo.call(values=["a"])


def test_errors_from_the_provider(clnt, serve, unique):
    def handler(request, req, resp):
        if req.seq == 1:
            raise RuntimeError("kaputt")
        if req.seq == 2:
            return 7
        if req.seq == 3:
            return 0  # forgot to respond
        request.respond_error(9, "explained")
        return 0

    serve("svc.err." + unique, "pytest/small_srv", handler)
    svc = clnt.get_service("svc.err." + unique, "pytest/small_srv")
    with pytest.raises(ln.LNError, match="kaputt") as info:
        svc.call(seq=1)
    assert info.value.code == ln.LNE_SVC_HANDLER_EXC
    with pytest.raises(ln.LNError) as info:
        svc.call(seq=2)
    assert info.value.code == ln.LNE_USER_DEFINED_ERROR and info.value.user_code == 7
    with pytest.raises(ln.LNError) as info:
        svc.call(seq=3)
    assert info.value.code == ln.LNE_SVC_HANDLER_NO_RESP
    with pytest.raises(ln.LNError, match="explained") as info:
        svc.call(seq=4)
    assert info.value.user_code == 9


def test_no_provider(clnt, unique):
    svc = clnt.get_service("svc.nobody." + unique, "pytest/small_srv")
    with pytest.raises(ln.LNError):
        svc.call(seq=1)
    with pytest.raises(ln.LNError):
        clnt.get_service("svc.nobody." + unique)  # no interface known
    assert clnt.wait_for_service("svc.nobody." + unique, 0.1) is False


def sleepy(request, req, resp):
    deadline = time.time() + req.seconds
    while time.time() < deadline:
        if request.is_aborted():  # the caller gave up: stop early
            return 0
        time.sleep(0.01)
    resp.done = 1
    request.respond()
    return 0


def recorded(handler, started, finished):
    """`handler`, setting the events `started` and `finished` around each call."""

    def run(request, req, resp):
        started.set()
        try:
            return handler(request, req, resp)
        finally:
            finished.set()

    return run


def test_timeout_async_and_futures(clnt, serve, unique):
    finished = threading.Event()
    serve("svc.sleep." + unique, "pytest/sleep", recorded(sleepy, threading.Event(), finished))
    svc = clnt.get_service("svc.sleep." + unique, "pytest/sleep")
    with pytest.raises(ln.LNError) as info:
        svc.call_with_timeout(seconds=5.0, timeout=0.2)  # the handler outlasts the timeout, even on a loaded machine
    assert info.value.code == ln.LNE_SVC_TIMEOUT
    assert finished.wait(10), "the handler of the timed-out call never returned"  # the provider is free again
    svc.call_async(seconds=1.0)
    assert svc.finished() is False  # the handler takes a second
    deadline = time.time() + 20
    while not svc.finished():
        assert time.time() < deadline
        time.sleep(0.01)
    assert svc.resp.done == 1
    future = svc.call_future(seconds=0.1)
    assert future.result(5).done == 1 and future.done()


def test_wait_for_service_and_availability(clnt, serve, unique):
    name = "svc.avail." + unique
    assert clnt.wait_for_service(name, 0) is False
    events = []
    clnt.set_service_availability_handler(name, lambda n, up: events.append(up))
    found = []
    waiting = threading.Event()

    def wait():
        waiting.set()
        found.append(clnt.wait_for_service(name, 10))

    waiter = threading.Thread(target=wait)
    waiter.start()
    assert waiting.wait(10)
    ln_testing.wait_asleep(waiter.native_id, 10, "the waiter blocked in wait_for_service()")
    assert found == [], "wait_for_service returned before the service existed"
    serve(name, "pytest/small_srv", small_handler)
    waiter.join(10)
    assert found == [True]
    ln_testing.wait_for(lambda: True in events, 10, "the availability handler to see the service")
    assert events[0] is False and True in events


CALL_SCRIPT = textwrap.dedent("""
    import sys, links_and_nodes as ln
    svc = ln.client("sigint_caller").get_service(sys.argv[1], "pytest/sleep")
    print("calling", flush=True)
    try:
        svc.call(seconds=30)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
""")


def test_ctrl_c_interrupts_a_blocking_call(manager, serve, tmp_path, unique):
    name = "svc.sigint." + unique
    handling = threading.Event()
    serve(name, "pytest/sleep", recorded(sleepy, handling, threading.Event()))
    script = tmp_path / "call.py"
    script.write_text(CALL_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), name], env=manager.env(), stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "calling"
        assert handling.wait(20), "the call never reached the provider"  # so the caller blocks in call()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=25)  # the call itself takes 30 s: ending sooner means interrupted
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "interrupted" in out


# ------------------------------------------------------------- wrapped API


def test_wrapped_api(clnt, unique):
    prefix = "area." + unique
    provider_client = ln.client("wrapped_provider")
    areas = AreaProvider(provider_client, prefix)
    thread = threading.Thread(target=areas.handle_service_group_requests, daemon=True)
    thread.start()
    try:
        calls = AreaCalls(clnt, prefix)
        result = calls.compute_circle_area(2.0)
        assert result["error_code"] == 0 and abs(result["area"] - 12.566) < 1e-3
        with pytest.raises(ln.ServiceErrorResponse, match="negative radius") as info:
            calls.compute_circle_area(radius=-1.0)
        assert info.value.response["error_code"] == 1
        with pytest.raises(ln.ServiceErrorResponse, match="no triangles today"):
            calls.triangle(3.0)
        with pytest.raises(TypeError, match="radius"):
            calls.compute_circle_area()
        with pytest.raises(AttributeError, match="diameter"):
            calls.compute_circle_area(diameter=1)
    finally:
        areas.keep_running = False
        thread.join(5)
        provider_client.close()
