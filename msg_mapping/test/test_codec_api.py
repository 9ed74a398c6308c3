"""The codec from Python: buffer types, *_into, bad input, and a bounded fuzz run.

No generated ROS package is needed here (the round trips against rclpy are in
test_ln_roundtrip.py and test_ros_to_ln.py).
"""

import os
import random
import struct

import pytest

import msg_mapping

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "ln_corpus")


@pytest.fixture(scope="module")
def gen():
    library = msg_mapping.Library([CORPUS])
    g = msg_mapping.LnToRos()
    for name in msg_mapping.definition_names_under(CORPUS):
        g.add(library, name)
    return g


def test_buffer_types_and_into(gen):
    codec = gen.codec("mmbench/array4k")
    assert codec.fixed_ln_size == 4096 and codec.fixed_cdr_size == 4100
    data = bytes(range(256)) * 16
    cdr = codec.ln_to_cdr(data)
    assert cdr[:4] == b"\x00\x01\x00\x00" and cdr[4:] == data
    for buffer in (bytearray(data), memoryview(data)):
        assert codec.ln_to_cdr(buffer) == cdr
    numpy = pytest.importorskip("numpy")
    assert codec.ln_to_cdr(numpy.frombuffer(data, dtype=numpy.float64)) == cdr
    out = bytearray(5000)
    assert codec.ln_to_cdr_into(data, out) == 4100 and bytes(out[:4100]) == cdr
    ln = bytearray(4096)
    assert codec.cdr_to_ln_into(cdr, ln) == 4096 and bytes(ln) == data
    with pytest.raises(msg_mapping.CodecError, match="output buffer too small"):
        codec.ln_to_cdr_into(data, bytearray(100))
    with pytest.raises((TypeError, BufferError)):
        codec.ln_to_cdr_into(data, bytes(5000))  # not writable
    with pytest.raises((TypeError, BufferError)):
        codec.ln_to_cdr_into(data, memoryview(bytearray(10000))[::2])  # not contiguous


def test_parts_of_services_and_events(gen):
    request = gen.codec("mmtest/sub/deep_service", "request")
    assert request.ros_name == "mmtest_ln_msgs/srv/SubDeepService_Request"
    assert gen.codec("mmtest/alarm_event", "call").ros_name == "mmtest_ln_msgs/msg/AlarmEventCall"
    with pytest.raises(msg_mapping.MappingError, match="is a service: say which part"):
        gen.codec("mmtest/sub/deep_service")
    with pytest.raises(msg_mapping.MappingError, match="has no part 'call'"):
        gen.codec("mmtest/sub/deep_service", "call")
    with pytest.raises(msg_mapping.MappingError, match="has not been added"):
        gen.codec("mmtest/unknown")


def test_service_flat_format(gen):
    codec = gen.codec("mmtest/half_service", "request")
    assert codec.ln_to_cdr(struct.pack("<d", 0.5)) == b"\x00\x01\x00\x00" + struct.pack("<d", 0.5)
    empty = gen.codec("mmtest/half_service", "response")
    assert empty.ln_to_cdr(b"") == b"\x00\x01\x00\x00\x00\x00\x00\x00"
    # dynamic fields: uint32 count then elements, wherever (and whatever type) X_len was declared
    odd = gen.codec("mmtest/odd_lengths")
    ln = bytes([9]) + struct.pack("<I", 3) + b"abc" + struct.pack("<h", -2) + struct.pack("<I", 2) + b"hi"
    cdr = odd.ln_to_cdr(ln)
    assert cdr == (
        b"\x00\x01\x00\x00"
        + bytes([9])
        + b"\0\0\0"
        + struct.pack("<I", 3)
        + b"abc"
        + b"\0"
        + struct.pack("<h", -2)
        + b"\0\0"
        + struct.pack("<I", 3)
        + b"hi\0"
    )
    assert odd.cdr_to_ln(cdr) == ln


def test_bad_cdr_gives_clear_errors(gen):
    codec = gen.codec("mmtest/dynamic_plain")
    with pytest.raises(msg_mapping.CodecError, match="lacks the 4-byte header"):
        codec.cdr_to_ln(b"\x00")
    with pytest.raises(msg_mapping.CodecError, match=r"DynamicPlain: before: input truncated"):
        codec.cdr_to_ln(b"\x00\x01\x00\x00")
    bad_count = b"\x00\x01\x00\x00" + b"\x01\0\0\0" + struct.pack("<I", 0x7FFFFFFF) + bytes(8)
    with pytest.raises(msg_mapping.CodecError, match=r"values: sequence count 2147483647 is impossible"):
        codec.cdr_to_ln(bad_count)
    with pytest.raises(msg_mapping.CodecError, match="left over after the LN message"):
        codec.ln_to_cdr(_minimal_ln("mmtest/dynamic_plain") + b"\0")
    with pytest.raises(msg_mapping.CodecError, match="expected 24"):
        gen.codec("mmtest/point").ln_to_cdr(bytes(23))


def _mutations(rng, data):
    data = bytearray(data)
    kind = rng.randrange(4)
    if kind == 0 and data:
        for _ in range(3):
            data[rng.randrange(len(data))] = rng.randrange(256)
    elif kind == 1:
        del data[rng.randrange(len(data) + 1) :]
    elif kind == 2 and len(data) >= 8:
        at = rng.randrange(4, len(data) - 3)
        data[at : at + 4] = struct.pack("<I", rng.choice([0xFFFFFFFF, 0x80000000, len(data), 1 << 20]))
    else:
        data += bytes(rng.randrange(256) for _ in range(rng.randrange(1, 9)))
    return bytes(data)


def test_fuzz_never_crashes(gen):
    """Bounded: 40 rounds per type of mutated valid messages and random bytes."""
    rng = random.Random(2024)
    for name in ("mmtest/dynamic_plain", "mmtest/tree", "mmtest/nested", "mmtest/odd_lengths"):
        codec = gen.codec(name)
        seeds = []
        if codec.fixed_ln_size:
            seeds.append(bytes(codec.fixed_ln_size))
        else:
            seeds.append(codec.cdr_to_ln(codec.ln_to_cdr(_minimal_ln(name))))
        for ln in seeds:
            cdr = codec.ln_to_cdr(ln)
            for _ in range(40):
                for convert, data in ((codec.cdr_to_ln, _mutations(rng, cdr)), (codec.ln_to_cdr, _mutations(rng, ln))):
                    try:
                        convert(data)
                    except msg_mapping.CodecError:
                        pass
                garbage = bytes(rng.randrange(256) for _ in range(rng.randrange(64)))
                for convert in (codec.cdr_to_ln, codec.ln_to_cdr):
                    try:
                        convert(b"\x00\x01\x00\x00" + garbage)
                    except msg_mapping.CodecError:
                        pass


def _minimal_ln(name):
    # Every dynamic field empty: the LN flat form of a "zero" message.
    return {
        "mmtest/dynamic_plain": bytes([1]) + bytes(4) + bytes([2]) + bytes(4 * 6) + bytes([3]),
        "mmtest/tree": bytes(4) + bytes(4) + bytes(4),
        "mmtest/odd_lengths": bytes(1) + bytes(4) + bytes(2) + bytes(4),
    }[name]
