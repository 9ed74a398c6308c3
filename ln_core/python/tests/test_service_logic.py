"""The Python service layer (packing, handlers, wrapped API) over a loopback
stand-in for the native Service: no manager, no libln services needed."""

import math

import links_and_nodes as ln
import numpy as np
import pytest
from conftest import MSGDEFS, AreaCalls, AreaProvider
from links_and_nodes import _ln, _services
from links_and_nodes._packets import Compiler

PROVIDERS = {}


class FakeRequest:
    def __init__(self, flat):
        self._flat = bytes(flat)
        self.responded = False
        self.response = None
        self.error = None

    def data(self):
        return self._flat

    def respond(self, flat):
        self.responded, self.response = True, bytes(flat)

    def respond_error(self, code, message):
        self.responded, self.error = True, (code, message)

    def is_aborted(self):
        return False


class FakeService:
    """Provider and caller in one process: call() runs the handler."""

    def __init__(self, client, name, interface, signature):
        self.name = name
        self.handler = None

    def set_handler(self, handler, request_buffer=None):
        self.handler = handler  # (the native layer prefills request_buffer; the fake lets Python decode)

    def register(self, group_name=None):
        PROVIDERS[self.name] = self

    def call(self, flat, timeout=0.0, into=None):
        provider = PROVIDERS.get(self.name)
        if provider is None:
            raise ln.LNError("no provider registered for service '%s'" % self.name, ln.LNE_REQUEST_FAILED, 0)
        request = FakeRequest(flat)
        ret = provider.handler(request)
        if request.error:
            code, message = request.error
            raise ln.LNError(message, -code if code < 0 else ln.LNE_USER_DEFINED_ERROR, max(code, 0))
        if ret:
            raise ln.LNError("provider returned %d" % ret, ln.LNE_USER_DEFINED_ERROR, ret)
        if not request.responded:
            raise ln.LNError("no response", ln.LNE_SVC_HANDLER_NO_RESP, 0)
        return request.response

    def release(self):
        PROVIDERS.pop(self.name, None)


class FakeClient(ln.client):
    """ln.client without a manager: definitions come from tests/msgdefs."""

    def __init__(self):
        self.name = "fake"
        self._native = None
        self._compiler = Compiler()
        self._models = {}
        self._services = set()

    def _model(self, md_name, text=None):
        if md_name not in self._models:
            self._models[md_name] = _ln.model_from_dirs(md_name, [MSGDEFS])
        return self._models[md_name]

    def get_service(self, service_name, interface_name="", mainloop=None):
        return _services.service_wrapper(self, service_name, interface_name, None, "", is_provider=False)

    def get_service_provider(self, service_name, interface_name, mainloop=None):
        svc = _services.service_wrapper(self, service_name, interface_name, None, "", is_provider=True)
        self._services.add(svc)
        return svc

    def wait_and_handle_service_group_requests(self, group_name=None, timeout=-1):
        pass


@pytest.fixture
def fake(monkeypatch):
    monkeypatch.setattr(_ln, "Service", FakeService)
    PROVIDERS.clear()
    return FakeClient()


def echo_handler(request, req, resp):
    resp.counter = req.counter + 1
    resp.sum = float(np.sum(req.values)) + req.vec[2]
    resp.values = req.values * 2
    resp.text = req.text + "!"
    resp.points = [req.origin] + list(req.points)
    request.respond()
    return 0


def test_request_and_response_travel_flat(fake):
    provider = fake.get_service_provider("e", "pytest/echo")
    provider.set_handler(echo_handler)
    provider.do_register()
    svc = fake.get_service("e", "pytest/echo")
    svc.call(counter=1, vec=[0, 0, 0.5], values=[1, 2], text="hi", origin={"x": 1.0}, points=[{"x": 2.0, "y": 3.0}])
    r = svc.resp
    assert (r.counter, r.sum, list(r.values), r.text) == (2, 3.5, [2.0, 4.0], "hi!")
    assert [(p.x, p.y) for p in r.points] == [(1.0, 0.0), (2.0, 3.0)]
    assert r.values_len == 2 and r.points_len == 2
    assert svc.definition["defines"]["point_t"] == [["double", "x", 1], ["double", "y", 1]]


def test_handler_errors(fake, caplog):
    def handler(request, req, resp):
        if req.seq == 1:
            raise KeyError("boom")
        return 5

    provider = fake.get_service_provider("s", "pytest/small_srv")
    provider.set_handler(handler)
    provider.do_register()
    svc = fake.get_service("s", "pytest/small_srv")
    with pytest.raises(ln.LNError, match="boom") as info:
        svc.call(seq=1)
    assert info.value.code == ln.LNE_SVC_HANDLER_EXC
    assert "boom" in caplog.text  # logged, not printed
    with pytest.raises(ln.LNError) as info:
        svc.call(seq=2)
    assert info.value.user_code == 5


def test_register_needs_a_handler(fake):
    with pytest.raises(ln.LNError, match="set_handler"):
        fake.get_service_provider("x", "pytest/small_srv").do_register()


def test_wrapped_api_names_values_and_errors(fake):
    AreaProvider(fake, "area")
    assert set(PROVIDERS) == {"area.compute_circle_area", "area.triangle"}
    calls = AreaCalls(fake, "area")
    result = calls.compute_circle_area(1.0)
    assert result == {"area": math.pi, "error_code": 0}
    with pytest.raises(ln.ServiceErrorResponse) as info:
        calls.compute_circle_area(radius=-2.0)
    assert str(info.value).startswith("error_message: negative radius\n")
    assert info.value.response["error_code"] == 1
    with pytest.raises(ln.ServiceErrorResponse, match="ValueError: no triangles"):
        calls.triangle(1.0)
    with pytest.raises(TypeError):
        calls.compute_circle_area(1.0, 2.0)


def test_single_field_and_ln_string_shapes(fake):
    class Echo(ln.service_provider):
        def __init__(self, clnt):
            ln.service_provider.__init__(self, clnt)
            self.wrap_service_provider("echo", "pytest/echo")

        def echo(self, counter, vec, values, text, origin, points):
            assert isinstance(origin, dict) and isinstance(points, list)
            return {"counter": counter, "sum": float(sum(values)), "values": values, "text": text, "points": [origin]}

    Echo(fake)

    class Caller(ln.services_wrapper):
        def __init__(self, clnt):
            ln.services_wrapper.__init__(self, clnt)
            self.wrap_service("echo", "pytest/echo", default_arguments={"vec": [0, 0, 0], "points": []})

    out = Caller(fake).echo(counter=3, values=[1.5], text="t", origin={"x": 4.0, "y": 5.0})
    assert out["counter"] == 3 and out["text"] == "t" and out["points"] == [{"x": 4.0, "y": 5.0}]
    assert "values_len" not in out
