"""Topic loggers, LN 2.9's Python API: client.get_logger(name) gives a
logger; download() and logger_data.load() give a logger_data_wrapper whose
.topics map topic names to topic_cursor_wrapper objects, whose get_sample(i)
returns the i-th sample (oldest first) as a packet with the extra attributes
log_ts, src_ts and packet_counter.

The manager records (see ln/ln.h, "Topic loggers"); the native layer copies
each download, so a wrapper stays valid after later downloads. Samples are
decoded with the definition the data carries (LN 2.9's Python dict notation),
so files from LN 2.9 decode without a manager.
"""

from __future__ import annotations

import ast
import struct
from collections.abc import Callable, Iterable, Mapping, MutableMapping
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _ln
from ._packets import Compiler

if TYPE_CHECKING:
    import os
    from typing import TypeVar

    from ._packets import Part

    _UserDict = TypeVar("_UserDict", bound=MutableMapping[str, Any])

    class _LoggedPacket(Part):
        """A packet class of a recorded topic: its fields plus the sample header."""

        log_ts: float
        src_ts: float
        packet_counter: int


_HEADER = struct.Struct("=ddI")
_compiler = Compiler()  # packet classes of loaded data (no client needed)


class attr_dict(dict):
    """A dict whose keys are also attributes (LN 2.9's ln_wrappers.attr_dict)."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def __setattr__(self, name: str, value: Any) -> None:
        self[name] = value


def do_stack_fields(
    data: MutableMapping[str, Any], prefix: str, out_name: str | None = None, transpose: bool = True
) -> None:
    """Joins the per-field arrays of every entry of `data` whose key starts
    with `prefix` into one entry `out_name` (default: the prefix) of stacked
    arrays, as LN 2.9's helper of the same name."""
    out = attr_dict()
    for key in sorted(k for k in data.keys() if k.startswith(prefix)):
        for field, field_data in data[key].items():
            out.setdefault(field, []).append(field_data)
    for field, values in out.items():
        out[field] = np.array(values).transpose() if transpose else np.array(values)
    data[prefix if out_name is None else out_name] = out


def _sources(md_name, md_text):
    """Definition texts equivalent to a definition in LN 2.9's dict notation
    ({'fields': [[type, name, count]...], 'defines': {local: fields}})."""
    definition = ast.literal_eval(md_text)  # a literal, never evaluated code
    defines = definition.get("defines", {})
    # Sub-types are named by their local names, as LN 2.9 shows them.
    source_name = {local: local if local != md_name else "__logger_define__/" + local for local in defines}

    def text(fields):
        used, lines = [], []
        for field_type, name, count in fields:
            base = field_type.rstrip("*")
            if base in defines and base not in used:
                used.append(base)
            lines.append("%s %s%s" % (field_type, name, "" if count == 1 else "[%d]" % count))
        head = "".join('define %s as "%s"\n' % (local, source_name[local]) for local in used)
        return head + "\n".join(lines) + "\n"

    sources = {md_name: text(definition["fields"])}
    for local, fields in defines.items():
        sources[source_name[local]] = text(fields)
    return sources


class logger_sample_header:
    """A sample of a logger that records only timestamps (set_only_ts)."""

    __slots__ = ("log_ts", "src_ts", "packet_counter")
    _fields = ()
    log_ts: float
    src_ts: float
    packet_counter: int

    def keys(self) -> list[str]:
        return []

    def items(self) -> list[tuple[str, Any]]:
        return []

    def __repr__(self) -> str:
        return "<logger sample log_ts=%r src_ts=%r packet_counter=%r>" % (self.log_ts, self.src_ts, self.packet_counter)


class logger_topic_:
    """ln.h's logger_topic of one recorded topic (read-only)."""

    __slots__ = ("name", "log_size", "divisor", "n_samples", "sample_size", "md_name", "md", "_samples")
    name: str
    log_size: int
    divisor: int
    n_samples: int
    sample_size: int
    md_name: str
    md: str
    _samples: bytes

    def __init__(self, fields: Mapping[str, Any]) -> None:
        for key in self.__slots__[:-1]:
            setattr(self, key, fields[key])
        self._samples = fields["samples"]

    def __repr__(self) -> str:
        return "<logger_topic_ %r: %d samples of %d bytes>" % (self.name, self.n_samples, self.sample_size)


class topic_cursor:
    """Access to one recorded topic (LN 2.9's _ln.topic_cursor)."""

    def __init__(self, topic: logger_topic_) -> None:
        self.name = topic.name
        self._topic = topic

    def get_topic(self) -> logger_topic_:
        return self._topic

    def get_sample(self, idx: int, target_buffer: bytearray) -> None:
        """Copies sample `idx` (header and packet) into a bytearray."""
        if not isinstance(target_buffer, bytearray):
            raise ValueError("provided data is not a bytearray-object!")
        topic = self._topic
        if not 0 <= idx < topic.n_samples:
            raise IndexError("sample %s is out of range (0..%d)" % (idx, topic.n_samples - 1))
        start = idx * topic.sample_size
        target_buffer[: topic.sample_size] = topic._samples[start : start + topic.sample_size]


class topic_cursor_wrapper:
    """One recorded topic: len() samples, get_sample(i) the i-th (oldest first)."""

    def __init__(self, c: topic_cursor) -> None:
        self.name = c.name
        self.c = c
        self.topic = c.get_topic()
        self._packet_class: type[_LoggedPacket] | None = None
        if self.topic.md and self.topic.sample_size > _HEADER.size:
            model = _ln.model_from_sources(self.topic.md_name, _sources(self.topic.md_name, self.topic.md))
            part = _compiler.part_class(model)
            if part._size != self.topic.sample_size - _HEADER.size:
                raise ValueError(
                    "topic %r: samples of %d bytes do not hold packets of %r (%d bytes)"
                    % (self.name, self.topic.sample_size, self.topic.md_name, part._size)
                )
            self._packet_class = type(part.__name__, (part,), {"__slots__": ("log_ts", "src_ts", "packet_counter")})
        # As in LN 2.9: None when the topic was never seen published.
        self.packet: _LoggedPacket | logger_sample_header | None = self._new_packet() if self.topic.md else None

    def _new_packet(self) -> _LoggedPacket | logger_sample_header:
        return self._packet_class() if self._packet_class is not None else logger_sample_header()

    def get_sample(self, idx: int) -> _LoggedPacket | logger_sample_header:
        """Sample `idx` as a new packet with log_ts, src_ts and packet_counter."""
        topic = self.topic
        packet: _LoggedPacket | logger_sample_header
        if idx < 0 or idx >= topic.n_samples:
            raise IndexError("index %s is out of range" % idx)
        start = idx * topic.sample_size
        if self._packet_class is not None:
            packet = self._packet_class(bytearray(topic._samples[start + _HEADER.size : start + topic.sample_size]))
        else:
            packet = logger_sample_header()
        packet.log_ts, packet.src_ts, packet.packet_counter = _HEADER.unpack_from(topic._samples, start)
        return packet

    def __len__(self) -> int:
        return self.topic.n_samples

    def __repr__(self) -> str:
        return "<topic_cursor_wrapper %r: %d samples>" % (self.name, len(self))


def _column(value, n):
    """An empty column of `n` rows for values like `value` (None: a part)."""
    if isinstance(value, (bool, int, float)):
        return np.zeros((n,), dtype=type(value))
    if isinstance(value, (str, bytes)):
        return np.zeros((n,), dtype=object)
    if isinstance(value, np.ndarray):
        return np.zeros((n,) + value.shape, dtype=value.dtype)
    return None


def _columns_of(part, n, dict_type):
    """Columns for every field of `part`, nested parts as nested dicts."""
    out = dict_type()
    for name, value in part.items():
        if isinstance(value, list):
            out[name] = [_columns_of(item, n, dict_type) for item in value]
        elif _column(value, n) is None:
            out[name] = _columns_of(value, n, dict_type)
        else:
            out[name] = _column(value, n)
    return out


def _fill(columns, part, row):
    for name, value in part.items():
        target = columns[name]
        if isinstance(value, list):
            for sub_columns, item in zip(target, value):
                _fill(sub_columns, item, row)
        elif isinstance(target, dict):
            _fill(target, value, row)
        else:
            target[row] = value


def _shapes(columns, prefix, out):
    for name, value in columns.items():
        if isinstance(value, list):
            for i, sub in enumerate(value):
                _shapes(sub, "%s%s[%d]." % (prefix, name, i), out)
        elif isinstance(value, dict):
            _shapes(value, "%s%s." % (prefix, name), out)
        else:
            out.append((prefix + name, value.shape))


class logger_data_wrapper:
    """Downloaded or loaded logger data: .topics maps names to topic_cursor_wrapper."""

    def __init__(self, data: _ln.LoggerData) -> None:
        self.data = data
        self.topics: dict[str, topic_cursor_wrapper] = {}
        for fields in data.topics():
            cursor = topic_cursor(logger_topic_(fields))
            self.topics[cursor.name] = topic_cursor_wrapper(cursor)

    def save(self, fn: str) -> None:
        """Writes the data in LN 2.9's file format (logger_data.load reads it)."""
        self.data.save(fn)

    def get_dict(
        self, do_print: bool = False, do_transform_topic_name: bool = False, use_attr_dict: bool = False
    ) -> dict[str, Any]:
        return self.unpack_into(
            dict(), do_print=do_print, do_transform_topic_name=do_transform_topic_name, use_attr_dict=use_attr_dict
        )

    def unpack_into(
        self,
        user_dict: _UserDict,
        src_ts_name: str = "_packet_source_ts",
        stack_fields: Iterable[str | tuple[str, str]] | None = None,
        do_print: bool = True,
        do_transform_topic_name: bool = False,
        use_attr_dict: bool = True,
    ) -> _UserDict:
        """Per topic a dict of numpy arrays, one row per sample: the packet
        fields (nested parts as nested dicts, arrays of parts as lists of
        them) and `src_ts_name`, _packet_counter, _packet_log_ts. With
        do_transform_topic_name the topics are keyed by identifiers
        ("a.b" -> "a_b"). LN 2.9 stores _packet_log_ts as integers; here it
        keeps its fraction."""
        dict_type: Callable[[], dict[str, Any]] = attr_dict if use_attr_dict else dict
        shapes: list[tuple[str, tuple[int, ...]]] = []
        for topic, cursor in self.topics.items():
            n = len(cursor)
            if do_transform_topic_name:
                key = topic.strip().replace(".", "_").replace("/", "_").replace(" ", "_")
                prefix = key + "."
            else:
                key = topic
                prefix = '["%s"].' % topic
            target = user_dict[key] = dict_type()
            target[src_ts_name] = np.zeros((n,), dtype=np.double)
            target["_packet_counter"] = np.zeros((n,), dtype=int)
            target["_packet_log_ts"] = np.zeros((n,), dtype=np.double)
            columns = None
            for row in range(n):
                sample = cursor.get_sample(row)
                if columns is None:
                    columns = _columns_of(sample, n, dict_type)
                _fill(columns, sample, row)
                target[src_ts_name][row] = sample.src_ts
                target["_packet_counter"][row] = sample.packet_counter
                target["_packet_log_ts"][row] = sample.log_ts
            target.update(columns or {})
            _shapes(target, prefix, shapes)
        if do_print:
            width = max((len(name) for name, _ in shapes), default=0)
            for name, shape in shapes:
                print("%-*s %s" % (width, name, shape))
        for stack in stack_fields or []:
            if isinstance(stack, tuple):
                do_stack_fields(user_dict, stack[0], stack[1])
            else:
                do_stack_fields(user_dict, stack)
        return user_dict


class logger_data:
    """LN 2.9's _ln.logger_data: logger_data.load(filename)."""

    @staticmethod
    def load(filename: str | os.PathLike[str]) -> logger_data_wrapper:
        """Logger data from a file written by save() (also LN 2.9's)."""
        return logger_data_wrapper(_ln.LoggerData.load(str(filename)))


class logger:
    """A topic logger of a client (client.get_logger(name)); the manager records."""

    def __init__(self, native: _ln.Logger) -> None:
        self._native = native
        self.name = native.name

    def add_topic(self, topic_name: str, log_size: int, divisor: int = 1) -> None:
        """Records `log_size` samples of the topic (a ring), every `divisor`-th packet."""
        self._native.add_topic(topic_name, int(log_size), int(divisor))

    def clear_topics(self) -> None:
        self._native.clear_topics()

    def set_only_ts(self, only_ts: bool) -> None:
        self._native.set_only_ts(bool(only_ts))

    def enable(self) -> None:
        self._native.enable()

    def disable(self) -> None:
        self._native.disable()

    def download(self) -> logger_data_wrapper:
        return logger_data_wrapper(self._native.download())

    def direct_download(self) -> logger_data_wrapper:
        """As in LN 2.9: disables the logger, then downloads."""
        return logger_data_wrapper(self._native.direct_download())

    def manager_save(self, filename: str | os.PathLike[str], format: str = "auto") -> None:
        """The manager writes the recording to a file on its host: raw, pcap, mat, mat4, mcap or auto."""
        self._native.manager_save(str(filename), format)

    def __repr__(self) -> str:
        return "<links_and_nodes.logger %r>" % self.name
