"""Reading MCAP recordings -- ours, rosbag2's, any tool's -- with the `mcap`
package, and telling exactly what is wrong with a damaged one.

An indexed file (summary and footer) is read through its index. A file
without one (a recording cut off by SIGKILL, power loss, a full disk) is read
sequentially up to its last complete record; `problem` then says where it
ends and why, and everything before that point is usable.
"""

import os
import struct

from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Message, Schema, Statistics
from mcap.stream_reader import StreamReader

from ._native import BagError

MAGIC = b"\x89MCAP0\r\n"
#: What reading a damaged file can raise besides McapError.
DAMAGE = (McapError, struct.error, ValueError, EOFError, KeyError, IndexError, OverflowError, MemoryError)


def describe_damage(error):
    text = str(error).strip() or type(error).__name__
    if type(error).__name__ == "EndOfFile" or "unpack requires" in text or isinstance(error, EOFError):
        return "it ends in the middle of a record (cut off while it was being written?)"
    return "it is damaged (%s)" % text


class Recording:
    """An MCAP file opened for reading: schemas, channels, message counts and
    time range, from its summary or, where it has none, from a scan."""

    def __init__(self, path):
        self.path = path
        try:
            self._file = open(path, "rb")
        except OSError as error:
            raise BagError("cannot open %s: %s" % (path, error.strerror or error)) from None
        head = self._file.read(len(MAGIC))
        if head != MAGIC:
            self._file.close()
            raise BagError(
                "%s is not an MCAP file (%s)" % (path, "it is empty" if not head else "it starts with %r" % head[:8])
            )
        self.size = os.path.getsize(path)
        self.schemas = {}  # id -> mcap Schema
        self.channels = {}  # id -> mcap Channel
        self.counts = {}  # channel id -> messages
        self.message_count = 0
        self.start_time = self.end_time = 0
        self.indexed = False
        self.problem = None  # why only part of the file is readable
        self._read_summary() or self._scan()

    def close(self):
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------- overview
    def _read_summary(self):
        try:
            summary = SeekingReader(self._file).get_summary()
        except DAMAGE:
            return False  # no footer: cut off, or damaged at the end; scan instead
        if summary is None or summary.statistics is None:
            return False
        stats = summary.statistics
        self.schemas, self.channels = dict(summary.schemas), dict(summary.channels)
        self.counts = dict(stats.channel_message_counts)
        if not self.counts and stats.message_count:
            return False  # no per-channel counts: count them
        self.message_count = stats.message_count
        self.start_time, self.end_time = stats.message_start_time, stats.message_end_time
        self.indexed = bool(summary.chunk_indexes) or not self.message_count
        return True

    def _scan(self):
        for _ in self._records(count=True):
            pass

    def _records(self, count=False):
        """Every record in file order (chunks opened); stops at damage, noting it."""
        self._file.seek(0)
        reader = StreamReader(self._file)
        try:
            for record in reader.records:
                if isinstance(record, Schema):
                    self.schemas[record.id] = record
                elif isinstance(record, Channel):
                    self.channels[record.id] = record
                elif isinstance(record, Message) and count:
                    self.counts[record.channel_id] = self.counts.get(record.channel_id, 0) + 1
                    self.message_count += 1
                    if self.message_count == 1 or record.log_time < self.start_time:
                        self.start_time = record.log_time
                    self.end_time = max(self.end_time, record.log_time)
                elif isinstance(record, Statistics):
                    continue
                yield record
        except DAMAGE as error:
            self.problem = "%s: %s; read up to byte %d of %d" % (
                self.path,
                describe_damage(error),
                self._file.tell(),
                self.size,
            )

    # ------------------------------------------------------------- messages
    def messages(self, channel_ids=None, start_time=None):
        """(channel, message) pairs in log-time order (in file order where the
        file has no index), of the given channels only, from `start_time` (ns) on."""
        wanted = None if channel_ids is None else set(channel_ids)
        if self.indexed:
            topics = None if wanted is None else sorted({self.channels[c].topic for c in wanted})
            self._file.seek(0)
            try:
                for _, channel, message in SeekingReader(self._file).iter_messages(
                    topics=topics, start_time=start_time, log_time_order=True
                ):
                    if wanted is None or channel.id in wanted:
                        yield channel, message
            except DAMAGE as error:
                raise BagError("%s: %s" % (self.path, describe_damage(error))) from None
            return
        for record in self._records():
            if (
                isinstance(record, Message)
                and (wanted is None or record.channel_id in wanted)
                and (start_time is None or record.log_time >= start_time)
            ):
                channel = self.channels.get(record.channel_id)
                if channel is None:
                    raise BagError(
                        "%s: a message on channel %d, which the file never declares" % (self.path, record.channel_id)
                    )
                yield channel, record

    def schema_of(self, channel):
        return self.schemas.get(channel.schema_id)
