"""rosbag2 bag directories: the MCAP file plus `metadata.yaml`, as rosbag2
(Jazzy, metadata version 9) writes them, so `ros2 bag` and rosbags open them."""

import os

import yaml

from ._native import BagError
from .reading import Recording

METADATA = "metadata.yaml"
VERSION = 9


def mcap_name(directory):
    """The bag's one file: <directory name>_0.mcap, as rosbag2 names it."""
    return os.path.basename(os.path.normpath(directory)) + "_0.mcap"


def write_metadata(directory, mcap_path):
    """Writes DIR/metadata.yaml describing the (closed, indexed) MCAP file."""
    with Recording(mcap_path) as rec:
        if rec.problem:
            raise BagError(rec.problem)
        topics = []
        for channel in sorted(rec.channels.values(), key=lambda c: c.topic):
            schema = rec.schema_of(channel)
            topics.append(
                {
                    "topic_metadata": {
                        "name": channel.topic,
                        "type": schema.name if schema else "",
                        "serialization_format": channel.message_encoding,
                        "offered_qos_profiles": yaml.safe_load(channel.metadata.get("offered_qos_profiles", "")) or [],
                        "type_description_hash": "",
                    },
                    "message_count": rec.counts.get(channel.id, 0),
                }
            )
        duration = max(0, rec.end_time - rec.start_time)
        relative = os.path.relpath(mcap_path, directory)
        information = {
            "version": VERSION,
            "storage_identifier": "mcap",
            "relative_file_paths": [relative],
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": rec.start_time},
            "message_count": rec.message_count,
            "topics_with_message_count": topics,
            "compression_format": "",
            "compression_mode": "",
            "files": [
                {
                    "path": relative,
                    "starting_time": {"nanoseconds_since_epoch": rec.start_time},
                    "duration": {"nanoseconds": duration},
                    "message_count": rec.message_count,
                }
            ],
            "custom_data": {"recorded_by": "ln_core ln record"},
            "ros_distro": "jazzy",
        }
    path = os.path.join(directory, METADATA)
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        yaml.safe_dump({"rosbag2_bagfile_information": information}, f, default_flow_style=False, sort_keys=False)
    os.replace(temporary, path)
    return path
