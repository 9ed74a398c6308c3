"""Topic behaviour (ln_spec §4.5, §7.3): lnbt_probe, lnbt_publisher and
lnbt_subscriber compiled against LN 2.9 and against ln_core, each pair run
against its own system's manager; the observations must match (exactly where
the behaviour is deterministic, structurally where it depends on timing)."""

from __future__ import annotations

import contextlib
import itertools

import lnbt_support as support
import pytest

_topic_numbers = itertools.count(1)


def topic(stem: str) -> str:
    """A fresh topic name per use (the managers live for the whole session)."""
    return f"lnbt.{stem}.{next(_topic_numbers)}"


def probe(lnbt, system, *args, env=None):
    return support.run([system.programs["lnbt_probe"], *args], lnbt.client_env(system, **(env or {})))


def outcome(program) -> list[str]:
    """The probe's result lines (without the argument echo)."""
    return [line for line in program.lines if not line.startswith("args ")]


def counters(program) -> list[int]:
    return [int(line.split()[1]) for line in program.lines if line.startswith("counter ")]


def start_when_ready(system, env, subscriber, name, count, period) -> support.Program:
    """Starts lnbt_publisher for `subscriber` (which printed "subscribed"): it
    waits for has_subscriber(), then writes probe packets until the
    subscriber printed "ready" (it received one while has_publisher() was
    true: see lnbt_publisher.cpp for why has_subscriber() alone is not
    enough), then it is told to go and writes the counters 1..count."""
    publisher = support.Program(
        [system.programs["lnbt_publisher"], name, count, period, "--wait-subscriber", 10, "--probe", 10],
        env,
        stdin_pipe=True,
    )
    try:
        assert subscriber.wait_for_line("ready", 10) is not None, subscriber.describe() + publisher.describe()
        publisher.tell("go")
    except BaseException:
        publisher.kill()
        raise
    return publisher


def pub_sub(lnbt, system, name, sub_options, pub_count, pub_period, timeout=support.PROGRAM_TIMEOUT):
    """Starts the subscriber and, once it subscribed and is ready, the
    publisher (start_when_ready); waits for both. Returns both programs."""
    env = lnbt.client_env(system)
    subscriber = support.Program([system.programs["lnbt_subscriber"], name, *map(str, sub_options)], env)
    try:
        assert subscriber.wait_for_line("subscribed", 10) is not None, subscriber.describe()
        publisher = start_when_ready(system, env, subscriber, name, pub_count, pub_period)
        try:
            publisher.finish(timeout)
            subscriber.finish(timeout)
        finally:
            publisher.kill()
    finally:
        subscriber.kill()
    return publisher, subscriber


def received(subscriber) -> list[str]:
    """The subscriber's lines without timing and the probe handshake."""
    return [line for line in subscriber.lines if not line.startswith(("elapsed", "ready"))]


@contextlib.contextmanager
def publishing(lnbt, system, client_name, name):
    """An lnbt_probe client that publishes topic `name` (lnbt/counter) until the block ends."""
    holder = support.Program(
        [system.programs["lnbt_probe"], "publish", client_name, name, "lnbt/counter", "30"],
        lnbt.client_env(system),
        stdin_pipe=True,
    )
    try:
        assert holder.wait_for_line("ready", 10) is not None, holder.describe()
        yield holder
    finally:
        holder.finish(10)


# ------------------------------------------------------------------- errors


def test_second_publisher_is_refused(lnbt):
    results = {}
    for system in lnbt.systems():
        name = topic("twice")
        with publishing(lnbt, system, "lnbt_first", name):
            second = probe(lnbt, system, "publish", "lnbt_second", name, "lnbt/counter")
            other_md = probe(lnbt, system, "publish", "lnbt_third", name, "lnbt/other")
        assert "already published" in second.stderr, second.describe()
        results[system.label] = (outcome(second), outcome(other_md))
    assert results["ln29"] == (
        ["name lnbt_second", "error LNE_REQUEST_FAILED"],
        ["name lnbt_third", "error LNE_REQUEST_FAILED"],
    )
    assert results["ln_core"] == results["ln29"]


def test_definition_mismatch_and_unknown_definition(lnbt):
    results = {}
    for system in lnbt.systems():
        name = topic("mismatch")
        with publishing(lnbt, system, "lnbt_holder", name):
            mismatch = probe(lnbt, system, "subscribe", "lnbt_mismatch", name, "lnbt/other")
            matching = probe(lnbt, system, "subscribe", "lnbt_matching", name, "lnbt/counter")
        assert "you requested message_definition 'lnbt/other' but topic" in mismatch.stderr, mismatch.describe()
        unknown_sub = probe(lnbt, system, "subscribe", "lnbt_unknown_sub", topic("unknown"), "lnbt/does_not_exist")
        unknown_pub = probe(lnbt, system, "publish", "lnbt_unknown_pub", topic("unknown"), "lnbt/does_not_exist")
        for program in (unknown_sub, unknown_pub):
            assert "'lnbt/does_not_exist' not found in these di" in program.stderr, program.describe()
        results[system.label] = [outcome(p) for p in (mismatch, matching, unknown_sub, unknown_pub)]
    assert results["ln29"] == [
        ["name lnbt_mismatch", "error LNE_REQUEST_FAILED"],
        ["name lnbt_matching", "subscribed size 16"],
        ["name lnbt_unknown_sub", "error LNE_REQUEST_FAILED"],
        ["name lnbt_unknown_pub", "error LNE_REQUEST_FAILED"],
    ]
    assert results["ln_core"] == results["ln29"]


def test_write_sizes(lnbt):
    """A write larger than the topic's packet is refused with
    LNE_PACKET_TOO_LARGE; the exact size and a smaller one are accepted."""
    results = {}
    for system in lnbt.systems():
        results[system.label] = outcome(
            probe(lnbt, system, "write_sizes", "lnbt_sizes", topic("sizes"), "lnbt/counter")
        )
    assert results["ln29"] == ["name lnbt_sizes", "write =  OK", "write +1 LNE_PACKET_TOO_LARGE", "write -1 OK"]
    assert results["ln_core"] == results["ln29"]


def test_dynamic_field_topic_documented_difference(lnbt):
    """Deliberate difference (README P9): LN 2.9 accepts a topic definition
    with a dynamic field and sizes it without the pointed-to data (8 bytes for
    lnbt/dynamic: the count and a pointer, whose data is silently never sent);
    ln_core refuses it with LNE_INVALID_PARAMETER on publish and subscribe."""
    results = {}
    for system in lnbt.systems():
        pub = probe(lnbt, system, "publish", "lnbt_dyn_pub", topic("dynamic"), "lnbt/dynamic")
        sub = probe(lnbt, system, "subscribe", "lnbt_dyn_sub", topic("dynamic"), "lnbt/dynamic")
        results[system.label] = (outcome(pub), outcome(sub), sub.stderr)
    assert results["ln29"][:2] == (
        ["name lnbt_dyn_pub", "published size 8"],
        ["name lnbt_dyn_sub", "subscribed size 8"],
    )
    assert results["ln_core"][:2] == (
        ["name lnbt_dyn_pub", "error LNE_INVALID_PARAMETER"],
        ["name lnbt_dyn_sub", "error LNE_INVALID_PARAMETER"],
    )
    assert "dynamic field" in results["ln_core"][2]
    support.DIFFERENCES.append(
        "topic with a dynamic field: LN 2.9 publishes/subscribes it with message_size 8 "
        "(data dropped), ln_core refuses it with LNE_INVALID_PARAMETER"
    )


# ---------------------------------------------------------------- data flow


def test_same_output(lnbt):
    """Subscribe, then publish 50 counters at 100 Hz once the publisher sees
    the subscriber: both the publisher's and the subscriber's output are
    identical on both systems (timing lines aside)."""
    outputs = {}
    for system in lnbt.systems():
        publisher, subscriber = pub_sub(
            lnbt,
            system,
            topic("same"),
            ["--buffers", 64, "--count", 50],
            50,
            0.01,
        )
        assert publisher.returncode == 0 and subscriber.returncode == 0, publisher.describe() + subscriber.describe()
        outputs[system.label] = (publisher.lines, received(subscriber))
    ref = outputs["ln29"]
    assert ref[0] == ["publishing", "subscriber seen", "published 50"]
    assert ref[1][:2] == ["has_publisher_at_start 0", "subscribed"]
    assert ref[1][2:] == [f"counter {i} value {i * 0.5:.1f} check ok" for i in range(1, 51)] + ["received 50"]
    assert outputs["ln_core"] == ref


def test_buffers_1_slow_reader_sees_only_the_newest(lnbt):
    """buffers=1, a reader sleeping 0.1 s before each read of a 200 Hz
    stream: every read returns the newest packet, about 20 counters after the
    previous one (P8: a repeat is possible, so count steps, not reads)."""
    for system in lnbt.systems():
        publisher, subscriber = pub_sub(
            lnbt,
            system,
            topic("b1"),
            ["--buffers", 1, "--sleep", 0.1, "--duration", 1.0],
            300,
            0.005,
        )
        seen = counters(subscriber)
        assert len(seen) >= 6, f"{system}\n{subscriber.describe()}"
        steps = [b - a for a, b in zip(seen, seen[1:]) if b != a]
        assert all(step > 0 for step in steps), f"{system}: out of order {seen}"
        typical = sorted(steps)[len(steps) // 2]
        assert 12 <= typical <= 30, f"{system}: median step {typical} in {seen}"
        assert sum(1 for s in steps if s == 1) <= 1, f"{system}: consecutive reads in {seen}"


@pytest.mark.parametrize("buffers", [5, 1])
def test_buffers_after_a_stall(lnbt, buffers):
    """The reader takes 3 packets, stalls 0.3 s (about 60 packets written at
    200 Hz), then reads as fast as it can: with buffers=5 it gets the 5 newest
    buffered packets in order (consecutive counters) and then the live
    stream; with buffers=1 it gets only the newest."""
    shapes = {}
    for system in lnbt.systems():
        publisher, subscriber = pub_sub(
            lnbt,
            system,
            topic(f"stall{buffers}"),
            ["--buffers", buffers, "--stall-after", 3, "--stall", 0.3, "--count", 14],
            300,
            0.005,
        )
        seen = counters(subscriber)
        assert len(seen) == 14, f"{system}\n{subscriber.describe()}"
        assert seen[0] < seen[1] < seen[2], f"{system}: {seen}"
        jump = seen[3] - seen[2]
        assert jump >= 30, f"{system}: no jump after the stall: {seen}"
        after = seen[3:]
        steps = [b - a for a, b in zip(after, after[1:])]
        assert all(step >= 1 for step in steps), f"{system}: out of order or repeated: {seen}"
        # Shape: consecutive counters right after the stall (the buffered ones).
        run = 1
        while run < len(after) and after[run] == after[run - 1] + 1:
            run += 1
        shapes[system.label] = (run >= buffers, seen)
    assert shapes["ln29"][0], f"LN 2.9: {shapes['ln29'][1]}"
    assert shapes["ln_core"][0], f"ln_core: {shapes['ln_core'][1]}"


def test_rate_decimation(lnbt):
    """rate=10 on a 200 Hz publisher: about 10 packets per second, evenly
    spaced (about 20 counters apart)."""
    for system in lnbt.systems():
        publisher, subscriber = pub_sub(
            lnbt,
            system,
            topic("rate"),
            ["--rate", 10, "--buffers", 1, "--duration", 2.0],
            500,
            0.005,
        )
        seen = counters(subscriber)
        assert 15 <= len(seen) <= 26, f"{system}: {len(seen)} packets in 2 s at rate=10: {seen}"
        steps = [b - a for a, b in zip(seen, seen[1:])]
        assert min(steps) >= 15, f"{system}: packets closer than 1/rate: {seen}"


def run_alongside(first_argv, ready_line, second_argv, env):
    """Starts the first program, runs the second to its end once the first printed ready_line,
    then lets the first finish; returns both (support.Program, support.run result)."""
    first = support.Program(first_argv, env)
    try:
        assert first.wait_for_line(ready_line, 10) is not None, first.describe()
        second = support.run(second_argv, env)
        first.finish()
    finally:
        first.kill()
    return first, second


@pytest.mark.parametrize(
    "order,pub_buffers", [("subscriber_first", 1), ("publisher_first", 256), ("publisher_first", 1)]
)
def test_waiting_publisher_loses_nothing(lnbt, order, pub_buffers):
    """The publisher waits for has_subscriber() and then writes 200 packets
    back to back; the subscriber (256 buffers) gets every one, in order.
    LN 2.9 does too as long as its segment already has the subscriber's
    buffers; a publisher with 1 buffer and a later subscriber makes it
    re-create the segment, and the packets written meanwhile are lost (all of
    them here). ln_core loses none there either (documented difference)."""
    results = {}
    for system in lnbt.systems():
        name = topic(f"join.{order}.{pub_buffers}")
        env = lnbt.client_env(system)
        sub_argv = [
            system.programs["lnbt_subscriber"],
            name,
            "--buffers",
            "256",
            "--count",
            "200",
            "--first-timeout",
            "5",
            "--duration",
            "3",
        ]
        pub_argv = [
            system.programs["lnbt_publisher"],
            name,
            "200",
            "0",
            "--wait-subscriber",
            "5",
            "--buffers",
            str(pub_buffers),
            "--linger",
            "1",
        ]
        if order == "subscriber_first":
            subscriber, publisher = run_alongside(sub_argv, "subscribed", pub_argv, env)
        else:
            publisher, subscriber = run_alongside(pub_argv, "publishing", sub_argv, env)
        assert "subscriber seen" in publisher.lines, f"{system}\n{publisher.describe()}"
        results[system.label] = (counters(subscriber), subscriber)
    everything = list(range(1, 201))
    assert results["ln_core"][0] == everything, results["ln_core"][1].describe()
    if order == "publisher_first" and pub_buffers == 1:
        if results["ln29"][0] != everything:
            support.DIFFERENCES.append(
                f"publisher (1 buffer) waits for has_subscriber, then writes 200: a later subscriber with 256 "
                f"buffers gets {len(results['ln29'][0])} of them from LN 2.9, all from ln_core"
            )
    else:
        assert results["ln29"][0] == everything, results["ln29"][1].describe()


def test_subscribe_before_publish_and_has_publisher(lnbt):
    """A subscription made before the topic exists gets the data once a
    publisher appears (has_publisher false at first); after the publisher
    exits, has_publisher() turns false."""
    outputs = {}
    for system in lnbt.systems():
        publisher, subscriber = pub_sub(
            lnbt,
            system,
            topic("early"),
            ["--buffers", 64, "--count", 20, "--watch-publisher", 5],
            20,
            0.01,
        )
        outputs[system.label] = received(subscriber)
    ref = outputs["ln29"]
    assert ref[:2] == ["has_publisher_at_start 0", "subscribed"]
    assert ref[-3:] == ["received 20", "has_publisher_before_watch 1", "publisher_gone"], ref
    assert outputs["ln_core"] == ref


def test_no_latched_value_for_a_late_subscriber(lnbt):
    """A subscriber that comes after the packets were written gets nothing
    (no last-value delivery)."""
    results = {}
    for system in lnbt.systems():
        env = lnbt.client_env(system)
        name = topic("late")
        publisher = support.Program([system.programs["lnbt_publisher"], name, "5", "0.01", "--linger", "3"], env)
        try:
            assert publisher.wait_for_line("published 5", 10) is not None, publisher.describe()
            subscriber = support.run(
                [system.programs["lnbt_subscriber"], name, "--buffers", "8", "--first-timeout", "0.6"], env
            )
        finally:
            publisher.kill()
        results[system.label] = [l for l in subscriber.lines if not l.startswith("elapsed")]
    assert results["ln29"] == ["has_publisher_at_start 1", "subscribed", "received 0"]
    assert results["ln_core"] == results["ln29"]


def test_has_publisher_after_publisher_is_killed(lnbt):
    """The publisher dies (SIGKILL) while publishing: the subscriber's
    has_publisher() turns false (the manager notices the lost connection)."""
    outputs = {}
    for system in lnbt.systems():
        env = lnbt.client_env(system)
        name = topic("killed")
        subscriber = support.Program(
            [system.programs["lnbt_subscriber"], name, "--buffers", "8", "--count", "5", "--watch-publisher", "5"], env
        )
        publisher = None
        try:
            assert subscriber.wait_for_line("subscribed", 10) is not None, subscriber.describe()
            publisher = start_when_ready(system, env, subscriber, name, 100000, 0.01)
            assert subscriber.wait_for_line("has_publisher_before_watch", 15) is not None, subscriber.describe()
            publisher.kill()
            subscriber.finish(15)
        finally:
            subscriber.kill()
            if publisher:
                publisher.kill()
        outputs[system.label] = [l for l in received(subscriber) if not l.startswith("counter")]
    assert outputs["ln29"] == [
        "has_publisher_at_start 0",
        "subscribed",
        "received 5",
        "has_publisher_before_watch 1",
        "publisher_gone",
    ]
    assert outputs["ln_core"] == outputs["ln29"]
