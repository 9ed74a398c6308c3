"""`ln bag convert IN OUT.mcap`: LN 2.9's recorder and logger files, or an MCAP
file, into an indexed MCAP file with the channels `ln record` writes.

Inputs (recognised by content):
* lnrecorder pcap logs (also gzip/bzip2/xz) and lnrdb directories: topics and
  service calls; LN 2.9 keeps no packet counter there, so a message's
  sequence is its position on its topic (service calls: the request id);
* LN 2.9 logger files written by manager_save: .pcap (as above), .pickle and
  .mat (per topic the flattened fields plus _packet_log_ts, _packet_source_ts,
  _packet_counter; the files name no definitions: --topic TOPIC:DEFINITION);
* an MCAP file: what is readable is written again, complete with its index
  (the repair of a recording that was cut off).

Definitions: the definition files found on the search path (--md-dir, then
LN's standard directories) when their hash is the recorded one, else the text
rebuilt from the recording's own description of the definition (same hash).
"""

import os
import pickle
import shutil
import struct
import sys

from links_and_nodes.cli.common import CliError

from . import ln29, rosbag2
from ._native import BagError, McapWriter, TopicMapping
from .channels import channel_metadata, ns_from_seconds, ros_topic_for
from .reading import Recording


class Converter:
    def __init__(self, writer, md_dirs):
        self.writer = writer
        self.md_dirs = md_dirs
        self.schemas = {}  # (ROS type, schema) -> id
        self.channels = {}  # key -> [channel id, mapping, messages so far]
        self.services = {}  # service key -> (name, interface, form, hash)
        self.messages = 0

    # ------------------------------------------------------------ definitions
    def mapping(self, name, form, md_hash, part=""):
        """The TopicMapping of an LN 2.9 definition (see the module doc)."""
        import msg_mapping

        search = msg_mapping.Library(self.md_dirs, True).search_dirs
        try:
            found = TopicMapping(name, {}, search, part)
            if not md_hash or found.ln_hash == md_hash:
                return found
        except BagError:
            pass
        texts = ln29.definition_texts(name, form, service=bool(part))
        rebuilt = TopicMapping(name, texts, [], part)
        if md_hash and rebuilt.ln_hash != md_hash:
            raise BagError(
                "definition '%s': the recording describes it with hash %s but names hash %s, and no "
                "definition file with that hash was found (give its directory with --md-dir)"
                % (name, rebuilt.ln_hash, md_hash)
            )
        return rebuilt

    def channel(self, key, ln_name, mapping, publisher=None, part=None):
        schema_key = (mapping.ros_type, mapping.schema)
        if schema_key not in self.schemas:
            self.schemas[schema_key] = self.writer.add_schema(mapping.ros_type, "ros2msg", mapping.schema)
        channel_id = self.writer.add_channel(
            self.schemas[schema_key],
            ros_topic_for(ln_name, part),
            "cdr",
            channel_metadata(ln_name, mapping, publisher, part),
        )
        self.channels[key] = [channel_id, mapping, 0]

    def write(self, key, sequence, log_time, publish_time, ln_bytes, where):
        channel_id, mapping, count = self.channels[key]
        try:
            cdr = mapping.ln_to_cdr(ln_bytes)
        except BagError as error:
            raise BagError("%s: %s" % (where, error)) from None
        sequence = count + 1 if sequence is None else sequence
        self.writer.add_message(
            channel_id, sequence & 0xFFFFFFFF, ns_from_seconds(log_time), ns_from_seconds(publish_time), cdr
        )
        self.channels[key][2] = count + 1
        self.messages += 1

    # ----------------------------------------------------------------- inputs
    def ln29_events(self, events, where):
        for event in events:
            if isinstance(event, ln29.Topic):
                mapping = self.mapping(event.definition, event.form, event.hash)
                if mapping.packet_size != event.message_size:
                    raise BagError(
                        "%s: topic '%s' has packets of %d bytes, definition '%s' %d"
                        % (where, event.name, event.message_size, event.definition, mapping.packet_size)
                    )
                self.channel(event.key, event.name, mapping, event.publisher)
            elif isinstance(event, ln29.Packet):
                self.write(event.key, event.sequence, event.log_time, event.publish_time, event.data, where)
            elif isinstance(event, ln29.Service):
                self.services[event.key] = (event.name, event.interface, event.form, event.hash)
            elif isinstance(event, ln29.Call):
                name, interface, form, md_hash = self.services[event.key]
                key = ("service", name, interface, event.part)
                if key not in self.channels:
                    self.channel(key, name, self.mapping(interface, form, md_hash, event.part), part=event.part)
                self.write(key, event.request_id, event.log_time, event.completion_time, event.data, where)

    def mcap(self, rec):
        """Copies every readable message with its schema and channel."""
        ids = {}
        for channel, message in rec.messages():
            if channel.id not in ids:
                schema = rec.schema_of(channel)
                schema_id = 0
                if schema is not None:
                    key = (schema.name, schema.data)
                    if key not in self.schemas:
                        self.schemas[key] = self.writer.add_schema(
                            schema.name, schema.encoding, schema.data.decode("utf-8", "surrogateescape")
                        )
                    schema_id = self.schemas[key]
                ids[channel.id] = self.writer.add_channel(
                    schema_id, channel.topic, channel.message_encoding, dict(channel.metadata)
                )
            self.writer.add_message(
                ids[channel.id], message.sequence, message.log_time, message.publish_time, message.data
            )
            self.messages += 1


# --------------------------------------------------------------- logger files

#: What unpickling a logger file may construct: numpy arrays, nothing else.
_PICKLE_GLOBALS = {
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("_codecs", "encode"),
}


class _ArraysOnly(pickle.Unpickler):
    def find_class(self, module, name):
        if (module, name) in _PICKLE_GLOBALS:
            return super().find_class(module, name)
        raise pickle.UnpicklingError("it wants %s.%s, which a logger file never holds" % (module, name))


_STRUCT_CODES = {
    "double": "d",
    "float": "f",
    "int8_t": "b",
    "uint8_t": "B",
    "char": "b",
    "int16_t": "h",
    "uint16_t": "H",
    "int32_t": "i",
    "uint32_t": "I",
    "int64_t": "q",
    "uint64_t": "Q",
}


def logger_columns(model, defs, parent=None):
    """(column name, primitive, count) of LN 2.9's flattened logger data, in packet order:
    sub-type fields are named PARENT_FIELD, elements of sub-type arrays PARENT[i]_FIELD."""
    out = []
    for name, _, primitive, sub, dynamic, count, _ in model["fields"]:
        column = name if parent is None else "%s_%s" % (parent, name)
        if dynamic:
            raise BagError("field '%s' is dynamic: topics (and so logger files) have none" % name)
        if sub:
            for i in range(count):
                out += logger_columns(defs[sub], defs, "%s[%d]" % (column, i) if count > 1 else column)
        else:
            out.append((column, primitive, count))
    return out


def read_logger_pickle(path, topics, md_dirs):
    """Events of an LN 2.9 logger file saved as .pickle; topics: {topic: definition}."""
    try:
        with open(path, "rb") as f:
            data = _ArraysOnly(f).load()
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, ImportError) as error:
        raise BagError("%s: not a readable LN logger pickle: %s" % (path, error)) from None
    if not isinstance(data, dict):
        raise BagError("%s: not an LN logger pickle (a %s, not a dict of topics)" % (path, type(data).__name__))
    missing = sorted(set(data) - set(topics))
    if missing:
        raise BagError(
            "%s holds topics %s; say their LN definitions with --topic TOPIC:DEFINITION" % (path, ", ".join(missing))
        )
    return _logger_events(path, data, topics, md_dirs, lambda topic, column: column)


def _mat_name(name):
    """A name as LN 2.9's logger turns it into a MATLAB variable name."""
    return name.replace(".", "_").replace("/", "_").replace("[", "_").replace("]", "")


def read_logger_mat(path, topics, md_dirs):
    """Events of an LN 2.9 logger file saved as .mat: one variable per column, named
    COLUMN (one topic; a leading '_' moves to the end) or TOPIC_COLUMN (several
    topics; without the column's leading '_'), '.', '/', '[' as '_' and ']' dropped."""
    from .matfile import read_mat5

    variables = read_mat5(path)
    if "packet_log_ts_" in variables:  # a file of one topic
        if len(topics) != 1:
            raise BagError("%s is the log of one topic; say which with one --topic TOPIC:DEFINITION" % path)

        def variable(topic, column):
            return _mat_name(column[1:] + "_" if column.startswith("_") else column)

        return _logger_events(path, {next(iter(topics)): variables}, topics, md_dirs, variable)
    logged = sorted(v[: -len("_packet_log_ts")] for v in variables if v.endswith("_packet_log_ts"))
    by_name = {_mat_name(t): t for t in topics}
    missing = [name for name in logged if name not in by_name]
    if missing or not logged:
        raise BagError(
            "%s holds the logs of %s; say their LN topics and definitions with --topic TOPIC:DEFINITION"
            % (path, ", ".join(missing) if logged else "no topic")
        )

    def variable(topic, column):
        return _mat_name("%s_%s" % (topic, column[1:] if column.startswith("_") else column))

    return _logger_events(path, {by_name[name]: variables for name in logged}, topics, md_dirs, variable)


def _logger_events(path, data, topics, md_dirs, variable):
    """Topic and Packet events of LN 2.9's flattened logger data: data = {topic: columns},
    variable(topic, column) the name of a column in `columns`."""
    import numpy as np
    from links_and_nodes import _ln

    import msg_mapping

    search = msg_mapping.Library(list(md_dirs), True).search_dirs
    for key, topic in enumerate(sorted(data)):
        columns, md_name = data[topic], topics[topic]
        try:
            model = _ln.model_from_dirs(md_name, search)
        except Exception as error:
            raise BagError("%s: topic '%s': %s" % (path, topic, str(error).splitlines()[0])) from None
        layout = logger_columns(model, model.get("defs", {}))
        names = ["_packet_log_ts", "_packet_source_ts", "_packet_counter"] + [c for c, _, _ in layout]
        for needed in names:
            if variable(topic, needed) not in columns:
                raise BagError(
                    "%s: topic '%s' has no column '%s', which definition '%s' needs (is it the "
                    "definition the topic was logged with?)" % (path, topic, variable(topic, needed), md_name)
                )
        log_ts, source_ts, counters = (np.asarray(columns[variable(topic, c)]).reshape(-1) for c in names[:3])
        n = len(counters)
        fmt = "<" + "".join("%d%s" % (count, _STRUCT_CODES[primitive]) for _, primitive, count in layout)
        yield ln29.Topic(key, topic, md_name, None, model["hash"], "", struct.calcsize(fmt))
        arrays = [np.asarray(columns[variable(topic, c)]).reshape(n, -1) for c, _, _ in layout]
        for i in range(n):
            values = []
            for a in arrays:
                values += [_number(v) for v in a[i].tolist()]
            yield ln29.Packet(key, float(log_ts[i]), float(source_ts[i]), struct.pack(fmt, *values), int(counters[i]))


def _number(value):
    """A logged value as struct.pack takes it (char columns hold small arrays or bytes)."""
    if hasattr(value, "item"):
        value = value.item() if getattr(value, "size", 1) == 1 else value
    if isinstance(value, bytes):
        return value[0] if value else 0
    return value


def _topic_definitions(items):
    out = {}
    for item in items:
        topic, sep, md = item.rpartition(":")
        if not sep or not topic or not md:
            raise CliError("--topic %r: expected TOPIC:DEFINITION" % item, "e.g. --topic robot.state:robot/state")
        out[topic] = md
    return out


def convert_file(source, output, md_dirs=(), topics=None, rosbag2_dir=False, overwrite=False):
    """Converts `source` (see the module doc) into the MCAP file (or, with
    rosbag2_dir, the bag directory) `output`. Returns (kind, messages, damage):
    damage says where a cut-off input ended (everything before is converted).
    Raises BagError naming the file and what is wrong, leaving no output then.
    (The entry point for other tools, e.g. a logger's manager_save(FILE, "mcap")
    after saving LN 2.9's logger pcap.)"""
    if not os.path.exists(source):
        raise BagError("%s does not exist" % source)
    if os.path.isfile(os.path.join(source, "metadata.yaml")):  # a rosbag2 bag: its MCAP file
        from .info import mcap_files

        files = mcap_files(source)
        if len(files) != 1:
            raise BagError("%s has %d files; ln bag convert reads bags of one file" % (source, len(files)))
        source = files[0]
    kind = ln29.kind_of(source)
    if kind is None:
        raise BagError(
            "%s is not a recording ln bag convert knows (it reads lnrecorder .pcap files and lnrdb "
            "directories, LN 2.9 logger .pcap/.pickle/.mat files and MCAP files)" % source
        )
    if rosbag2_dir:
        bag_dir = output.rstrip("/") or output
        if os.path.exists(bag_dir):
            raise BagError("%s already exists (rosbag2 bags are new directories)" % bag_dir)
        os.makedirs(bag_dir)
        path = os.path.join(bag_dir, rosbag2.mcap_name(bag_dir))
    else:
        bag_dir, path = None, output
        if os.path.exists(path) and not overwrite:
            raise BagError("%s already exists (choose another name or pass --overwrite)" % path)
        if os.path.abspath(path) == os.path.abspath(source):
            raise BagError("%s: input and output are the same file" % path)
    writer = McapWriter(path)
    converter = Converter(writer, list(md_dirs))
    damage = None
    try:
        if kind == "mcap":
            with Recording(source) as rec:
                converter.mcap(rec)
                damage = rec.problem
        elif kind in ("pickle", "mat"):
            read = read_logger_pickle if kind == "pickle" else read_logger_mat
            converter.ln29_events(read(source, topics or {}, list(md_dirs)), source)
        else:
            events = ln29.read_pcap(source) if kind == "pcap" else ln29.read_lnrdb(source)
            try:
                converter.ln29_events(events, source)
            except BagError as error:
                if "cut off" not in str(error):
                    raise
                damage = str(error)
    except BagError:
        # Nothing usable was converted (the input is untouched): no half output stays behind.
        try:
            writer.close()
        except BagError:
            pass
        shutil.rmtree(bag_dir) if bag_dir else os.unlink(path)
        raise
    writer.close()
    if bag_dir:
        rosbag2.write_metadata(bag_dir, path)
    return kind, converter.messages, damage


def run(cli):
    args = cli.args
    try:
        kind, messages, damage = convert_file(
            args.input, args.output, args.md_dir, _topic_definitions(args.topic), args.rosbag2, args.overwrite
        )
    except BagError as error:
        raise CliError(str(error)) from None
    if damage:
        sys.stderr.write("ln bag convert: %s; converted everything before\n" % damage)
    output = args.output.rstrip("/") if args.rosbag2 else args.output
    if cli.json:
        cli.out.json({"input": args.input, "format": kind, "output": output, "messages": messages})
    else:
        cli.out.line("converted %d messages from %s (%s) to %s" % (messages, args.input, kind, output))
    return 0
