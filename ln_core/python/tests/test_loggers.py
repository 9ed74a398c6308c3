"""Topic loggers with LN 2.9's Python API (client.get_logger, logger_data,
topic_cursor_wrapper) against ln_core's manager, which records."""

import struct

import links_and_nodes as ln
import numpy as np
import pytest


def write_all_types(port, values):
    for i in values:
        port.packet.i32 = i
        port.packet.u64 = 2**40 + i
        port.packet.vec = [i, i + 0.5, -i]
        port.packet.name = "n%d" % i
        port.packet.corners[1].x = i * 2.0
        port.write()


def test_a_logger_records_and_its_samples_are_packets(clnt, unique):
    topic = "pytest.log." + unique
    port = clnt.publish(topic, "pytest/all_types")
    lg = clnt.get_logger("py_" + unique)
    assert lg.name == "py_" + unique
    lg.add_topic(topic, 3)  # divisor defaults to 1
    lg.enable()
    write_all_types(port, range(1, 6))
    assert not port.has_subscriber()
    lg.disable()
    data = lg.download()
    assert isinstance(data, ln.logger_data_wrapper)
    assert list(data.topics) == [topic]
    cursor = data.topics[topic]
    assert isinstance(cursor, ln.topic_cursor_wrapper)
    assert len(cursor) == 3
    assert cursor.topic.n_samples == 3 and cursor.topic.log_size == 3 and cursor.topic.divisor == 1
    assert cursor.topic.md_name == "pytest/all_types"
    assert cursor.topic.md.startswith("{'fields': [['float', 'f', 1], ['double', 'd', 1]")
    assert cursor.topic.sample_size == 20 + port.packet._size
    samples = [cursor.get_sample(i) for i in range(len(cursor))]
    assert [s.i32 for s in samples] == [3, 4, 5]
    assert [s.name for s in samples] == ["n3", "n4", "n5"]
    assert [s.corners[1].x for s in samples] == [6.0, 8.0, 10.0]
    assert [s.packet_counter for s in samples] == [3, 4, 5]
    assert all(s.log_ts >= s.src_ts > 0 for s in samples)
    with pytest.raises(IndexError):
        cursor.get_sample(3)
    # the raw access of LN 2.9's _ln.topic_cursor
    raw = bytearray(cursor.topic.sample_size)
    cursor.c.get_sample(0, raw)
    assert struct.unpack_from("=ddI", raw)[2] == 3


def test_downloads_stay_valid_and_get_dict_gives_arrays(clnt, unique):
    topic = "pytest.dict." + unique
    lg = clnt.get_logger("dict_" + unique)
    lg.add_topic(topic, 10, 2)
    port = clnt.publish(topic, "pytest/all_types")
    lg.enable()
    write_all_types(port, range(1, 7))
    lg.disable()
    first = lg.download()
    second = lg.download()  # the first stays usable
    assert [first.topics[topic].get_sample(i).i32 for i in range(3)] == [2, 4, 6]
    d = second.get_dict()
    t = d[topic]
    assert list(t["i32"]) == [2, 4, 6]
    assert list(t["u64"]) == [2**40 + 2, 2**40 + 4, 2**40 + 6]
    assert t["vec"].shape == (3, 3) and list(t["vec"][1]) == [4.0, 4.5, -4.0]
    assert list(t["name"]) == ["n2", "n4", "n6"]
    assert list(t["corners"][1]["x"]) == [4.0, 8.0, 12.0]
    assert list(t["_packet_counter"]) == [2, 4, 6]
    assert t["_packet_log_ts"].dtype == np.double and t["_packet_log_ts"][0] % 1 != 0
    named = second.unpack_into({}, do_print=False, do_transform_topic_name=True)
    key = topic.replace(".", "_")
    assert list(named[key].i32) == [2, 4, 6]  # attribute access (attr_dict)


def test_save_load_and_manager_save(clnt, unique, tmp_path):
    topic = "pytest.save." + unique
    lg = clnt.get_logger("save_" + unique)
    lg.add_topic(topic, 10)
    port = clnt.publish(topic, "pytest/point")
    lg.enable()
    for i in range(4):
        port.packet.x = i
        port.write()
    lg.disable()
    data = lg.download()
    data.save(str(tmp_path / "log.lnlog"))
    loaded = ln.logger_data.load(str(tmp_path / "log.lnlog"))
    assert [loaded.topics[topic].get_sample(i).x for i in range(4)] == [0.0, 1.0, 2.0, 3.0]
    lg.manager_save(str(tmp_path / "log.raw"))
    raw = (tmp_path / "log.raw").read_bytes()
    assert len(raw) == 4 * (20 + 16)
    assert struct.unpack_from("=ddIdd", raw, 36)[2:] == (2, 1.0, 0.0)
    lg.manager_save(str(tmp_path / "log.pcap"), "pcap")
    assert (tmp_path / "log.pcap").read_bytes()[:4] == struct.pack("=I", 0xA1B2C3D4)
    with pytest.raises(ln.LNError) as info:
        lg.manager_save(str(tmp_path / "log.pickle"))
    assert info.value.code == ln.LNE_REQUEST_FAILED and "pickle" in str(info.value)
    assert not (tmp_path / "log.pickle").exists()


def test_only_timestamps_and_bad_input(clnt, unique, tmp_path):
    topic = "pytest.ts." + unique
    port = clnt.publish(topic, "pytest/point")
    lg = clnt.get_logger("ts_" + unique)
    lg.add_topic(topic, 5)
    lg.set_only_ts(True)
    lg.enable()
    port.write()
    port.write()
    lg.disable()
    cursor = lg.download().topics[topic]
    assert cursor.topic.sample_size == 20
    assert [cursor.get_sample(i).packet_counter for i in range(2)] == [1, 2]
    assert lg.download().get_dict()[topic]["_packet_counter"].tolist() == [1, 2]

    with pytest.raises(ln.LNError) as info:
        lg.add_topic(topic, 0)
    assert info.value.code == ln.LNE_INVALID_PARAMETER
    empty = clnt.get_logger("empty_" + unique)
    with pytest.raises(ln.LNError) as info:
        empty.enable()
    assert info.value.code == ln.LNE_NO_LOGGER_TOPICS
    with pytest.raises(ln.LNError) as info:
        empty.download()
    assert info.value.code == ln.LNE_REQUEST_FAILED and "does not exist" in str(info.value)
    (tmp_path / "bad").write_bytes(b"\x20\x04" + b"\xff" * 10)
    with pytest.raises(ln.LNError) as info:
        ln.logger_data.load(str(tmp_path / "bad"))
    assert "version" in str(info.value)
    with pytest.raises(ln.LNError):
        ln.logger_data.load(str(tmp_path / "missing"))


def test_a_topic_never_published_has_no_packet(clnt, unique):
    lg = clnt.get_logger("never_" + unique)
    lg.add_topic("pytest.never." + unique, 5)
    lg.enable()
    lg.disable()
    cursor = lg.download().topics["pytest.never." + unique]
    assert len(cursor) == 0 and cursor.packet is None and cursor.topic.md == ""


def test_a_closed_clients_logger_says_so(manager, unique):
    c = ln.client("pytest_closing")
    lg = c.get_logger("closing_" + unique)
    c.close()
    with pytest.raises(ln.LNError) as info:
        lg.enable()
    assert info.value.code == ln.LNE_CLIENT_NOT_INITIALIZED
