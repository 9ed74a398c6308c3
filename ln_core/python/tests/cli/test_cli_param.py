"""ln param list | get | set | reset against a live parameter block."""

import threading
import time
import uuid

import links_and_nodes as ln
import numpy as np
import pytest
from cli_helpers import ok, ok_json, one_line_error, run_ln, table


@pytest.fixture(scope="module")
def manager(builtins_manager):
    return builtins_manager  # ln/parameters/* from the source tree


@pytest.fixture(scope="module")
def live(manager):
    """Block "cli<unique>" of client "cli_params", updated every millisecond."""
    group = "cli" + uuid.uuid4().hex[:8]
    clnt = ln.client("cli_params")
    block = clnt.parameter_block(group)
    block.add("gain", 1.5, description="the gain")
    block.add("vec", [1.0, 2.0, 3.0])
    block.add("mat", np.eye(2, dtype=np.int16))
    block.add("limit", 5, dtype="int8", before_update=lambda v: v < 100)
    block.register()
    stop = threading.Event()

    def loop():
        while not stop.is_set():
            block.update()
            time.sleep(0.001)

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    yield group, block
    stop.set()
    thread.join(5)
    clnt.close()


def test_list_and_get(manager, live):
    group, _ = live
    rows = table(ok(run_ln(manager, "param", "list", group)))
    assert rows[0] == ["PARAMETER", "VALUE", "OVERRIDE", "PROVIDER", "DESCRIPTION"]
    assert [group + ".gain", "1.5", "-", "cli_params", "the gain"] in rows
    assert [group + ".mat", "[[1, 0], [0, 1]]", "-", "cli_params", "-"] in rows
    listed = {row["name"]: row for row in ok_json(run_ln(manager, "param", "list", "--json"))}
    assert listed[group + ".vec"]["value"] == [1.0, 2.0, 3.0]
    info = ok_json(run_ln(manager, "param", "get", group + ".limit", "--json"))
    assert (info["value"], info["override_enabled"], info["provider"]) == (5, False, "cli_params")
    fields = dict(row[:2] for row in table(ok(run_ln(manager, "param", "get", group + ".gain"))))
    assert fields["value"] == "1.5" and fields["description"] == "the gain"
    assert "no parameters below" in ok(run_ln(manager, "param", "list", "nothing" + group))


def test_set_and_reset(manager, live):
    group, block = live
    ok(run_ln(manager, "param", "set", group + ".gain", "2.5"))
    assert block.gain.output == 2.5  # waited for the provider's update
    ok(run_ln(manager, "param", "set", group + ".mat", "[[0, 1], [1, 0]]"))
    assert block.mat.output.tolist() == [[0, 1], [1, 0]]
    info = ok_json(run_ln(manager, "param", "get", group + ".gain", "--json"))
    assert (info["value"], info["input"], info["override_enabled"]) == (2.5, 1.5, True)
    assert "yes (input 1.5)" in ok(run_ln(manager, "param", "list", group))
    ok(run_ln(manager, "param", "reset", group + ".gain"))
    assert block.gain.output == 1.5


def test_errors_are_one_line(manager, live):
    group, _ = live
    one_line_error(run_ln(manager, "param", "get", group + ".nothere"), "unknown parameter", "ln param list")
    one_line_error(run_ln(manager, "param", "set", group + ".limit", "300"), "300 does not fit int8")
    one_line_error(run_ln(manager, "param", "set", group + ".limit", "110"), "refused")
    one_line_error(run_ln(manager, "param", "set", group + ".vec", "[1, 2]"), "takes 3 values")
    one_line_error(run_ln(manager, "param", "set", group + ".gain", "abc"), "not a number")
    one_line_error(run_ln(manager, "param", "set", group + ".gain", " "), "no value")


def test_completion_of_parameter_names(manager, live):
    group, _ = live
    words = ok(run_ln(manager, "__complete", "ln param set %s.g" % group)).split()
    assert words == [group + ".gain"]
    assert ok(run_ln(manager, "__complete", "ln param ")).split() == ["get", "list", "reset", "set"]
