"""msg_mapping: LN <-> ROS 2 interface mapping and LN <-> CDR codecs.

The mapping and the codecs are C++ (msg_mapping._native, built on ln_core's
message-definition model); this package adds the file handling, the rule
files and the ln_ros2_gen command line.

    from msg_mapping import Library, LnToRos
    lib = Library(["/path/to/message_definitions"])
    gen = LnToRos()
    gen.add(lib, "tests/counters")
    codec = gen.codec("tests/counters")        # services: part="request"/"response"
    cdr = codec.ln_to_cdr(ln_packet_bytes)     # == rclpy serialize_message(...)
    ln = codec.cdr_to_ln(cdr)

Codec input is any buffer (bytes, bytearray, memoryview, numpy); the `*_into`
variants write into a preallocated writable buffer and return the size.
"""

import os

from ._native import (
    Codec,
    CodecError,
    DefinitionError,
    Library,
    LnToRos,
    MappingError,
    RosToLn,
    RuleCodec,
    camel_to_snake,
    definition_names_under,
    ros_field_name_for,
    ros_type_name_for,
)

__all__ = [
    "Codec",
    "CodecError",
    "DefinitionError",
    "Library",
    "LnToRos",
    "MappingError",
    "RosToLn",
    "RuleCodec",
    "camel_to_snake",
    "definition_names_under",
    "ros_field_name_for",
    "ros_share_dirs",
    "ros_type_name_for",
]


def ros_share_dirs(environ=None):
    """The share/ directories of every prefix on AMENT_PREFIX_PATH (where .msg/.srv files are)."""
    environ = os.environ if environ is None else environ
    dirs = []
    for prefix in environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        share = os.path.join(prefix, "share")
        if prefix and os.path.isdir(share) and share not in dirs:
            dirs.append(share)
    if not dirs and os.environ.get("VIRTUAL_ENV"):
        share = os.path.join(os.environ["VIRTUAL_ENV"], "share")
        if os.path.isdir(share):
            dirs.append(share)
    return dirs
