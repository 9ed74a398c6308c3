"""A logger's manager_save(FILE, "mcap"): ln_core's manager writes the
recording as LN's recorder pcap and has ln_bag's `ln bag convert` (found as
`ln` on the manager's PATH) turn it into MCAP. Read back with independent
readers (mcap + mcap-ros2-support) against what was published; and the clear
errors when the converter is missing."""

import importlib.util
import os
import struct
import sys

import links_and_nodes as ln
import pytest
from bag_readers import mcap_messages
from conftest import MSGDEFS, ln_fixtures
from test_convert import by_topic, ns
from test_record import EPOCH, assert_filled_pose, fill_counter, fill_pose, md_text

ln_testing = ln_fixtures.ln_testing


def ln_package_dir():
    spec = importlib.util.find_spec("links_and_nodes")
    return os.path.dirname(os.path.dirname(spec.origin))


def launcher(directory, pythonpath):
    """An `ln` command in `directory` (as ln_core installs one: a script running
    links_and_nodes.cli) whose Python sees `pythonpath`."""
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, "ln")
    with open(path, "w") as f:
        f.write('#!/bin/sh\nPYTHONPATH=%s exec %s -m links_and_nodes.cli "$@"\n' % (pythonpath, sys.executable))
    os.chmod(path, 0o755)
    return directory


def start_manager(work_dir, path):
    """An ln_core manager with msgdefs/ on its search path and PATH=`path`."""
    env = dict(os.environ, PATH=path)
    m = ln_testing.LnCore(
        work_dir,
        base_env=env,
        home=work_dir,
        manager_exe=ln_fixtures.manager_binary(),
        package_dir=ln_package_dir(),
    )
    return m.start((MSGDEFS,))


def record(clnt, logger, topics, n):
    """Publishes n packets on each of `topics` ({topic: (definition, fill)})
    with the timestamps EPOCH + i/1000 (pose) and EPOCH + i/1000 + 0.0005
    (the others) while `logger` records them; returns the ports."""
    lg = clnt.get_logger(logger)
    ports = {topic: clnt.publish(topic, md) for topic, (md, _) in topics.items()}
    for topic in topics:
        lg.add_topic(topic, n)
    lg.enable()
    for i in range(n):
        for k, (topic, (_, fill)) in enumerate(topics.items()):
            fill(ports[topic].packet, i)
            ports[topic].write(EPOCH + i / 1000.0 + k * 0.0005)
    lg.disable()
    data = lg.download()
    assert [len(data.topics[t]) for t in topics] == [n] * len(topics)
    return lg, ports


def test_manager_save_mcap_is_what_was_published(tmp_path, unique):
    ln_dir = launcher(
        tmp_path / "bin",
        os.pathsep.join(p for p in (ln_package_dir(), os.environ.get("PYTHONPATH", "")) if p),
    )
    with start_manager(tmp_path / "manager", os.pathsep.join([str(ln_dir), os.environ.get("PATH", "")])) as m:
        clnt = ln.client("save_mcap", m.address)
        try:
            pose, counter = "save.%s.pose" % unique, "save.%s.counter" % unique
            n = 150
            lg, ports = record(
                clnt,
                "mcap_" + unique,
                {pose: ("bagtest/pose", fill_pose), counter: ("bagtest/counter", fill_counter)},
                n,
            )
            out = tmp_path / "out"
            out.mkdir()
            lg.manager_save(str(out / "log.mcap"), "mcap")
            lg.manager_save(str(out / "auto.mcap"))  # "auto": by the name
            assert sorted(os.listdir(out)) == ["auto.mcap", "log.mcap"]  # no temporary file stays
        finally:
            clnt.close()

    messages = mcap_messages(str(out / "log.mcap"))
    assert [(m.topic, m.sequence, m.publish_time, m.data) for m in messages] == [
        (m.topic, m.sequence, m.publish_time, m.data) for m in mcap_messages(str(out / "auto.mcap"))
    ]
    assert len(messages) == 2 * n
    topics = by_topic(messages)
    assert sorted(topics) == ["/save/%s/counter" % unique, "/save/%s/pose" % unique]

    poses = topics["/save/%s/pose" % unique]
    assert {m.schema for m in poses} == {"bagtest_ln_msgs/msg/Pose"}
    metadata = poses[0].metadata
    assert metadata["ln.topic"] == pose and metadata["ln.definition"] == "bagtest/pose"
    assert metadata["ln.hash"] == ports[pose].msg_def_hash
    # The manager's definition directories were handed on: the file's own text.
    assert metadata["ln.text"] == md_text("bagtest/pose")
    for i, message in enumerate(poses):
        # LN's recorder files keep no packet counter: the sequence is the position.
        assert message.sequence == i + 1
        assert message.publish_time == ns(EPOCH + i / 1000.0)  # the publisher's timestamp, to the ns
        assert abs(message.log_time - message.publish_time) < 1000  # the pcap record's time of it
        assert_filled_pose(message.decoded, i)
    counters = topics["/save/%s/counter" % unique]
    assert {m.schema for m in counters} == {"bagtest_ln_msgs/msg/Counter"}
    assert [(m.decoded.count, m.decoded.stamp) for m in counters] == [(i, i * 0.001) for i in range(n)]
    assert [m.publish_time for m in counters] == [ns(EPOCH + i / 1000.0 + 0.0005) for i in range(n)]
    # The file is in log time order: the topics interleaved as published.
    assert [m.log_time for m in messages] == sorted(m.log_time for m in messages)


@pytest.mark.parametrize("missing", ["ln", "ln_bag"])
def test_without_the_converter_manager_save_mcap_says_what_is_missing(tmp_path, unique, missing):
    if missing == "ln":
        path = "/usr/bin:/bin"  # coreutils' ln only
        expected = "has no LN `ln` command"
    else:
        path = os.pathsep.join([str(launcher(tmp_path / "bin", ln_package_dir())), "/usr/bin:/bin"])
        expected = "recordings need the ln_bag package"
    with start_manager(tmp_path / "manager", path) as m:
        clnt = ln.client("save_mcap", m.address)
        try:
            topic = "save.%s.pose" % unique
            lg, _ = record(clnt, "missing_" + unique, {topic: ("bagtest/pose", fill_pose)}, 5)
            target = tmp_path / "log.mcap"
            with pytest.raises(ln.LNError) as info:
                lg.manager_save(str(target), "mcap")
            assert info.value.code == ln.LNE_REQUEST_FAILED
            text = str(info.value)
            assert "cannot write '%s' as MCAP" % target in text and expected in text, text
            assert not target.exists()
            assert sorted(p.name for p in tmp_path.iterdir()) == ["bin", "manager"][missing == "ln" :]
            # The other formats still work.
            lg.manager_save(str(tmp_path / "log.pcap"))
            assert (tmp_path / "log.pcap").read_bytes()[:4] == struct.pack("=I", 0xA1B2C3D4)
        finally:
            clnt.close()
