"""Rule files: LN definitions mapped onto existing ROS types (see README, "Rules").

    mappings:
      - ln: robot/tcp_pose
        ros: geometry_msgs/msg/PoseStamped
        fields:
          header.stamp: {from: time, convert: seconds_to_time}
          header.frame_id: {value: map}
          pose.position.x: {from: "pos_mm[0]", scale: 0.001}
          pose.orientation.w: quat[3]          # short form of {from: quat[3]}

The checks that matter (fields exist, types fit) happen in C++ when the rule
is compiled (compile_rules); this module only reads and shapes the YAML.
"""

import yaml

from ._native import MappingError, compile_rule

_FIELD_KEYS = {"from", "value", "scale", "offset", "convert", "lossy"}


def _text(value):
    """YAML scalars as the C++ side takes them: numbers without float noise, booleans as true/false."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def load_rules(path):
    """Reads a rule file; returns [{"ln", "ros", "fields": [{"ros", "from"|"value", ...}]}]. Raises MappingError."""
    try:
        with open(path, encoding="utf-8") as f:
            document = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as e:
        raise MappingError(f"{path}: cannot read the rule file: {e}") from e
    if document is None:
        return []
    entries = document.get("mappings") if isinstance(document, dict) else document
    if not isinstance(entries, list):
        raise MappingError(f"{path}: expected a list under 'mappings'")
    rules = []
    for number, entry in enumerate(entries, 1):
        where = f"{path}: mapping {number}"
        if not isinstance(entry, dict) or "ln" not in entry or "ros" not in entry:
            raise MappingError(f"{where}: needs 'ln' (an LN definition) and 'ros' (a ROS message type)")
        where = f"{path}: mapping {entry['ln']} -> {entry['ros']}"
        unknown = set(entry) - {"ln", "ros", "fields"}
        if unknown:
            raise MappingError(f"{where}: unknown key(s) {sorted(unknown)}")
        fields = []
        for ros_path, spec in (entry.get("fields") or {}).items():
            if not isinstance(spec, dict):
                spec = {"from": spec}
            unknown = set(spec) - _FIELD_KEYS
            if unknown:
                raise MappingError(f"{where}, field {ros_path}: unknown key(s) {sorted(unknown)}")
            fields.append({"ros": str(ros_path), **{k: _text(v) for k, v in spec.items()}})
        rules.append({"ln": str(entry["ln"]), "ros": str(entry["ros"]), "fields": fields})
    return rules


def compile_rules(rules, library, ros):
    """RuleCodec per rule (validated against the LN library and the ROS types). Raises MappingError."""
    return [compile_rule(library, ros, r["ln"], r["ros"], r["fields"]) for r in rules]
