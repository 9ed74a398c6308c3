"""Topics through ln_core's manager and libln."""

import copy
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
from conftest import handshake


def pair(clnt, md, unique, **sub_kwargs):
    topic = "pytest.%s.%s" % (md.replace("/", "_"), unique)
    pub = clnt.publish(topic, md)
    sub = clnt.subscribe(topic, md, **sub_kwargs)
    handshake(pub, sub)
    return pub, sub


def test_client_basics(clnt, manager):
    assert clnt.name.startswith("pytest")
    assert clnt.ping(2.0) >= 0
    other = ln.client("pytest_argv", ["prog", "--ln-manager", manager.address, "rest"])
    assert other.get_remaining_args() == ["prog", "rest"]
    other.close()
    with pytest.raises(ln.LNError) as info:
        other.publish("x.y", "counter/count_message")
    assert info.value.code == ln.LNE_CLIENT_NOT_INITIALIZED


def test_no_manager_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("LN_MANAGER", raising=False)
    with pytest.raises(ln.LNError) as info:
        ln.client("nobody")
    assert info.value.code == ln.LNE_NO_MANAGER_ADDRESS
    with pytest.raises(ln.LNError):
        ln.client("nobody", "127.0.0.1:1")
    with pytest.raises(TypeError):
        ln.client("nobody", 5)


def test_publish_subscribe_round_trip(clnt, unique):
    pub, sub = pair(clnt, "counter/count_message", unique)
    assert pub.has_subscriber()
    assert sub.has_publisher()
    assert (sub.topic_name, sub.msg_def_name) == (pub.topic_name, "counter/count_message")
    assert sub.msg_def_hash == pub.msg_def_hash and len(pub.msg_def_hash) == 64
    pub.packet.time = 12.5
    pub.packet.num_counts = 42
    pub.write(timestamp=1234.5)
    packet = sub.read(2.0)
    assert packet is sub.packet
    assert (packet.time, packet.num_counts) == (12.5, 42)
    assert sub.timestamp == 1234.5
    assert sub.read(False) is None
    assert sub.read(0.05) is None
    pub.write()
    assert sub.read(True).num_counts == 42
    assert abs(sub.timestamp - time.time()) < 5
    sequence, lost, _ = sub.sample_info
    assert sequence > 0 and lost == 0


def test_all_types_and_arrays_travel(clnt, unique):
    pub, sub = pair(clnt, "pytest/all_types", unique, buffers=4)
    p = pub.packet
    p.vec = [1.0, 2.0, 3.0]
    p.name = "ln_core"
    p.corners[1].x = 7.0
    p.u64 = 2**64 - 1
    pub.write()
    got = sub.read(2.0)
    assert list(got.vec) == [1.0, 2.0, 3.0]
    assert got.name == "ln_core" and got.corners[1].x == 7.0 and got.u64 == 2**64 - 1


def test_buffers_keep_packets_in_order(clnt, unique):
    pub, sub = pair(clnt, "counter/count_message", unique, buffers=8)
    for i in range(5):
        pub.packet.num_counts = i
        pub.write()
    assert [sub.read(1.0).num_counts for _ in range(5)] == list(range(5))


def test_subscribe_without_md_name_asks_the_manager(clnt, unique):
    topic = "pytest.auto.%s" % unique
    clnt.publish(topic, "counter/count_message")
    sub = clnt.subscribe(topic)
    assert sub.msg_def_name == "counter/count_message"
    assert clnt.get_message_definition_for_topic(topic)[0] == "counter/count_message"


def test_refusals(clnt, unique):
    topic = "pytest.refuse.%s" % unique
    clnt.publish(topic, "counter/count_message")
    with pytest.raises(ln.LNError):
        clnt.subscribe(topic, "pytest/p64")
    with pytest.raises(ln.LNError, match="dynamic"):
        clnt.publish("pytest.dyn.%s" % unique, "pytest/dyn_topic")
    with pytest.raises(ln.LNError):
        clnt.publish("pytest.nomd.%s" % unique, "pytest/does_not_exist")
    with pytest.raises(TypeError):
        clnt.subscribe(topic, 5)


def blocked_reader(sub):
    """A thread that is asleep in sub.read(True) (waited for), and the list of
    the LNErrors that end its read."""
    errors = []

    def reader():
        try:
            sub.read(True)
        except ln.LNError as error:
            errors.append(error)

    thread = threading.Thread(target=reader)
    thread.start()
    ln_testing.wait_asleep(thread.native_id, 10, "the reader blocked in read(True)")
    return thread, errors


def test_unblock_ends_a_blocking_read(clnt, unique):
    sub = clnt.subscribe("pytest.unblock.%s" % unique, "counter/count_message")
    thread, errors = blocked_reader(sub)
    sub.unblock()
    thread.join(5)
    assert not thread.is_alive()
    assert errors and errors[0].code == ln.LNE_PORT_UNBLOCKED


def test_multi_waiter(clnt, unique):
    pub_a, sub_a = pair(clnt, "counter/count_message", unique + "a")
    pub_b, sub_b = pair(clnt, "counter/count_message", unique + "b")
    waiter = clnt.get_multi_waiter()
    waiter.add_port(sub_a)
    waiter.add_port(sub_b)
    assert waiter.wait(0.05) is False
    pub_b.write()
    assert waiter.wait(2.0) is True
    assert waiter.can_read(sub_b) and not waiter.can_read(sub_a)
    assert sub_b.read(False) is not None
    waiter.remove_port(sub_a)


def test_unpublish_and_unsubscribe(clnt, unique):
    pub, sub = pair(clnt, "counter/count_message", unique)
    clnt.unsubscribe(sub)
    clnt.unpublish(pub)
    with pytest.raises(ln.LNError):
        pub.write()
    with pytest.raises(ln.LNError):
        sub.read(False)


def test_borrow_is_zero_copy_and_read_only(clnt, unique):
    pub, sub = pair(clnt, "pytest/p1m", unique)
    pub.packet.seq = 5
    pub.packet.pad[:] = 7
    pub.write()
    with sub.borrow(2.0) as pkt:
        assert pkt.seq == 5
        pad = pkt.pad
        assert pad.shape == (1048572,) and pad[123] == 7
        assert not pad.flags.writeable
        assert pad.base is not None  # a view, not a copy
        with pytest.raises(ValueError):
            pad[0] = 1
        with pytest.raises(ln.LNError):
            sub.borrow(False)
    # the array outlives the block: the loan ends only when it is gone
    assert pad[0] == 7
    del pad
    pub.write()
    with sub.borrow(2.0) as pkt:
        assert pkt is not None
    with sub.borrow(False) as pkt:
        assert pkt is None


def test_a_borrowed_packet_compares_and_copies_like_a_read_one(clnt, unique):
    pub, sub = pair(clnt, "counter/count_message", unique)
    pub.packet.num_counts = 41
    pub.write()
    read = sub.read(2.0)
    pub.write()
    with sub.borrow(2.0) as pkt:
        assert pkt == read and read == pkt
        kept = copy.copy(pkt)
    assert kept == read and kept.num_counts == 41  # the copy outlives the loan


def test_read_into_numpy_has_no_extra_copy(clnt, unique):
    pub, sub = pair(clnt, "pytest/p1m", unique)
    pad = sub.packet.pad
    pub.packet.pad[:] = 3
    pub.write()
    sub.read(2.0)
    assert sub.packet.pad is pad and pad[1000] == 3
    assert np.shares_memory(pad, np.frombuffer(sub.packet._buf, np.uint8))


SIGINT_SCRIPT = textwrap.dedent("""
    import sys, links_and_nodes as ln
    c = ln.client("sigint")
    port = c.subscribe("pytest.sigint." + sys.argv[1], "counter/count_message")
    print("reading", flush=True)
    try:
        port.read(True)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
""")


def test_ctrl_c_interrupts_a_blocking_read(manager, tmp_path, unique):
    script = tmp_path / "sigint.py"
    script.write_text(SIGINT_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), unique], env=manager.env(), stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "reading"
        ln_testing.wait_asleep(proc.pid, 10, "the program blocked in read(True)", pid=proc.pid)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "interrupted" in out and proc.returncode == 0


def test_publisher_availability_handler(clnt, unique):
    topic = "pytest.avail.%s" % unique
    seen = []
    event = threading.Event()

    def handler(name, available):
        seen.append((name, available))
        if available:
            event.set()

    clnt.set_publisher_availability_handler(topic, handler)
    other = ln.client("pytest_avail_pub")
    other.publish(topic, "counter/count_message")
    assert event.wait(5)
    assert (topic, True) in seen
    clnt.set_publisher_availability_handler(topic, None)
    other.close()


def test_environment_names_the_client(manager):
    out = subprocess.run(
        [sys.executable, "-c", "import links_and_nodes as ln; print(ln.client('x').name)"],
        env=manager.env(LN_PROGRAM_NAME="renamed_by_env"),
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.stdout.strip().startswith("renamed_by_env"), out.stderr


def test_close_ends_reads_blocked_in_other_threads(manager, unique):
    c = ln.client("pytest_close")
    thread, errors = blocked_reader(c.subscribe("pytest.close.%s" % unique, "counter/count_message"))
    c.close()
    thread.join(10)
    assert not thread.is_alive()
    assert errors and errors[0].code in (ln.LNE_PORT_UNBLOCKED, ln.LNE_CLIENT_NOT_INITIALIZED)
    c.close()  # twice is fine


def test_borrowed_views_block_unsubscribe_and_close_until_dropped(manager, unique):
    c = ln.client("pytest_loans")
    pub = c.publish("pytest.loans.%s" % unique, "pytest/p64")
    sub = c.subscribe("pytest.loans.%s" % unique, "pytest/p64")
    handshake(pub, sub)
    pub.write()
    with sub.borrow(2.0) as pkt:
        view = pkt.pad
    with pytest.raises(ln.LNError, match="still in use"):
        c.unsubscribe(sub)
    with pytest.raises(ln.LNError, match="still in use"):
        c.close()
    assert view.sum() == 0  # still readable: the loan lives on
    del view
    c.unsubscribe(sub)
    c.close()
