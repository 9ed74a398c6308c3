"""What a recording keeps per channel.

Topic: the ROS name of the LN topic (`a.b.c` -> `/a/b/c`, msg_mapping.names,
as the bridge names it). Schema: the ROS 2 type msg_mapping maps the LN
definition to (named as ln_ros2_gen names it) with its .msg text. Metadata:
everything about the LN side, so that a recording is replayed exactly even
where no ROS package and no LN definition file exists:

    ln.topic       the LN topic (or service) name
    ln.definition  the LN message definition (or service interface)
    ln.hash        its hash
    ln.text        its text
    ln.uses        JSON {name: text} of every definition it uses ("" if none)
    ln.publisher   the publishing client, when known
    ln.part        "request"/"response" for service calls (absent for topics)
    offered_qos_profiles  the QoS rosbag2 replays with (reliable, volatile, keep last 10)
"""

import json
import math

from msg_mapping.names import ros_name_for

from ._native import BagError, TopicMapping

TOPIC = "ln.topic"
DEFINITION = "ln.definition"
HASH = "ln.hash"
TEXT = "ln.text"
USES = "ln.uses"
PUBLISHER = "ln.publisher"
PART = "ln.part"

#: What rosbag2 (metadata version 9) writes for a reliable, volatile publisher
#: with ROS's default depth; durations "infinite" as rmw reports them.
OFFERED_QOS_PROFILES = """- history: keep_last
  depth: 10
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false"""


def ros_topic_for(ln_name, part=None):
    """The ROS name of an LN topic; a service's calls go to NAME/_request and NAME/_response."""
    name = ros_name_for(ln_name)
    return name + "/_" + part if part else name


def channel_metadata(ln_name, mapping, publisher=None, part=None):
    """The metadata of the channel recording `ln_name` with `mapping` (a TopicMapping)."""
    texts = dict(mapping.texts)
    main = texts.pop(mapping.ln_name)
    metadata = {
        TOPIC: ln_name,
        DEFINITION: mapping.ln_name,
        HASH: mapping.ln_hash,
        TEXT: main,
        USES: json.dumps(texts, sort_keys=True) if texts else "",
        "offered_qos_profiles": OFFERED_QOS_PROFILES,
    }
    if publisher:
        metadata[PUBLISHER] = publisher
    if part:
        metadata[PART] = part
    return metadata


def is_ln_channel(metadata):
    return TOPIC in metadata and DEFINITION in metadata and TEXT in metadata


def mapping_from_metadata(metadata, where):
    """The TopicMapping a channel was recorded with, from its metadata alone.
    `where` names the file and channel in errors."""
    texts = {}
    try:
        if metadata.get(USES):
            texts.update(json.loads(metadata[USES]))
    except (ValueError, TypeError) as error:
        raise BagError("%s: metadata '%s' is not JSON: %s" % (where, USES, error)) from None
    texts[metadata[DEFINITION]] = metadata[TEXT]
    try:
        mapping = TopicMapping(metadata[DEFINITION], texts, part=metadata.get(PART, ""))
    except BagError as error:
        raise BagError("%s: %s" % (where, error)) from None
    if metadata.get(HASH) and mapping.ln_hash != metadata[HASH]:
        raise BagError(
            "%s: the recorded text of '%s' has hash %s, but the channel says %s"
            % (where, metadata[DEFINITION], mapping.ln_hash, metadata[HASH])
        )
    return mapping


def ns_from_seconds(seconds):
    """LN's double seconds as MCAP nanoseconds, the nearest one (the whole seconds
    apart: one product with 1e9 would be off by up to 128 ns); 0 where there is none."""
    if not seconds > 0 or not math.isfinite(seconds) or seconds >= 1.8e10:
        return 0
    whole = math.floor(seconds)
    return whole * 10**9 + round((seconds - whole) * 1e9)


def seconds_from_ns(ns):
    """MCAP nanoseconds as LN's double seconds, the nearest double (so the LN
    timestamp a publish_time came from comes back exactly)."""
    whole, rest = divmod(ns, 10**9)
    return whole + rest / 1e9
