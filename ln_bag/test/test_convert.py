"""`ln bag convert`: LN 2.9's recorder and logger files -- made by LN 2.9's own
tools (data/ln29/, remade by `python ln29_recordings.py data/ln29`) and once
live in the test -- compared message by message with what LN 2.9's own code
reads from them; MCAP files rewritten with their index; damaged inputs."""

import json
import os
import pickle
import shutil
import struct
from fractions import Fraction
from pathlib import Path

import ln29_recordings
import pytest
from bag_readers import mcap_messages, rosbags_messages
from cli_helpers import ok, one_line_error, run_ln
from conftest import MSGDEFS

DATA = Path(__file__).resolve().parent / "data" / "ln29"
POSE_TEXT = (Path(MSGDEFS) / "bagtest" / "pose").read_text()


@pytest.fixture(scope="module")
def ln29():
    return ln29_recordings.support.require(ln29_recordings.reference(), "LN 2.9 reference")


def convert(*args):
    return run_ln(None, "bag", "convert", *map(str, args))


def ns(seconds):
    """The nearest nanosecond of an LN double timestamp (what a recording keeps)."""
    return round(Fraction(seconds) * 10**9)


def by_topic(messages):
    out = {}
    for m in messages:
        out.setdefault(m.topic, []).append(m)
    return out


def assert_pose(decoded, reference):
    assert decoded.counter == reference["counter"] and decoded.time == reference["time"]
    position = reference["position"]
    assert (decoded.position.x, decoded.position.y, decoded.position.z) == (position["x"], position["y"], position["z"])
    assert list(decoded.orientation) == reference["orientation"]
    assert list(decoded.flags) == reference["flags"]
    frame = reference["frame"]
    assert bytes(decoded.frame) == (
        frame.encode("latin-1").ljust(16, b"\0") if isinstance(frame, str) else bytes(v & 0xFF for v in frame)
    )


def check_against_ln29(messages, reference, with_services=True):
    """Every message of the converted file against LN 2.9's reading of the input."""
    topics = by_topic(messages)
    ref_poses = [r for r in reference if r["kind"] == "topic"]
    poses = topics["/ln29/pose"]
    assert len(poses) == len(ref_poses) > ln29_recordings.PACKETS // 2  # lnrecorder may miss the first ones
    for m, r in zip(poses, ref_poses):
        assert_pose(m.decoded, r["data"])
        assert m.log_time == ns(r["log_time"]) and m.publish_time == ns(r["publish_time"])
        assert m.schema == "bagtest_ln_msgs/msg/Pose" and m.metadata["ln.topic"] == "ln29.pose"
    if not with_services:
        return
    for part, event in (("request", "request"), ("response", "response")):
        converted = topics["/ln29/add/_%s" % part]
        ref = sorted((r for r in reference if r["kind"] == event), key=lambda r: r["log_time"])
        assert len(converted) == len(ref) == ln29_recordings.CALLS
        for m, r in zip(sorted(converted, key=lambda m: m.log_time), ref):
            assert m.schema == "bagtest_ln_msgs/srv/Add_%s" % part.capitalize()
            assert m.metadata["ln.part"] == part and m.metadata["ln.topic"] == "ln29.add"
            if part == "request":
                assert (m.decoded.a, m.decoded.b, m.decoded.text) == (r["data"]["a"], r["data"]["b"], r["data"]["text"])
                assert m.sequence == r["request_id"]
            else:
                assert (m.decoded.sum, m.decoded.text) == (r["data"]["sum"], r["data"]["text"])


def test_lnrecorder_pcap_converts_to_what_ln29_reads(ln29, tmp_path):
    out = tmp_path / "pcap.mcap"
    text = ok(convert(DATA / "recorder.pcap", out, "--md-dir", MSGDEFS))
    messages = mcap_messages(str(out))
    assert "converted %d messages" % len(messages) in text
    check_against_ln29(messages, ln29_recordings.decode(ln29, "pcap", DATA / "recorder.pcap"))
    pose = by_topic(messages)["/ln29/pose"]
    assert [m.sequence for m in pose] == list(range(1, len(pose) + 1))  # LN 2.9 kept no packet counter
    assert pose[0].metadata["ln.text"] == POSE_TEXT  # the definition file (--md-dir), its hash checked
    assert pose[0].metadata["ln.publisher"] == "ln29_publisher"


def test_without_definition_files_the_recorded_description_gives_the_same_types(ln29, tmp_path):
    out = tmp_path / "rebuilt.mcap"
    ok(convert(DATA / "recorder.pcap", out))
    messages = mcap_messages(str(out))
    check_against_ln29(messages, ln29_recordings.decode(ln29, "pcap", DATA / "recorder.pcap"))
    rebuilt = by_topic(messages)["/ln29/pose"][0].metadata
    ok(convert(DATA / "recorder.pcap", tmp_path / "files.mcap", "--md-dir", MSGDEFS))
    from_files = by_topic(mcap_messages(str(tmp_path / "files.mcap")))["/ln29/pose"][0].metadata
    assert rebuilt["ln.hash"] == from_files["ln.hash"]  # LN 2.9's hash of the rebuilt text
    assert rebuilt["ln.text"] != from_files["ln.text"]  # (comments are not recorded)
    assert json.loads(rebuilt["ln.uses"]) == {"bagtest/vec3": "double x\ndouble y\ndouble z\n"}


def test_lnrdb_directory_converts_to_what_ln29_reads(ln29, tmp_path):
    out = tmp_path / "lnrdb.mcap"
    ok(convert(DATA / "recorder_lnrdb", out))
    messages = mcap_messages(str(out))
    reference = ln29_recordings.decode(ln29, "lnrdb", DATA / "recorder_lnrdb")
    check_against_ln29(messages, reference, with_services=False)
    topics = by_topic(messages)
    requests, responses = topics["/ln29/add/_request"], topics["/ln29/add/_response"]
    calls = ln29_recordings.CALLS
    assert [(m.decoded.a, m.decoded.b, m.decoded.text) for m in requests] == [
        (i, 10, "call %d" % i) for i in range(calls)
    ]
    assert [(m.decoded.sum, m.decoded.text) for m in responses] == [
        (i + 10, "sum of call %d" % i) for i in range(calls)
    ]


def test_logger_files_pcap_and_pickle(ln29, tmp_path):
    from_pcap, from_pickle = tmp_path / "logger_pcap.mcap", tmp_path / "logger_pickle.mcap"
    ok(convert(DATA / "logger.pcap", from_pcap))
    check_against_ln29(
        mcap_messages(str(from_pcap)), ln29_recordings.decode(ln29, "pcap", DATA / "logger.pcap"), with_services=False
    )
    one_line_error(convert(DATA / "logger.pickle", from_pickle), "ln29.pose", "--topic TOPIC:DEFINITION")
    ok(convert(DATA / "logger.pickle", from_pickle, "--topic", "ln29.pose:bagtest/pose", "--md-dir", MSGDEFS))
    pcap_poses, pickle_poses = mcap_messages(str(from_pcap)), mcap_messages(str(from_pickle))
    assert [m.data for m in pickle_poses] == [m.data for m in pcap_poses]  # the same samples, the same CDR
    assert [m.publish_time for m in pickle_poses] == [m.publish_time for m in pcap_poses]
    with open(DATA / "logger.pickle", "rb") as f:
        columns = pickle.load(f)["ln29.pose"]
    assert [m.sequence for m in pickle_poses] == columns["_packet_counter"].tolist()  # LN's packet counter
    # the pickle keeps when the logger received each packet (its pcap only the publisher's time)
    assert [m.log_time for m in pickle_poses] == [ns(t) for t in columns["_packet_log_ts"].tolist()]


def test_converting_into_a_rosbag2_directory(tmp_path):
    bag = tmp_path / "converted_bag"
    ok(convert(DATA / "recorder.pcap", bag, "--rosbag2"))
    messages = rosbags_messages(str(bag))
    poses = [m.counter for t, _, _, m in messages if t == "/ln29/pose"]
    assert len(poses) > 30 and poses == list(range(poses[0], ln29_recordings.PACKETS))
    ok(convert(bag, tmp_path / "back.mcap"))  # and a bag directory back into a plain file
    assert [m.decoded.counter for m in mcap_messages(str(tmp_path / "back.mcap")) if m.topic == "/ln29/pose"] == poses


def test_a_fresh_lnrecorder_recording(ln29, tmp_path):
    """What the installed LN 2.9 writes today converts too: a live lnrecorder session."""
    recording = tmp_path / "live.pcap"
    ln29_recordings._session(ln29, tmp_path / "session", recording=recording)
    out = tmp_path / "live.mcap"
    ok(convert(recording, out))
    topics = by_topic(mcap_messages(str(out)))
    counters = [m.decoded.counter for m in topics["/ln29/pose"]]
    assert len(counters) > 30 and counters == list(range(counters[0], ln29_recordings.PACKETS))
    assert [m.decoded.sum for m in topics["/ln29/add/_response"]] == [i + 10 for i in range(ln29_recordings.CALLS)]


# ----------------------------------------------------------------- damaged input


def test_a_cut_off_pcap_converts_up_to_the_cut(tmp_path):
    cut = tmp_path / "cut.pcap"
    data = (DATA / "recorder.pcap").read_bytes()
    cut.write_bytes(data[: len(data) - 50])
    out = tmp_path / "cut.mcap"
    result = convert(cut, out)
    assert result.returncode == 0, result.stderr
    assert "cut off" in result.stderr and str(cut) in result.stderr
    ok(convert(DATA / "recorder.pcap", tmp_path / "all.mcap"))
    complete = mcap_messages(str(tmp_path / "all.mcap"))
    converted = mcap_messages(str(out))
    assert 0 < len(converted) < len(complete)
    assert [m.data for m in converted] == [m.data for m in complete[: len(converted)]]


def test_damaged_and_unknown_inputs_get_one_clear_error(tmp_path):
    garbage = tmp_path / "garbage.bin"
    garbage.write_bytes(os.urandom(200))
    one_line_error(convert(garbage, tmp_path / "g.mcap"), str(garbage), "is not a recording")
    one_line_error(convert(tmp_path / "missing.pcap", tmp_path / "m.mcap"), "missing.pcap", "does not exist")

    data = bytearray((DATA / "recorder.pcap").read_bytes())
    wrong_link = tmp_path / "other.pcap"
    other = bytearray(data)
    other[20:24] = struct.pack("<I", 1)  # an Ethernet capture
    wrong_link.write_bytes(bytes(other))
    one_line_error(convert(wrong_link, tmp_path / "o.mcap"), str(wrong_link), "not an LN recording", "link type 1")

    broken = bytearray(data)
    broken[24 + 8 : 24 + 12] = struct.pack("<I", 0xFFFFFFF0)  # the first frame's length
    broken_path = tmp_path / "broken.pcap"
    broken_path.write_bytes(bytes(broken))
    one_line_error(
        convert(broken_path, tmp_path / "b.mcap"), str(broken_path), "frame at byte 24", "impossible frame length"
    )

    wrong_hash = bytearray(data)
    at = bytes(wrong_hash).index(b"ln29.pose")  # the topic's frame: name, definition, text, publisher, hash
    hash_at = bytes(wrong_hash).index(b"\x40\x00\x00\x00", at) + 4
    wrong_hash[hash_at] = ord("0") if wrong_hash[hash_at] != ord("0") else ord("1")
    wrong_path = tmp_path / "wrong_hash.pcap"
    wrong_path.write_bytes(bytes(wrong_hash))
    line = one_line_error(convert(wrong_path, tmp_path / "w.mcap"), "definition 'bagtest/pose'", "--md-dir")
    assert "names hash %s" % bytes(wrong_hash[hash_at : hash_at + 64]).decode() in line

    existing = tmp_path / "existing.mcap"
    existing.write_bytes(b"keep me")
    one_line_error(convert(DATA / "recorder.pcap", existing), "already exists")
    assert existing.read_bytes() == b"keep me"


def test_a_cut_off_lnrdb_table_converts_its_complete_rows(tmp_path):
    db = tmp_path / "db"
    shutil.copytree(DATA / "recorder_lnrdb", db)
    table = next(db.glob("topics_*")) / "data"
    table.write_bytes(table.read_bytes()[:-10])
    out = tmp_path / "db.mcap"
    result = convert(db, out)
    assert result.returncode == 0 and "incomplete" in result.stderr
    ok(convert(DATA / "recorder_lnrdb", tmp_path / "whole.mcap"))
    whole = [m.decoded.counter for m in by_topic(mcap_messages(str(tmp_path / "whole.mcap")))["/ln29/pose"]]
    poses = by_topic(mcap_messages(str(out)))["/ln29/pose"]
    assert [m.decoded.counter for m in poses] == whole[:-1]


def test_a_pickle_that_wants_more_than_arrays_is_refused(tmp_path):
    class Sneaky:
        def __reduce__(self):
            return (os.system, ("echo owned > %s" % (tmp_path / "owned"),))

    evil = tmp_path / "evil.pickle"
    evil.write_bytes(pickle.dumps({"t": {"_packet_counter": Sneaky()}}, protocol=2))
    one_line_error(convert(evil, tmp_path / "e.mcap", "--topic", "t:bagtest/counter"), str(evil), "posix.system")
    assert not (tmp_path / "owned").exists()


def test_an_mcap_file_cut_off_while_recording_is_rewritten_with_its_index(tmp_path):
    import ln_bag

    path = tmp_path / "source.mcap"
    mapping = ln_bag.TopicMapping("bagtest/counter", md_dirs=[MSGDEFS])
    writer = ln_bag.McapWriter(str(path), chunk_size=4096)
    channel = writer.add_channel(writer.add_schema(mapping.ros_type, "ros2msg", mapping.schema), "/c", "cdr", {})
    for i in range(500):
        writer.add_message(channel, i, 10**18 + i, 10**18 + i, mapping.ln_to_cdr(struct.pack("<Qd48x", i, i * 0.5)))
    writer.close()
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    fixed = tmp_path / "fixed.mcap"
    result = convert(cut, fixed)
    assert result.returncode == 0 and "cut off" in result.stderr
    messages = mcap_messages(str(fixed))  # indexed: the summary is there
    counts = [m.decoded.count for m in messages]
    assert 100 < len(counts) < 500 and counts == list(range(len(counts)))
    assert [m.sequence for m in messages] == counts


def test_logger_mat_files_of_one_and_of_several_topics(tmp_path):
    """LN 2.9's logger .mat files, written here by libmatio from LN 2.9's own logger data (its pickle),
    convert to the same messages as the pickle."""
    from mat_writer import logger_variables, write_mat

    with open(DATA / "logger.pickle", "rb") as f:
        columns = pickle.load(f)["ln29.pose"]
    ok(
        convert(
            DATA / "logger.pickle", tmp_path / "pickle.mcap", "--topic", "ln29.pose:bagtest/pose", "--md-dir", MSGDEFS
        )
    )
    expected = [(m.data, m.log_time, m.publish_time, m.sequence) for m in mcap_messages(str(tmp_path / "pickle.mcap"))]

    one = tmp_path / "one.mat"
    write_mat(one, logger_variables(columns))
    ok(convert(one, tmp_path / "one.mcap", "--topic", "ln29.pose:bagtest/pose", "--md-dir", MSGDEFS))
    assert [
        (m.data, m.log_time, m.publish_time, m.sequence) for m in mcap_messages(str(tmp_path / "one.mcap"))
    ] == expected

    several = tmp_path / "several.mat"
    write_mat(
        several,
        dict(logger_variables(columns, "ln29_pose"), **logger_variables(columns, "other_pose")),
        compressed=True,
    )
    one_line_error(
        convert(several, tmp_path / "x.mcap", "--topic", "ln29.pose:bagtest/pose", "--md-dir", MSGDEFS),
        "other_pose",
        "--topic TOPIC:DEFINITION",
    )
    ok(
        convert(
            several,
            tmp_path / "several.mcap",
            "--topic",
            "ln29.pose:bagtest/pose",
            "--topic",
            "other.pose:bagtest/pose",
            "--md-dir",
            MSGDEFS,
        )
    )
    topics = by_topic(mcap_messages(str(tmp_path / "several.mcap")))
    assert sorted(topics) == ["/ln29/pose", "/other/pose"]
    assert [m.data for m in topics["/other/pose"]] == [e[0] for e in expected]

    damaged = tmp_path / "damaged.mat"
    damaged.write_bytes(one.read_bytes()[:-100])
    one_line_error(
        convert(damaged, tmp_path / "d.mcap", "--topic", "ln29.pose:bagtest/pose", "--md-dir", MSGDEFS),
        str(damaged),
        "cut off",
    )
