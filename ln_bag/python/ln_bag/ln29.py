"""LN 2.9's recording files, read without LN 2.9: the formats as its tools write them.

* lnrecorder's pcap log (`lnrecorder record FILE.pcap`, also gzip/bzip2/xz
  compressed, and what a logger's manager_save(FILE.pcap) writes): a pcap file
  header (link type 147), then frames of a 20-byte header (seconds, nanoseconds
  of the recorder's clock, length, length, frame type) and a body: 0 file
  version, 1 new topic, 2 topic packet, 3 topic gone, 4 service peer, 5 new
  service, 6 service request or response;
* lnrecorder's lnrdb directory (`lnrecorder record DIR`): a `meta` file and a
  table directory per topic or service side, each with `meta` (Python literals:
  name, LN definition in dict form, hash, field-description) and `data` (fixed
  rows; dynamic fields as count + offset into a sub-table directory).

Both describe definitions in LN 2.9's dict form ({'fields': [[type, name,
count]...], 'resp_fields': [...], 'defines': {local type: fields}});
definition_texts() turns that back into definition text with the same LN hash.

Every reader yields the same events:
  Topic(key, name, definition, form, hash, publisher, message_size)
  Service(key, name, interface, form, hash, client)
  Packet(key, log_time, publish_time, data, sequence)  times in seconds; sequence None: not recorded
  Call(key, part, log_time, completion_time, request_id, client_id, data)   part: request | response
"""

import ast
import bz2
import gzip
import lzma
import os
import struct
from collections import namedtuple

from ._native import BagError

Topic = namedtuple("Topic", "key name definition form hash publisher message_size")
Service = namedtuple("Service", "key name interface form hash client")
Packet = namedtuple("Packet", "key log_time publish_time data sequence", defaults=(None,))
Call = namedtuple("Call", "key part log_time completion_time request_id client_id data")

PCAP_MAGIC = 0xA1B2C3D4
PCAP_LINK_TYPE = 147
FRAME_HEADER = struct.Struct("IIIII")
SERVICE_EVENT = struct.Struct("=IBBdddIIIQ")
#: flags bit 1 of a service event: the request data starts with the call header (version, client id, request id)
HAS_CALL_HEADER = 2
CALL_HEADER_SIZE = 2 + 4 + 4


def kind_of(path):
    """'pcap', 'lnrdb', 'mcap', 'pickle', 'mat' or None, from the file's content."""
    if os.path.isdir(path):
        return "lnrdb" if os.path.isfile(os.path.join(path, "meta")) else None
    with open(path, "rb") as f:
        head = f.read(128)
    if head.startswith(b"\x89MCAP0\r\n"):
        return "mcap"
    if head[:2] == b"\x1f\x8b" or head[:3] == b"BZh" or head[:6] == b"\xfd7zXZ\x00":
        return "pcap"
    if len(head) >= 4 and struct.unpack("<I", head[:4])[0] in (PCAP_MAGIC, 0xD4C3B2A1):
        return "pcap"
    if head.startswith(b"MATLAB"):
        return "mat"
    if head[:1] == b"\x80" and head[1:2] in (b"\x02", b"\x03", b"\x04", b"\x05"):
        return "pickle"
    return None


# ------------------------------------------------------------------ definitions


def parse_form(text, where):
    """LN 2.9's dict form of a definition, from its repr text."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    try:
        form = ast.literal_eval(text) if text else None
    except (ValueError, SyntaxError) as error:
        raise BagError("%s: the message definition is not readable (%s)" % (where, error)) from None
    if not isinstance(form, dict) or not isinstance(form.get("fields"), list):
        raise BagError("%s: the message definition has no field list: %r" % (where, str(text)[:80]))
    return form


def definition_texts(name, form, service=False):
    """{definition name: text} for LN 2.9's dict form of `name`: the definition
    and one definition per sub-type, named after its local type next to `name`
    ("vec3_t" of "rec/pose" -> "rec/vec3"). Their hash is LN 2.9's."""
    defines = form.get("defines") or {}
    directory = name.rsplit("/", 1)[0] + "/" if "/" in name else ""
    names = {}
    for local in defines:
        base = local[:-2] if local.endswith("_t") and len(local) > 2 else local
        candidate, n = directory + base, 2
        while candidate in names.values() or candidate == name:
            candidate, n = "%s%s_%d" % (directory, base, n), n + 1
        names[local] = candidate
    texts = {}

    def field_lines(field_list):
        return ["%s %s%s" % (ftype, fname, "[%d]" % count if count != 1 else "") for ftype, fname, count in field_list]

    def text_of(*sections):
        used = []
        for field_list in sections:
            for ftype, _, _ in field_list:
                if ftype.rstrip("*") in defines and ftype.rstrip("*") not in used:
                    used.append(ftype.rstrip("*"))
        head = ['define %s as "%s"' % (local, names[local].rsplit("/", 1)[-1]) for local in used]
        if len(sections) == 1:
            return "\n".join(head + field_lines(sections[0])) + "\n"
        return (
            "\n".join(
                ["service", "request"] + head + field_lines(sections[0]) + ["response"] + field_lines(sections[1])
            )
            + "\n"
        )

    texts[name] = text_of(form["fields"], form.get("resp_fields") or []) if service else text_of(form["fields"])
    for local, fields in defines.items():
        texts[names[local]] = text_of(fields)
    return texts


# ------------------------------------------------------------------------- pcap


def _open_maybe_compressed(path):
    with open(path, "rb") as f:
        head = f.read(6)
    if head[:2] == b"\x1f\x8b":
        return gzip.open(path, "rb")
    if head[:3] == b"BZh":
        return bz2.open(path, "rb")
    if head[:6] == b"\xfd7zXZ\x00":
        return lzma.open(path, "rb")
    return open(path, "rb")


class _Body:
    """Reads the fields of one frame body; a short body is a BagError."""

    def __init__(self, data, order, where):
        self.data, self.order, self.where, self.at = data, order, where, 0

    def take(self, fmt):
        s = struct.Struct(self.order + fmt)
        if self.at + s.size > len(self.data):
            raise BagError("%s: frame too short" % self.where)
        values = s.unpack_from(self.data, self.at)
        self.at += s.size
        return values if len(values) > 1 else values[0]

    def string(self):
        n = self.take("I")
        if self.at + n > len(self.data):
            raise BagError("%s: frame too short for a field of %d bytes" % (self.where, n))
        value = self.data[self.at : self.at + n]
        self.at += n
        return value.decode("utf-8", "replace")

    def rest(self, n=None):
        end = len(self.data) if n is None else self.at + n
        if end > len(self.data):
            raise BagError("%s: frame too short" % self.where)
        value = self.data[self.at : end]
        self.at = end
        return value


def read_pcap(path):
    """The events of an lnrecorder pcap log (see the module doc)."""
    with _open_maybe_compressed(path) as f:
        try:
            head = f.read(24)
        except (OSError, EOFError, lzma.LZMAError) as error:
            raise BagError("%s: cannot decompress: %s" % (path, error)) from None
        if len(head) < 24:
            raise BagError("%s: too short for a pcap file header (%d bytes)" % (path, len(head)))
        order = "<" if struct.unpack("<I", head[:4])[0] == PCAP_MAGIC else ">"
        magic, major, minor, _, _, _, link_type = struct.unpack(order + "IHHIIII", head)
        if magic != PCAP_MAGIC:
            raise BagError("%s: not a pcap file (magic %#x)" % (path, magic))
        if link_type != PCAP_LINK_TYPE:
            raise BagError(
                "%s: a pcap file, but not an LN recording (link type %d, LN writes %d)"
                % (path, link_type, PCAP_LINK_TYPE)
            )
        header = struct.Struct(order + "IIIII")
        version, topics, offset = 1, {}, 24
        while True:
            try:
                raw = f.read(header.size)
            except (OSError, EOFError, lzma.LZMAError) as error:
                raise BagError("%s: cannot decompress after byte %d: %s" % (path, offset, error)) from None
            if not raw:
                return
            where = "%s, frame at byte %d" % (path, offset)
            if len(raw) < header.size:
                raise BagError("%s: the file ends inside a frame header (cut off?)" % where)
            sec, nsec, n_bytes, _, frame_type = header.unpack(raw)
            if n_bytes < 4 or n_bytes > 1 << 31:
                raise BagError("%s: impossible frame length %d (damaged?)" % (where, n_bytes))
            data = f.read(n_bytes - 4)
            if len(data) < n_bytes - 4:
                raise BagError("%s: the file ends inside a frame (cut off?)" % where)
            offset += header.size + len(data)
            stamp = sec + nsec / 1e9
            body = _Body(data, order, where)
            if frame_type == 0:
                version = body.take("I") & 0xFFFF
            elif frame_type == 1:
                key, size = body.take("II")
                name, md, form, publisher = body.string(), body.string(), body.string(), body.string()
                md_hash = body.string() if version >= 2 else ""
                topics[key] = size
                yield Topic(key, name, md, parse_form(form, where), md_hash, publisher, size)
            elif frame_type == 2:
                key = body.take("I")
                if key not in topics:
                    raise BagError("%s: a packet of topic id %d, which the file never declared" % (where, key))
                packet = body.rest(topics[key])
                publish_time = body.take("d") if version >= 2 else stamp
                yield Packet(key, stamp, publish_time, packet)
            elif frame_type == 5:
                client, name, interface, form = body.string(), body.string(), body.string(), body.string()
                key = body.take("I")
                md_hash = body.string() if version >= 2 else ""
                yield Service(key, name, interface, parse_form(form, where), md_hash, client)
            elif frame_type == 6:
                (key, item_type, flags, completion, _, _, _, client_id, request_id, _) = body.take("IBBdddIIIQ")
                payload = body.rest(body.take("I"))
                yield _call(key, item_type, flags, stamp, completion, request_id, client_id, payload, order, where)
            # 3 (topic gone) and 4 (service peer) carry nothing a conversion needs


def call_payload(item_type, flags, payload, where, order="<"):
    """(part, LN flat bytes) of what LN's service logging carries for a call
    (lnrecorder's service events, ln/log_service's data): uint32 total length,
    then the request (after the call header when flags say so) or the status
    and the response."""
    if len(payload) < 4 or struct.unpack(order + "I", bytes(payload[:4]))[0] != len(payload):
        raise BagError("%s: a service event whose length field does not match its %d bytes" % (where, len(payload)))
    if item_type == 0:
        return "request", bytes(payload[4 + (CALL_HEADER_SIZE if flags & HAS_CALL_HEADER else 0) :])
    return "response", bytes(payload[8:])


def _call(key, item_type, flags, stamp, completion, request_id, client_id, payload, order, where):
    part, data = call_payload(item_type, flags, payload, where, order)
    return Call(key, part, stamp, completion, request_id, client_id, data)


# ------------------------------------------------------------------------ lnrdb


def _read_meta(path):
    meta = {}
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except OSError as error:
        raise BagError("cannot read %s: %s" % (path, error.strerror)) from None
    for number, line in enumerate(lines, 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        key, sep, value = line.partition(": ")
        try:
            if not sep:
                raise ValueError("no 'key: value'")
            meta[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError) as error:
            raise BagError("%s:%d: not a meta line (%s): %s" % (path, number, error, line[:80])) from None
    return meta


class _Table:
    """One lnrdb table: rows of a packed numpy dtype, sub-tables for dynamic fields."""

    def __init__(self, directory):
        import numpy as np

        self.directory = directory
        self.meta = _read_meta(os.path.join(directory, "meta"))
        if self.meta.get("endianess", "little") != "little":
            raise BagError("%s: big-endian tables are not supported" % directory)
        if self.meta.get("table-format", "fixed") != "fixed":
            raise BagError("%s: table format %r is not supported" % (directory, self.meta.get("table-format")))
        self.fields = self.meta.get("field-description") or [["data", "u1"]]
        self.subtables = dict(self.meta.get("field-subtables") or [])
        try:
            self.dtype = np.dtype(self._numpy_fields(self.fields))
        except (TypeError, ValueError) as error:
            raise BagError("%s: field-description is not usable: %s" % (directory, error)) from None
        data_path = os.path.join(directory, "data")
        size = os.path.getsize(data_path) if os.path.exists(data_path) else 0
        self.complete_rows = size // self.dtype.itemsize
        self.cut = size % self.dtype.itemsize
        self.rows = (
            np.fromfile(data_path, self.dtype, count=self.complete_rows)
            if self.complete_rows
            else np.empty(0, self.dtype)
        )

    @staticmethod
    def _numpy_fields(fields):
        out = []
        for item in fields:
            kind = _Table._numpy_fields(item[1]) if isinstance(item[1], list) else item[1]
            out.append((item[0], kind) if len(item) == 2 else (item[0], kind, item[2]))
        return out

    def sub(self, path):
        return _Table(os.path.join(self.directory, self.subtables[path]))

    def flat(self, record, fields=None, prefix=""):
        """LN flat bytes of a row (or a nested struct of one): dynamic fields as
        uint32 count + elements from their sub-tables (msg_mapping's LN flat format)."""
        fields = self.fields if fields is None else fields
        out = bytearray()
        names = {item[0] for item in fields}
        for item in fields:
            name, kind = item[0], item[1]
            path = prefix + name
            if name.endswith("_len") and path[:-4] in self.subtables and name[:-4] + "_offset" in names:
                count, first = int(record[name]), int(record[name[:-4] + "_offset"])
                table = self._sub_cache(path[:-4])
                if first + count > len(table.rows):
                    raise BagError(
                        "%s: rows %d..%d of a sub-table with %d rows (cut off?)"
                        % (table.directory, first, first + count, len(table.rows))
                    )
                out += struct.pack("<I", count)
                for row in table.rows[first : first + count]:
                    out += table.flat(row)
            elif name.endswith("_offset") and path[:-7] in self.subtables:
                continue
            elif isinstance(kind, list):
                out += self.flat(record[name], kind, path + "/")
            else:
                out += record[name].tobytes()
        return bytes(out)

    def _sub_cache(self, path):
        cache = self.__dict__.setdefault("_subs", {})
        if path not in cache:
            cache[path] = self.sub(path)
        return cache[path]


def read_lnrdb(path):
    """The events of an lnrecorder lnrdb directory, ordered by receive time."""
    db = _read_meta(os.path.join(path, "meta"))
    if "lnrecorder-version" not in db and "version" not in db:
        raise BagError("%s: a directory with a meta file, but not an lnrdb recording" % path)
    tables = []
    for entry in sorted(os.listdir(path)):
        directory = os.path.join(path, entry)
        if os.path.isdir(directory) and os.path.isfile(os.path.join(directory, "meta")):
            tables.append(_Table(directory))
    events, declarations, cut = [], [], []
    for table in tables:
        m, name = table.meta, table.meta.get("name", "")
        if table.cut:
            cut.append(table.directory)
        if name.startswith("topics/"):
            key = ("topic", m["topic.id"])
            form = parse_form(m.get("topic.msg_def", ""), table.directory)
            declarations.append(
                Topic(
                    key,
                    m["topic.name"],
                    m["topic.md"],
                    form,
                    m.get("topic.msg_def_hash", ""),
                    m.get("topic.publisher", ""),
                    m["topic.message_size"],
                )
            )
            packet_bytes = table.dtype.itemsize - 16
            if packet_bytes != m["topic.message_size"]:
                raise BagError(
                    "%s: rows of %d bytes do not hold packets of %d"
                    % (table.directory, table.dtype.itemsize, m["topic.message_size"])
                )
            raw = table.rows.tobytes()
            stride = table.dtype.itemsize
            for i, row in enumerate(table.rows):
                events.append(
                    Packet(
                        key,
                        float(row["timestamp"]),
                        float(row["publisher_timestamp"]),
                        raw[i * stride + 16 : (i + 1) * stride],
                    )
                )
        elif name.startswith("services/") and "service.req_or_resp" in m:
            key = ("service", m["service.name"], m["service.md"])
            form = parse_form(m.get("service.msg_def", ""), table.directory)
            if key not in {d.key for d in declarations}:
                declarations.append(
                    Service(
                        key,
                        m["service.name"],
                        m["service.md"],
                        form,
                        m.get("service.msg_def_hash", ""),
                        m.get("service.client_name", ""),
                    )
                )
            request = m["service.req_or_resp"] == "req"
            for row in table.rows:
                if request:
                    data = table.flat(row["req_data"], _field(table.fields, "req_data"), "req_data/")
                else:
                    response = table._sub_cache("resp_data")
                    first, count = int(row["resp_data_offset"]), int(row["resp_data_len"])
                    if count != 1 or first + 1 > len(response.rows):
                        raise BagError("%s: a response row without its data (cut off?)" % table.directory)
                    data = response.flat(response.rows[first])
                events.append(
                    Call(
                        key,
                        "request" if request else "response",
                        float(row["timestamp"]),
                        float(row["completion_time"]),
                        int(row["request_id"]),
                        int(m.get("service.req.client_id", 0)),
                        data,
                    )
                )
    if cut:
        import sys

        sys.stderr.write(
            "ln bag convert: %s: the last row of %s is incomplete (cut off while recording); "
            "converting the complete rows\n" % (path, ", ".join(cut))
        )
    yield from declarations
    yield from sorted(events, key=lambda e: e.log_time)


def _field(fields, name):
    for item in fields:
        if item[0] == name:
            return item[1]
    raise BagError("no field %r" % name)
