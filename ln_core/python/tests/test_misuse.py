"""Misuse raises Python exceptions; it never crashes the interpreter."""

import gc
import threading
import time

import links_and_nodes as ln
import numpy as np
import pytest
from conftest import handshake
from links_and_nodes import _ln


def test_native_layer_checks_its_arguments(clnt, unique):
    port = _ln.InPort(clnt._native, "misuse.%s" % unique, "counter/count_message", -1.0, 1, False)
    with pytest.raises(TypeError):
        port.read("not a buffer", 0.0)
    with pytest.raises(TypeError):
        port.read(b"read-only bytes!", 0.0)
    with pytest.raises(ValueError):
        port.read(bytearray(3), 0.0)
    out = _ln.OutPort(clnt._native, "misuse.out.%s" % unique, "counter/count_message", 1)
    with pytest.raises(ValueError):
        out.write(bytearray(2))
    with pytest.raises(TypeError):
        out.write(12)


def test_bad_read_arguments(clnt, unique):
    sub = clnt.subscribe("misuse.read.%s" % unique, "counter/count_message")
    with pytest.raises(TypeError, match="blocking_or_timeout"):
        sub.read("soon")
    with pytest.raises(TypeError, match="blocking_or_timeout"):
        sub.borrow([1.0])
    assert sub.read(-5) is None  # <= 0: poll
    assert sub.read(0) is None
    assert sub.read(np.float32(0.01)) is None  # anything float() takes


def test_loans_after_release(clnt, unique):
    pub = clnt.publish("misuse.loan.%s" % unique, "pytest/p64")
    sub = clnt.subscribe("misuse.loan.%s" % unique, "pytest/p64")
    handshake(pub, sub)
    pub.write()
    borrowed = sub.borrow(2.0)
    loan = borrowed._loan
    borrowed.release()
    borrowed.release()
    with pytest.raises(BufferError):
        memoryview(loan)
    pub.write()
    with sub.borrow(2.0) as pkt:  # the port lends again once released
        assert pkt is not None


def test_objects_outliving_their_client(manager, unique):
    c = ln.client("misuse_gc")
    sub = c.subscribe("misuse.gc.%s" % unique, "counter/count_message")
    waiter = c.get_multi_waiter()
    waiter.add_port(sub)
    c.close()
    del c
    gc.collect()
    with pytest.raises(ln.LNError):
        sub.read(False)
    with pytest.raises(ln.LNError):
        waiter.wait(0)
    with pytest.raises(ln.LNError):
        sub.has_publisher()


def test_wrong_definition_kinds(clnt, unique):
    with pytest.raises(ln.LNError, match="service"):
        clnt.publish("misuse.kind.%s" % unique, "pytest/small_srv")
    with pytest.raises(ln.LNError):
        clnt.subscribe("misuse.unknown.%s" % unique)  # no md and no such topic


def test_threads_reading_in_parallel(clnt, unique):
    pairs = []
    for i in range(4):
        pub = clnt.publish("misuse.par%d.%s" % (i, unique), "counter/count_message")
        sub = clnt.subscribe("misuse.par%d.%s" % (i, unique), "counter/count_message", buffers=64)
        handshake(pub, sub)
        pairs.append((pub, sub))
    counts = [0] * 4

    def reader(i):
        sub = pairs[i][1]
        while counts[i] < 50:
            if sub.read(2.0) is None:
                return
            counts[i] += 1

    threads = [threading.Thread(target=reader, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for _ in range(50):
        for pub, _sub in pairs:
            pub.write()
    for t in threads:
        t.join(10)
    assert counts == [50] * 4


def test_threads_reading_one_port(clnt, unique):
    """Each packet is read exactly once by the threads reading the same port,
    whether it was there already or came while they waited (they share
    port.packet, so only the count is theirs to compare)."""
    pub = clnt.publish("misuse.shared.%s" % unique, "pytest/p64")
    sub = clnt.subscribe("misuse.shared.%s" % unique, "pytest/p64", buffers=64)
    handshake(pub, sub)
    counts = [0, 0]

    def reader(i):
        for _ in range(200):  # bounded; ends when no packet came for 0.5 s
            if sub.read(0.5) is None:
                return
            counts[i] += 1

    threads = [threading.Thread(target=reader, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for seq in range(1, 101):
        pub.packet.seq = seq
        pub.write()
        if seq % 10 == 0:
            time.sleep(0.002)  # some packets wait for a reader, some readers for a packet
    for t in threads:
        t.join(10)
    assert not any(t.is_alive() for t in threads)
    assert sum(counts) == 100  # none lost, none twice


def test_names_with_nul_bytes_are_refused(clnt, unique):
    # The C API takes C strings: "a.b\0x" would silently publish "a.b".
    topic = "misuse.nul.%s" % unique
    with pytest.raises(ValueError, match="the topic name must not contain NUL bytes"):
        clnt.publish(topic + "\x00x", "counter/count_message")
    with pytest.raises(ValueError, match="the topic name must not contain NUL bytes"):
        clnt.subscribe(topic + "\x00x", "counter/count_message")
    with pytest.raises(ValueError, match="the message definition name must not contain NUL bytes"):
        clnt.get_message_definition("counter/count_message\x00x")
    with pytest.raises(ValueError, match="the service name must not contain NUL bytes"):
        clnt.wait_for_service("misuse.svc\x00x", 0)
    with pytest.raises(ValueError, match="the client name must not contain NUL bytes"):
        ln.client("misuse\x00client")
    assert topic not in [t.name for t in clnt.list_topics()]


def test_buffers_below_one_are_refused(clnt, unique):
    for buffers in (0, -3):
        with pytest.raises(ValueError, match="buffers must be at least 1, not %d" % buffers):
            clnt.publish("misuse.buffers.%s" % unique, "counter/count_message", buffers=buffers)
        with pytest.raises(ValueError, match="buffers must be at least 1, not %d" % buffers):
            clnt.subscribe("misuse.buffers.%s" % unique, "counter/count_message", buffers=buffers)
    # The native layer (the C API) refuses 0 as well.
    with pytest.raises(ln.LNError, match="buffers must be at least 1"):
        _ln.OutPort(clnt._native, "misuse.buffers.%s" % unique, "counter/count_message", 0)


def test_packets_of_the_wrong_size_are_refused(clnt, unique):
    pub = clnt.publish("misuse.packet.%s" % unique, "counter/count_message")
    with pytest.raises(ValueError, match="'counter/count_message' messages are 12 bytes, got 5"):
        pub.packet = b"short"
    with pytest.raises(TypeError, match="port.packet takes a packet of 'counter/count_message'"):
        pub.packet = 12
    pub.write()  # the packet is still the port's own
    pub.packet = bytes(range(12))
    assert bytes(pub.packet._flat()) == bytes(range(12))
    other = clnt.publish("misuse.packet2.%s" % unique, "counter/count_message")
    other.packet.num_counts = 7
    pub.packet = other.packet
    assert pub.packet.num_counts == 7
    pub.write()
