"""ln service list | info | call against live providers."""

import math
import threading
import types
import uuid

import pytest
from cli_helpers import Providers, no_manager_env, ok, ok_json, one_line_error, run_ln, table  # noqa: F401


def circle_area(request, req, resp):
    if req.radius < 0:
        resp.area, resp.error_code, resp.error_message = 0.0, 1, "negative radius %g" % req.radius
    else:
        resp.area, resp.error_code, resp.error_message = math.pi * req.radius**2, 0, ""
    request.respond()
    return 0


def echo(request, req, resp):
    if req.counter == 99:
        request.respond_error(7, "counter 99 is not allowed")
        return 0
    resp.counter = req.counter + 1
    resp.sum = float(sum(req.vec)) + req.origin.x
    resp.values = req.values * 2
    resp.text = "echo: " + req.text
    resp.points = [{"x": p.y, "y": p.x} for p in req.points]
    request.respond()
    return 0


@pytest.fixture(scope="module")
def live(manager):
    unique = uuid.uuid4().hex[:8]
    system = types.SimpleNamespace(area="cli.area." + unique, echo="cli.echo." + unique, slow="cli.slow." + unique)
    # a provider that never answers, in a client of its own
    system.release = threading.Event()

    def never_answers(request, req, resp):
        system.release.wait(10)
        return 0

    with (
        Providers.serving(
            "cli_provider", (system.area, "area_service/circle_area", circle_area), (system.echo, "pytest/echo", echo)
        ) as system.providers,
        Providers.serving("cli_slow_provider", (system.slow, "pytest/sleep", never_answers)) as system.slow_provider,
    ):
        yield system
        system.release.set()


def test_list(manager, live):
    rows = {row["name"]: row for row in ok_json(run_ln(manager, "service", "list", "--json"))}
    area = rows[live.area]
    assert area["interface"].split("|")[0] == "area_service/circle_area"
    assert area["provider"] == live.providers.client.name and area["group"] == ""
    assert area["signature"] == "double 8 1|double 8 1,int32_t 4 1,uint32_t 4 1,char* 1 1"
    assert rows[live.echo]["interface"].split("|")[0] == "pytest/echo"

    lines = table(ok(run_ln(manager, "service", "list")))
    assert lines[0] == ["SERVICE", "INTERFACE", "PROVIDER", "GROUP"]
    row = next(r for r in lines if r[0] == live.area)
    assert row[1].startswith("area_service/circle_area") and row[2:] == [live.providers.client.name, "-"]


def test_info(manager, live):
    info = ok_json(run_ln(manager, "service", "info", live.echo, "--json"))
    assert info["provider"] == live.providers.client.name
    assert info["request"] == [
        "uint32_t counter",
        "double vec[3]",
        "double* values",
        "char* text",
        "point_t origin",
        "point_t* points",
    ]
    assert info["response"][:2] == ["uint32_t counter", "double sum"]
    text = ok(run_ln(manager, "service", "info", live.area))
    assert "interface  area_service/circle_area" in text
    assert "request:\n  double radius\nresponse:\n  double area\n  int32_t error_code\n  char* error_message" in text
    one_line_error(run_ln(manager, "service", "info", "cli.no_such_service"), "unknown service", "ln service list")


def test_call_prints_the_response(manager, live):
    text = ok(run_ln(manager, "service", "call", live.area, "radius: 2"))
    assert text.splitlines() == ["area: %.15g" % (math.pi * 4), "error_code: 0", 'error_message: ""']
    response = ok_json(run_ln(manager, "service", "call", live.area, "{radius: 0.5}", "--json"))
    assert response == {"area": pytest.approx(math.pi / 4), "error_code": 0, "error_message": ""}


def test_call_with_dynamic_and_nested_fields(manager, live):
    response = ok_json(
        run_ln(
            manager,
            "service",
            "call",
            live.echo,
            "--json",
            'counter: 41, vec: [1, 2, 3], values: [0.5, 1.5], text: "hi there"',
            "origin: {x: 10}",
            "points: [{x: 1, y: 2}, {x: 3}]",
        )
    )
    assert response == {
        "counter": 42,
        "sum": 16.0,
        "values": [1.0, 3.0],
        "text": "echo: hi there",
        "points": [{"x": 2.0, "y": 1.0}, {"x": 0.0, "y": 3.0}],
    }
    text = ok(run_ln(manager, "service", "call", live.echo, "counter: 1", "values: [1, 2, 3]"))
    assert "counter: 2\n" in text and "values: [2.0, 4.0, 6.0]\n" in text and 'text: "echo: "' in text
    assert "points: []" in text


def test_call_failures_are_one_line(manager, live):
    one_line_error(
        run_ln(manager, "service", "call", live.echo, "counter: 99"),
        "service '%s' failed" % live.echo,
        "error 7",
        "counter 99 is not allowed",
    )
    one_line_error(
        run_ln(manager, "service", "call", "cli.no_such_service"), "no provider for service", "ln service list"
    )
    one_line_error(run_ln(manager, "service", "call", live.echo, "counter: x"), "field 'counter'", "expects a number")
    one_line_error(run_ln(manager, "service", "call", live.echo, "points: [1, 2]"), "points[0]", "{x: ..., y: ...}")
    one_line_error(run_ln(manager, "service", "call", live.echo, "vec: [1, 2]"), "expects 3 values, got 2")
    one_line_error(run_ln(manager, "service", "call", live.echo, "counter: {"), "malformed")
    one_line_error(run_ln(manager, "service", "call", live.area, "diameter: 3"), "no field 'diameter'", "radius")


def test_call_response_with_error_message_fails(manager, live):
    result = run_ln(manager, "service", "call", live.area, "radius: -1")
    one_line_error(result, "error_message", "negative radius -1")
    assert 'error_message: "negative radius -1"' in result.stdout  # the response is still shown


def test_call_timeout(manager, live):
    result = run_ln(manager, "service", "call", live.slow, "seconds: 5", "--timeout", "0.5")
    one_line_error(result, "did not answer within 0.5 s")


def test_no_manager(manager, no_manager_env):
    for args in (["service", "list"], ["service", "call", "x", "a: 1"], ["service", "info", "x"]):
        one_line_error(run_ln(None, *args, env=no_manager_env), "cannot reach the ln_manager")
