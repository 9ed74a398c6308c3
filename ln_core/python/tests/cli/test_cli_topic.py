"""ln topic list | info | echo | hz | bw | pub against a live manager."""

import signal
import subprocess
import sys
import time
import types
import uuid

import links_and_nodes as ln
import pytest
from cli_helpers import Publisher, json_lines, no_manager_env, ok, ok_json, one_line_error, run_ln, table, wait_until  # noqa: F401

COUNTER_RATE = 50


def fill_counter(packet, i):
    packet.time = i * 0.02
    packet.num_counts = i


def fill_all_types(packet, i):
    packet.u32 = i
    packet.f = 0.1
    packet.vec = [i, 2.5, -1]
    packet.name = "n%d" % (i % 1000)
    packet.origin.y = -0.5
    packet.corners[1].x = 7


@pytest.fixture(scope="module")
def live(manager):
    unique = uuid.uuid4().hex[:8]
    system = types.SimpleNamespace(counter="cli.counter." + unique, all="cli.all." + unique, unique=unique)
    system.counter_pub = Publisher(
        "cli_pub_counter", system.counter, "counter/count_message", COUNTER_RATE, fill_counter
    )
    system.all_pub = Publisher("cli_pub_all", system.all, "pytest/all_types", 20, fill_all_types)
    system.listener = ln.client("cli_listener")
    system.listener_port = system.listener.subscribe(system.counter, "counter/count_message")
    yield system
    system.listener.close()
    system.counter_pub.stop()
    system.all_pub.stop()


def topic_rows(manager):
    return {row["name"]: row for row in ok_json(run_ln(manager, "topic", "list", "--json"))}


# ------------------------------------------------------------------- list/info


def test_list_shows_definition_publisher_subscribers_and_rate(manager, live):
    # the publisher reports its packet count about once a second
    row = wait_until(
        lambda: (topic_rows(manager).get(live.counter) or {}).get("rate") and topic_rows(manager)[live.counter],
        timeout=15,
        what="a rate in 'ln topic list'",
    )
    assert row["message_definition"] == "counter/count_message"
    assert row["publisher"] == live.counter_pub.client.name
    assert row["subscribers"] == 1
    assert row["message_size"] == 12 and len(row["hash"]) == 64
    assert 0.4 * COUNTER_RATE < row["rate"] < 1.6 * COUNTER_RATE
    assert row["packets"] > 0

    rows = table(ok(run_ln(manager, "topic", "list")))
    assert rows[0] == ["TOPIC", "DEFINITION", "PUBLISHER", "SUBS", "RATE"]
    counter = next(r for r in rows if r[0] == live.counter)
    assert counter[1:4] == ["counter/count_message", live.counter_pub.client.name, "1"]
    assert counter[4].endswith(" Hz")
    assert any(r[0] == live.all and r[1] == "pytest/all_types" for r in rows)


def test_output_has_colour_only_when_asked(manager, live):
    assert "\033[" not in ok(run_ln(manager, "topic", "list"))  # not a terminal
    assert "\033[1m" in ok(run_ln(manager, "topic", "list", "--color", "always"))
    assert "\033[" not in ok(run_ln(manager, "--color=always", "topic", "list", "--color", "never"))


def test_info(manager, live):
    info = ok_json(run_ln(manager, "topic", "info", live.counter, "--json"))
    assert info["name"] == live.counter and info["message_definition"] == "counter/count_message"
    assert info["publisher"] == live.counter_pub.client.name
    assert info["subscribers"] == 1 and info["subscriber_names"] == ["cli_listener"]
    text = ok(run_ln(manager, "topic", "info", live.counter))
    assert "definition   counter/count_message" in text
    assert "subscribers  1: cli_listener" in text
    assert "size         12 bytes" in text


def test_info_of_an_unknown_topic(manager, live):
    one_line_error(run_ln(manager, "topic", "info", "no.such.topic"), "unknown topic 'no.such.topic'", "ln topic list")


# ------------------------------------------------------------------------ echo


def test_echo_once_prints_the_fields(manager, live):
    text = ok(run_ln(manager, "topic", "echo", live.all, "--once"))
    lines = text.splitlines()
    assert lines[-1] == "---"
    assert "f: 0.1" in lines  # a float32 shows as typed, not as 0.10000000149
    assert 'name: "n' in text
    assert "vec: [" in text and ", 2.5, -1.0]" in text
    assert "origin:\n  x: 0.0\n  y: -0.5" in text
    assert "corners:\n  - x: 0.0\n    y: 0.0\n  - x: 7.0\n    y: 0.0" in text


def test_echo_count_json_gives_consecutive_messages(manager, live):
    messages = json_lines(run_ln(manager, "topic", "echo", live.counter, "--count", "3", "--json", "--buffers", "16"))
    assert len(messages) == 3
    counts = [m["num_counts"] for m in messages]
    assert counts == sorted(counts) and len(set(counts)) == 3
    assert all(m["time"] == pytest.approx(m["num_counts"] * 0.02) for m in messages)


def test_echo_field(manager, live):
    assert ok(run_ln(manager, "topic", "echo", live.all, "--field", "vec[1]", "--count", "2")).split() == ["2.5"] * 2
    assert json_lines(run_ln(manager, "topic", "echo", live.all, "--field", "corners[1]", "--once", "--json")) == [
        {"x": 7.0, "y": 0.0}
    ]
    assert ok(run_ln(manager, "topic", "echo", live.all, "-f", "origin.y", "--once")).strip() == "-0.5"


def test_echo_csv(manager, live):
    lines = ok(run_ln(manager, "topic", "echo", live.all, "--csv", "--count", "2")).splitlines()
    assert len(lines) == 3
    header = lines[0].split(",")
    assert header[:2] == ["f", "d"] and "vec[2]" in header and "corners[1].x" in header
    for line in lines[1:]:
        row = dict(zip(header, line.split(",")))
        assert row["corners[1].x"] == "7.0" and row["vec[1]"] == "2.5" and row["f"] == "0.1"
    field = ok(run_ln(manager, "topic", "echo", live.all, "--csv", "--once", "--field", "origin")).splitlines()
    assert field == ["origin.x,origin.y", "0.0,-0.5"]


def test_echo_bad_input(manager, live):
    one_line_error(run_ln(manager, "topic", "echo", "no.such.topic", "--once"), "unknown topic")
    one_line_error(run_ln(manager, "topic", "echo", live.all, "--field", "nope", "--once"), "no field 'nope'")
    one_line_error(run_ln(manager, "topic", "echo", live.all, "--field", "vec[7]", "--once"), "out of range")
    one_line_error(run_ln(manager, "topic", "echo", live.all, "--field", "vec..x", "--once"), "field path")
    one_line_error(run_ln(manager, "topic", "echo", live.all, "--count", "0"), "--count")


def test_echo_times_out_without_messages(manager, live):
    silent = "cli.silent." + live.unique
    result = run_ln(manager, "topic", "echo", silent, "--type", "counter/count_message", "--once", "--timeout", "0.5")
    one_line_error(result, "no message on topic '%s'" % silent)


def start_ln(manager, *args):
    return subprocess.Popen(
        [sys.executable, "-m", "links_and_nodes.cli", *args],
        env=manager.env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_echo_ends_quietly_on_ctrl_c_and_on_a_closed_pipe(manager, live):
    process = start_ln(manager, "topic", "echo", live.counter, "--count", "10000")
    try:
        assert process.stdout.readline().startswith("time: ")
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=10)
    finally:
        process.kill()
    assert process.returncode == 130 and stderr == ""

    process = start_ln(manager, "topic", "echo", live.counter, "--count", "10000", "--json")
    try:
        assert process.stdout.readline().startswith("{")
        process.stdout.close()  # as `| head -1` does
        process.wait(timeout=10)
        stderr = process.stderr.read()
    finally:
        process.kill()
    assert process.returncode == 0 and stderr == ""


# ---------------------------------------------------------------------- hz/bw


def test_hz_measures_rate_and_jitter(manager, live):
    reports = json_lines(run_ln(manager, "topic", "hz", live.counter, "--duration", "2", "--json"))
    assert len(reports) == 1
    report = reports[0]
    assert 0.5 * COUNTER_RATE < report["rate"] < 1.5 * COUNTER_RATE
    assert report["window"] >= 10 and report["lost"] >= 0
    assert 0 <= report["jitter"] < report["max"] and report["min"] <= report["mean"] <= report["max"]
    assert report["mean"] == pytest.approx(1.0 / COUNTER_RATE, rel=0.5)

    text = ok(run_ln(manager, "topic", "hz", live.counter, "--count", "1", "--period", "1"))
    assert text.startswith("rate: ") and " Hz " in text and "jitter: " in text and "window: " in text


def test_hz_adds_up_the_losses_of_every_read():
    # sample_info.lost counts the packets skipped since the previous read;
    # taken for a running total, losses went missing and turned negative.
    from links_and_nodes.cli.topic import RateMeter

    meter = RateMeter(window=10)
    for now, sequence, lost in ((0.0, 3, 2), (0.1, 4, 0), (0.2, 7, 2), (0.3, 8, 0), (0.4, 9, 0)):
        meter.add(now, sequence, lost)
    report = meter.report()
    assert report["lost"] == 4 and report["received"] == 5
    assert report["rate"] == pytest.approx((9 - 3) / 0.4)


def test_bw_measures_bytes_per_second(manager, live):
    report = json_lines(run_ln(manager, "topic", "bw", live.all, "--duration", "1.5", "--json"))[0]
    assert report["message_size"] == 136
    assert report["bandwidth"] == pytest.approx(report["rate"] * 136)
    assert 8 < report["rate"] < 30
    text = ok(run_ln(manager, "topic", "bw", live.all, "--count", "1"))
    assert text.startswith("bandwidth: ") and "B/s" in text and "136 B messages" in text


def test_hz_without_messages_fails(manager, live):
    silent = "cli.silent_hz." + live.unique
    one_line_error(
        run_ln(manager, "topic", "hz", silent, "-t", "counter/count_message", "--duration", "0.5"), "no message"
    )


# ------------------------------------------------------------------------- pub


def test_pub_delivers_validated_values(manager, live):
    topic = "cli.pub." + live.unique
    clnt = ln.client("cli_pub_reader")
    try:
        port = clnt.subscribe(topic, "counter/count_message", buffers=8)
        process = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "links_and_nodes.cli",
                "topic",
                "pub",
                topic,
                "time: 1.5",
                "num_counts: 0x10",
                "--type",
                "counter/count_message",
                "--count",
                "5",
                "--rate",
                "20",
            ],
            env=manager.env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        received = []
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (process.poll() is None or port.read(False) is not None):
            packet = port.read(0.1)
            if packet is not None:
                received.append((packet.time, packet.num_counts))
        stdout, stderr = process.communicate(timeout=10)
    finally:
        clnt.close()
    assert process.returncode == 0, stderr
    assert stdout.splitlines() == [
        "publishing %s (counter/count_message) at 20 Hz, 5 messages" % topic,
        "published 5 messages",
    ]
    assert received and set(received) == {(1.5, 16)}


def test_pub_nested_values_json(manager, live):
    topic = "cli.pub_nested." + live.unique
    result = run_ln(
        manager,
        "topic",
        "pub",
        topic,
        "--type",
        "pytest/all_types",
        "--once",
        "--wait",
        "0",
        "--json",
        'name: "hi you", corners[1].x: 3, vec: [1, 2, 3e0], origin: {x: 1}, small[2]: -7, f: .5',
    )
    report = ok_json(result)
    assert report["published"] == 1 and report["topic"] == topic
    message = report["message"]
    assert message["name"] == "hi you" and message["vec"] == [1.0, 2.0, 3.0] and message["small"] == [0, 0, -7, 0]
    assert message["origin"] == {"x": 1.0, "y": 0.0} and message["corners"][1] == {"x": 3.0, "y": 0.0}
    assert message["f"] == 0.5


@pytest.mark.parametrize(
    "values, words",
    [
        ("num_counts: -1", ["num_counts", "out of range"]),
        ("time: abc", ["field 'time'", "expects a number, got 'abc'"]),
        ("bogus: 1", ["no field 'bogus'", "time, num_counts"]),
        ("time: [1", ["malformed", "missing ']'"]),
        ("time 1", ["malformed", "expected ':'"]),
        ("time: 1, time: 2", ["given twice"]),
    ],
)
def test_pub_rejects_bad_values_before_publishing(manager, live, values, words):
    topic = "cli.pub_bad." + live.unique
    one_line_error(run_ln(manager, "topic", "pub", topic, values, "-t", "counter/count_message", "--once"), *words)
    assert topic not in topic_rows(manager)


def test_pub_needs_a_definition_and_a_free_topic(manager, live):
    one_line_error(run_ln(manager, "topic", "pub", "cli.nowhere", "time: 1", "--once"), "--type")
    one_line_error(run_ln(manager, "topic", "pub", "cli.nowhere", "-t", "no/such_md", "--once"), "no/such_md")
    one_line_error(run_ln(manager, "topic", "pub", live.counter, "time: 1", "--once"), "already published")


# -------------------------------------------------------------- no manager


def test_no_manager_is_one_line(manager, no_manager_env):
    for args in (["topic", "list"], ["topic", "echo", "x", "--once"], ["topic", "hz", "x", "--duration", "1"]):
        one_line_error(run_ln(None, *args, env=no_manager_env), "cannot reach the ln_manager", "is it running")
    env = dict(no_manager_env)
    del env["LN_MANAGER"]
    one_line_error(run_ln(None, "topic", "list", env=env), "no ln_manager address", "LN_MANAGER")
    one_line_error(run_ln(None, "topic", "list", "--ln-manager", "nonsense", env=env), "invalid ln_manager address")
