"""The MCAP writer on its own, checked record by record with the `mcap` package:
CRCs, statistics, chunk and message indexes, large messages, many channels."""

import io

import pytest
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, ChunkIndex, Message, MessageIndex, Schema, Statistics
from mcap.stream_reader import StreamReader

from ln_bag import BagError, McapWriter


def write(path, messages, channels=3, chunk_size=4096):
    """messages: (channel index, size); data = bytes counting from the message number."""
    writer = McapWriter(str(path), chunk_size=chunk_size)
    schema = writer.add_schema("test_msgs/msg/Blob", "ros2msg", "uint8[] data")
    ids = [writer.add_channel(schema, "/c%d" % i, "cdr", {"index": str(i)}) for i in range(channels)]
    expected = []
    for n, (channel, size) in enumerate(messages):
        data = bytes((n + k) & 0xFF for k in range(size))
        writer.add_message(ids[channel], n, 1_000_000_000 + n * 1000, 2_000_000_000 + n, data)
        expected.append(("/c%d" % channel, n, 1_000_000_000 + n * 1000, 2_000_000_000 + n, data))
    writer.close()
    return expected


def read_indexed(path):
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        messages = [
            (c.topic, m.sequence, m.log_time, m.publish_time, bytes(m.data))
            for _, c, m in reader.iter_messages(log_time_order=False)
        ]
    return summary, messages


def test_every_message_comes_back_through_the_index_with_valid_crcs(tmp_path):
    path = tmp_path / "small.mcap"
    expected = write(path, [(n % 3, 10 + n % 50) for n in range(2000)])
    summary, messages = read_indexed(path)
    assert messages == expected
    stats = summary.statistics
    assert stats.message_count == 2000 and stats.channel_count == 3 and stats.schema_count == 1
    assert stats.chunk_count == len(summary.chunk_indexes) > 10
    assert stats.channel_message_counts == {1: 667, 2: 667, 3: 666}
    assert (stats.message_start_time, stats.message_end_time) == (1_000_000_000, 1_000_000_000 + 1999 * 1000)
    assert summary.channels[2].metadata == {"index": "1"}
    with open(path, "rb") as f:  # the sequential reader checks the data section's CRC too
        assert sum(isinstance(r, Message) for r in StreamReader(f, validate_crcs=True).records) == 2000


def test_message_indexes_point_at_their_messages(tmp_path):
    path = tmp_path / "indexed.mcap"
    write(path, [(n % 2, 100) for n in range(300)], channels=2)
    data = path.read_bytes()
    _, messages = read_indexed(path)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    checked = 0
    for chunk_index in summary.chunk_indexes:
        chunk = next(
            StreamReader(io.BytesIO(data[chunk_index.chunk_start_offset :]), skip_magic=True, emit_chunks=True).records
        )
        assert isinstance(chunk, Chunk)
        records = chunk.data
        for channel_id, offset in chunk_index.message_index_offsets.items():
            index = next(StreamReader(io.BytesIO(data[offset:]), skip_magic=True).records)
            assert isinstance(index, MessageIndex) and index.channel_id == channel_id
            for log_time, at in index.records:
                message = next(StreamReader(io.BytesIO(records[at:]), skip_magic=True).records)
                assert isinstance(message, Message)
                assert (message.channel_id, message.log_time) == (channel_id, log_time)
                checked += 1
    assert checked == 300


def test_a_message_larger_than_a_chunk_gets_a_chunk_of_its_own(tmp_path):
    path = tmp_path / "big.mcap"
    expected = write(path, [(0, 100), (1, 3 << 20), (0, 100), (2, 1 << 20)], chunk_size=1 << 20)
    summary, messages = read_indexed(path)
    assert messages == expected
    # the small message's chunk is closed before each big one, which then fills a chunk of its own
    assert [c.message_start_time for c in summary.chunk_indexes] == [m[2] for m in expected]
    assert [c.uncompressed_size > 1 << 20 for c in summary.chunk_indexes] == [False, True, False, True]


def test_many_channels_and_an_empty_recording(tmp_path):
    path = tmp_path / "many.mcap"
    expected = write(path, [(n % 300, 8) for n in range(900)], channels=300)
    summary, messages = read_indexed(path)
    assert messages == expected and len(summary.channels) == 300

    empty = tmp_path / "empty.mcap"
    writer = McapWriter(str(empty))
    writer.close()
    writer.close()  # idempotent
    with open(empty, "rb") as f:
        records = list(StreamReader(f, validate_crcs=True).records)
    assert any(isinstance(r, Statistics) and r.message_count == 0 for r in records)
    assert not any(isinstance(r, (Schema, Channel, ChunkIndex)) for r in records)


def test_misuse_is_an_error_naming_the_file(tmp_path):
    path = tmp_path / "misuse.mcap"
    writer = McapWriter(str(path))
    with pytest.raises(BagError, match="misuse.mcap: message on an unknown channel"):
        writer.add_message(5, 0, 0, 0, b"x")
    with pytest.raises(BagError, match="unknown schema"):
        writer.add_channel(9, "/t", "cdr", {})
    writer.close()
    with pytest.raises(BagError, match="already closed"):
        writer.add_message(1, 0, 0, 0, b"x")
    with pytest.raises(BagError, match="cannot create .*/nowhere/x.mcap: No such file or directory"):
        McapWriter(str(tmp_path / "nowhere" / "x.mcap"))


def test_checksums_of_chunks_of_every_size(tmp_path):
    """Chunks from a few bytes to 100 KB at every alignment: the CRCs (computed with carry-less
    multiplication where the CPU has it) agree with zlib's, as the reader checks them."""
    import random

    rng = random.Random(17)
    for chunk_size in (1, 63, 64, 65, 200, 4099, 100_003):
        path = tmp_path / ("crc_%d.mcap" % chunk_size)
        expected = write(path, [(n % 3, rng.randrange(0, 3000)) for n in range(120)], chunk_size=chunk_size)
        assert read_indexed(path)[1] == expected
        with open(path, "rb") as f:
            assert sum(isinstance(r, Message) for r in StreamReader(f, validate_crcs=True).records) == 120
