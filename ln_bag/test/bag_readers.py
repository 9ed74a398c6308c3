"""Reading recordings the way other tools do, independently of ln_bag: the
`mcap` package with `mcap-ros2-support`'s decoder (as Foxglove and the mcap
CLI read), and `rosbags` (its own rosbag2 reader and CDR implementation)."""

import os
from dataclasses import dataclass

from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory


@dataclass
class Read:
    topic: str
    schema: str
    metadata: dict
    sequence: int
    log_time: int
    publish_time: int
    data: bytes
    decoded: object


def mcap_messages(path, validate=True):
    """Every message of an indexed file through its index (CRCs checked), decoded."""
    out = []
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=validate, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None, "%s has no summary" % path
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            out.append(
                Read(
                    channel.topic,
                    schema.name,
                    dict(channel.metadata),
                    message.sequence,
                    message.log_time,
                    message.publish_time,
                    bytes(message.data),
                    decoded,
                )
            )
    return out


def mcap_stream(path):
    """(messages read sequentially, the error that ended the read or None): what a
    reader gets from a file without summary, e.g. one cut off by SIGKILL."""
    decoders = {}
    factory = DecoderFactory()
    schemas, channels, out = {}, {}, []
    error = None
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                kind = type(record).__name__
                if kind == "Schema":
                    schemas[record.id] = record
                elif kind == "Channel":
                    channels[record.id] = record
                elif kind == "Message":
                    channel = channels[record.channel_id]
                    schema = schemas[channel.schema_id]
                    decode = decoders.get(schema.id) or decoders.setdefault(
                        schema.id, factory.decoder_for(channel.message_encoding, schema)
                    )
                    out.append(
                        Read(
                            channel.topic,
                            schema.name,
                            dict(channel.metadata),
                            record.sequence,
                            record.log_time,
                            record.publish_time,
                            bytes(record.data),
                            decode(record.data),
                        )
                    )
        except Exception as e:
            error = e
    return out, error


def rosbags_messages(bag_dir):
    """(topic, msgtype, timestamp, deserialized message) of a rosbag2 bag
    directory, with types registered from the bag's own definitions."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    out = []
    with Reader(bag_dir) as reader:
        types = {}
        for connection in reader.connections:
            found = get_types_from_msg(connection.msgdef.data, connection.msgtype)
            # rosbags files "pkg/srv/X_Request" (a service part, a real ROS type name) as "pkg/srv/msg/X_Request"
            types.update({name.replace("/srv/msg/", "/srv/"): t for name, t in found.items()})
        store.register(types)
        for connection, timestamp, raw in reader.messages():
            out.append(
                (connection.topic, connection.msgtype, timestamp, store.deserialize_cdr(raw, connection.msgtype))
            )
    return out


def file_size(path):
    return os.path.getsize(path)
