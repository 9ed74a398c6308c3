"""The bridge's YAML configuration: parsed and checked completely at start-up,
so a mistake is one clear message naming the file and the entry, never a
failure minutes later. See config/example.yaml for every key."""

import fnmatch
import os
import re
from dataclasses import dataclass, field, replace

import yaml
from msg_mapping.names import ln_name_for, ros_name_for


class ConfigError(Exception):
    pass


DIRECTIONS_TOPIC = ("ln_to_ros", "ros_to_ln", "both")
DIRECTIONS_SERVICE = ("ln_to_ros", "ros_to_ln")
RELIABILITY = ("reliable", "best_effort", "best_available")
DURABILITY = ("volatile", "transient_local", "best_available")
HISTORY = ("keep_last", "keep_all")
QOS_PRESETS = {
    "default": {"reliability": "reliable", "durability": "volatile", "depth": 10, "history": "keep_last"},
    "sensor_data": {"reliability": "best_effort", "durability": "volatile", "depth": 5, "history": "keep_last"},
    # state that late joiners must still get (the /tf_static pattern)
    "latched": {"reliability": "reliable", "durability": "transient_local", "depth": 1, "history": "keep_last"},
}


@dataclass(frozen=True)
class Qos:
    """ROS's default profile. Automatic ROS->LN subscriptions use best_available instead
    (they are made when the publishers are known, so it resolves to what they offer);
    explicit ones are made before any publisher exists, when best_available would settle
    on reliable + transient_local and then miss volatile publishers: configure
    best_effort (sensor_data) for best-effort publishers, transient_local for latched topics."""

    reliability: str = "reliable"
    durability: str = "volatile"
    depth: int = 10
    history: str = "keep_last"


@dataclass(frozen=True)
class LnPortSettings:
    buffers: int = 4  # LN ring slots: room for bursts while the bridge is busy
    rate: float = -1.0  # LN subscription rate: -1 every packet, > 0 packets per second
    reliable_transport: bool = False


@dataclass(frozen=True)
class TopicEntry:
    ln: str
    ros: str
    direction: str
    ln_type: str | None = None  # LN message definition; None: the topic's own (LN side)
    ros_type: str | None = None  # ROS type; None: derived from the LN definition
    qos: Qos = Qos()
    ln_port: LnPortSettings = LnPortSettings()
    origin: str = "config"  # "config" or "auto"


@dataclass(frozen=True)
class ServiceEntry:
    ln: str
    ros: str
    direction: str
    ln_type: str | None = None  # LN service definition; None: the provider's (LN side)
    ros_type: str | None = None
    timeout: float = 5.0
    origin: str = "config"


@dataclass(frozen=True)
class Filter:
    allow: tuple = ("*",)
    deny: tuple = ()

    def accepts(self, name):
        return any(fnmatch.fnmatchcase(name, p) for p in self.allow) and not any(
            fnmatch.fnmatchcase(name, p) for p in self.deny
        )


@dataclass(frozen=True)
class RemapRule:
    ln_prefix: str
    ros_prefix: str


@dataclass(frozen=True)
class AutoSettings:
    enabled: bool = False
    period: float = 2.0
    topics: Filter = Filter()
    services: Filter = Filter()
    directions: tuple = ("ln_to_ros", "ros_to_ln")
    ros_namespace: str = ""  # prefix for every auto-bridged ROS name
    remap: tuple = ()  # RemapRule, first match wins; else a.b.c <-> /a/b/c


# What is never bridged automatically: LN's own hidden services and ROS's
# per-node infrastructure. Explicit entries can still name them.
BUILTIN_DENY_LN = (
    "*.request_topic",
    "*.get_parameter*",
    "*.set_parameter*",
    "*.log_service*",
    "ln.*",
    "ln2.*",
    "ln_ros2_bridge_claims.*",
)
BUILTIN_DENY_ROS = (
    "/rosout",
    "/parameter_events",
    "*/describe_parameters",
    "*/get_parameters",
    "*/get_parameter_types",
    "*/list_parameters",
    "*/set_parameters",
    "*/set_parameters_atomically",
    "*/get_type_description",
    "*/_action/*",
)


@dataclass
class Config:
    source: str = "<defaults>"
    ln_manager: str | None = None
    ln_client_name: str = "ln_ros2_bridge"
    ln_definition_dirs: tuple = ()
    ros_node_name: str = "ln_ros2_bridge"
    ros_namespace: str = ""
    rule_files: tuple = ()
    string_capacity: int = 255  # LN capacities in definitions derived from ROS types (see types.RosCapacities)
    sequence_capacity: int = 64
    capacities: dict = field(default_factory=dict)  # "pkg/msg/Type.field[[]]" -> capacity
    qos: Qos = Qos()
    ln_port: LnPortSettings = LnPortSettings()
    service_timeout: float = 5.0
    bridge_names: tuple = ("ln_ros2_bridge*",)
    topics: list = field(default_factory=list)
    services: list = field(default_factory=list)
    auto: AutoSettings = AutoSettings()
    executor_threads: int = 4

    def is_bridge_name(self, name):
        """True for LN client names and ROS node names of bridges (ours or others)."""
        name = name.lstrip("/").rsplit("/", 1)[-1]
        return any(fnmatch.fnmatchcase(name, p) for p in self.bridge_names)


# ---------------------------------------------------------------------------------------------
# names
_ROS_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def ros_name_problem(name):
    """Why `name` is not a valid ROS topic/service name, or None."""
    if not name:
        return "empty name"
    if len(name) > 247:
        return "longer than 247 characters"
    body = name[1:] if name.startswith(("/", "~")) else name
    if name.startswith("~/"):
        body = name[2:]
    if name.endswith("/"):
        return "ends with '/'"
    for token in body.split("/"):
        if not token:
            return "contains '//'"
        if not _ROS_TOKEN.fullmatch(token):
            return "token %r must be letters, digits and '_' and must not start with a digit" % token
    return None


def ln_to_ros_name(ln_name, auto):
    """LN topic/service name -> ROS name: remap rules first, else a.b.c -> /a/b/c.
    Characters ROS does not allow become '_' (a leading digit gets 'ln_')."""
    for rule in auto.remap:
        if ln_name.startswith(rule.ln_prefix):
            rest = ln_name[len(rule.ln_prefix) :]
            name = ros_name_for(rest, rule.ros_prefix)
            break
    else:
        name = ros_name_for(ln_name)
    if auto.ros_namespace:
        name = auto.ros_namespace.rstrip("/") + name
    return name


def ros_to_ln_name(ros_name, auto):
    """ROS name -> LN name: the inverse of ln_to_ros_name for names it produced."""
    name = ros_name
    if auto.ros_namespace and name.startswith(auto.ros_namespace.rstrip("/") + "/"):
        name = name[len(auto.ros_namespace.rstrip("/")) :]
    for rule in auto.remap:
        prefix = rule.ros_prefix.rstrip("/") + "/"
        if name.startswith(prefix):
            return rule.ln_prefix + ln_name_for(name[len(prefix) :])
    return ln_name_for(name)


# ---------------------------------------------------------------------------------------------
# parsing
class _Reader:
    """Checks one YAML mapping: known keys only, typed values, messages with the path."""

    def __init__(self, data, where, source):
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise ConfigError("%s: %s must be a mapping, not %s" % (source, where, type(data).__name__))
        self.data = data
        self.where = where
        self.source = source
        self.used = set()

    def fail(self, message):
        raise ConfigError("%s: %s: %s" % (self.source, self.where, message))

    def get(self, key, kind, default=None, choices=None, check=None):
        self.used.add(key)
        if key not in self.data or self.data[key] is None:
            return default
        value = self.data[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if kind is int and isinstance(value, bool):
            self.fail("'%s' must be an integer, not %r" % (key, value))
        if kind is tuple:
            if isinstance(value, str):
                value = [value]
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                self.fail("'%s' must be a list of strings, not %r" % (key, value))
            value = tuple(value)
        elif not isinstance(value, kind):
            self.fail(
                "'%s' must be %s, not %r"
                % (
                    key,
                    {
                        str: "a string",
                        int: "an integer",
                        float: "a number",
                        bool: "true or false",
                        dict: "a mapping",
                        list: "a list",
                    }[kind],
                    value,
                )
            )
        if choices is not None and value not in choices:
            self.fail("'%s' must be one of %s, not %r" % (key, ", ".join(choices), value))
        if check is not None:
            problem = check(value)
            if problem:
                self.fail("'%s': %s" % (key, problem))
        return value

    def sub(self, key):
        self.used.add(key)
        return _Reader(self.data.get(key), "%s.%s" % (self.where, key) if self.where else key, self.source)

    def done(self):
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            self.fail("unknown key(s) %s; known: %s" % (", ".join(map(str, unknown)), ", ".join(sorted(self.used))))


def _positive(v):
    return None if v > 0 else "must be > 0"


def _qos(reader, base):
    preset = reader.get("preset", str, choices=tuple(QOS_PRESETS))
    values = dict(QOS_PRESETS[preset]) if preset else dict(base.__dict__)
    values["reliability"] = reader.get("reliability", str, values["reliability"], RELIABILITY)
    values["durability"] = reader.get("durability", str, values["durability"], DURABILITY)
    values["history"] = reader.get("history", str, values["history"], HISTORY)
    values["depth"] = reader.get(
        "depth", int, values["depth"], check=lambda v: None if 0 < v <= 100000 else "must be 1..100000"
    )
    reader.done()
    return Qos(**values)


def _qos_value(parent, key, base):
    """qos: a preset name or a mapping."""
    value = parent.data.get(key)
    if isinstance(value, str):
        parent.used.add(key)
        if value not in QOS_PRESETS:
            parent.fail("'%s' preset must be one of %s, not %r" % (key, ", ".join(QOS_PRESETS), value))
        return Qos(**QOS_PRESETS[value])
    return _qos(parent.sub(key), base)


def _ln_port(reader, base):
    settings = LnPortSettings(
        buffers=reader.get(
            "buffers", int, base.buffers, check=lambda v: None if 1 <= v <= 65536 else "must be 1..65536"
        ),
        rate=reader.get(
            "rate", float, base.rate, check=lambda v: None if v == -1 or v > 0 else "must be -1 (every packet) or > 0"
        ),
        reliable_transport=reader.get("reliable_transport", bool, base.reliable_transport),
    )
    reader.done()
    return settings


def _ln_name_problem(name):
    if not name or any(c.isspace() for c in name):
        return "must be a non-empty LN name without spaces"
    return None


def _ros_name_check(name):
    problem = ros_name_problem(name)
    return None if problem is None else "invalid ROS name %r: %s" % (name, problem)


def _type_check(kind):
    def check(value):
        parts = value.split("/")
        if len(parts) != 3 or parts[1] != kind or not all(parts):
            return "must look like 'package/%s/Type', not %r" % (kind, value)
        return None

    return check


# A ROS type name: package/msg/Type or package/srv/Type, the type CamelCase (LN definition
# names are lower case by convention, so `type:` can take either).
ROS_TYPE_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*/(msg|srv)/[A-Z][A-Za-z0-9_]*$")
_CAPACITY_KEY = re.compile(r"^(?:[A-Za-z][A-Za-z0-9_]*/msg/[A-Za-z][A-Za-z0-9_]*\.)?[A-Za-z][A-Za-z0-9_]*(\[\])?$")
MAX_CAPACITY = 1 << 24


def _capacity_check(v):
    return None if 1 <= v <= MAX_CAPACITY else "must be 1..%d" % MAX_CAPACITY


def _claim_names(r, seen, kind, entry):
    """Refuses an entry whose LN or ROS name an earlier entry of this kind bridges already."""
    for key in ((kind + "-ln", entry.ln), (kind + "-ros", entry.ros)):
        if key in seen:
            r.fail("%s is bridged twice (also by %s)" % (key[1], seen[key]))
        seen[key] = r.where


def _common_fields(r, config, what, kind, directions):
    """The fields topic and service entries share: 'ln' (required), 'ros' (default: the name
    automatic mode would give it), 'direction', and the types."""
    ln_name = r.get("ln", str, check=_ln_name_problem)
    if ln_name is None:
        r.fail("needs 'ln' (the LN %s name)" % what)
    r.where = "%s %s" % (what, ln_name)
    ln_type, ros_type = _types_of(r, kind)
    derived = ln_to_ros_name(ln_name, AutoSettings(ros_namespace=config.auto.ros_namespace, remap=config.auto.remap))
    return {
        "ln": ln_name,
        "ros": r.get("ros", str, derived, check=_ros_name_check),
        "direction": r.get("direction", str, "ln_to_ros", directions),
        "ln_type": ln_type,
        "ros_type": ros_type,
    }


def _types_of(r, kind):
    """(ln_type, ros_type) of an entry: `type` names an LN definition or a ROS type,
    `ros_type` a ROS type."""
    ln_type = r.get("type", str)
    ros_type = r.get("ros_type", str, check=_type_check(kind))
    match = ROS_TYPE_NAME.match(ln_type or "")
    if match:
        if match.group(1) != kind:
            r.fail(
                "'type' %r is a ROS %s type; a %s needs a %s type (package/%s/Type)"
                % (
                    ln_type,
                    "service" if match.group(1) == "srv" else "message",
                    "topic" if kind == "msg" else "service",
                    "message" if kind == "msg" else "service",
                    kind,
                )
            )
        if ros_type and ros_type != ln_type:
            r.fail("'type' %r and 'ros_type' %r name two ROS types" % (ln_type, ros_type))
        return None, ln_type
    return ln_type, ros_type


def _merge_capacities(r, ros_type, config, owners):
    """Merges `capacities` of an entry or of `defaults` (field -> capacity; keys
    "package/msg/Type.field", or in an entry relative to its ROS type) into
    config.capacities: one LN definition per ROS type, so two entries may not ask
    for different capacities of one field."""
    raw = r.get("capacities", dict, {})
    for key, value in raw.items():
        if not isinstance(key, str) or not _CAPACITY_KEY.match(key):
            r.fail(
                "'capacities' key %r must be a field ('name', 'name[]' for each string of a string array) "
                "or 'package/msg/Type.field'" % (key,)
            )
        if "/" not in key and not ros_type:
            r.fail(
                "'capacities' key %r must name the ROS type: 'package/msg/Type.%s'%s"
                % (key, key, "" if r.where == "defaults" else " (or give the entry a ROS type)")
            )
        if isinstance(value, bool) or not isinstance(value, int) or _capacity_check(value):
            r.fail("'capacities' %s must be an integer 1..%d, not %r" % (key, MAX_CAPACITY, value))
        full = key if "/" in key else "%s.%s" % (ros_type, key)
        if full in config.capacities and config.capacities[full] != value:
            r.fail(
                "capacity of %s is %d here but %d in %s (one LN definition per ROS type)"
                % (full, value, config.capacities[full], owners[full])
            )
        config.capacities[full] = value
        owners[full] = r.where


def parse_config(data, source="<config>"):
    """Config from parsed YAML (a dict). Raises ConfigError."""
    top = _Reader(data, "", source)
    config = Config(source=source)

    ln = top.sub("ln")
    config.ln_manager = ln.get(
        "manager", str, os.environ.get("LN_MANAGER") or None, check=lambda v: None if ":" in v else "must be HOST:PORT"
    )
    config.ln_client_name = ln.get("client_name", str, config.ln_client_name, check=_ln_name_problem)
    config.ln_definition_dirs = tuple(os.path.expanduser(d) for d in ln.get("message_definition_dirs", tuple, ()))
    ln.done()

    ros = top.sub("ros")
    config.ros_node_name = ros.get(
        "node_name",
        str,
        config.ros_node_name,
        check=lambda v: None if _ROS_TOKEN.fullmatch(v) else "must be a valid node name",
    )
    config.ros_namespace = ros.get("namespace", str, "")
    config.executor_threads = ros.get(
        "executor_threads", int, 4, check=lambda v: None if 1 <= v <= 64 else "must be 1..64"
    )
    ros.done()

    config.rule_files = top.get("rules", tuple, ())
    base_dir = os.path.dirname(os.path.abspath(source)) if os.path.exists(source) else os.getcwd()
    config.rule_files = tuple(os.path.join(base_dir, os.path.expanduser(f)) for f in config.rule_files)
    for f in config.rule_files:
        if not os.path.isfile(f):
            top.fail("rule file %s does not exist" % f)

    defaults = top.sub("defaults")
    config.qos = _qos_value(defaults, "qos", Qos())
    config.ln_port = _ln_port(defaults.sub("ln"), LnPortSettings())
    config.service_timeout = defaults.get("service_timeout", float, 5.0, check=_positive)
    config.string_capacity = defaults.get("string_capacity", int, 255, check=_capacity_check)
    config.sequence_capacity = defaults.get("sequence_capacity", int, 64, check=_capacity_check)
    owners = {}
    _merge_capacities(defaults, None, config, owners)
    defaults.done()

    loops = top.sub("loop_prevention")
    config.bridge_names = loops.get("bridge_names", tuple, config.bridge_names)
    loops.done()
    if not config.is_bridge_name(config.ln_client_name) or not config.is_bridge_name(config.ros_node_name):
        top.fail(
            "ln.client_name %r and ros.node_name %r must match loop_prevention.bridge_names %s, "
            "or other bridges (and this one) would re-bridge what this bridge publishes"
            % (config.ln_client_name, config.ros_node_name, list(config.bridge_names))
        )

    auto = top.sub("auto")
    remap = []
    for i, rule in enumerate(auto.get("remap", list, []) or []):
        r = _Reader(rule, "auto.remap[%d]" % i, source)
        ln_prefix = r.get("ln", str)
        ros_prefix = r.get("ros", str, check=lambda v: None if v.startswith("/") else "must start with '/'")
        r.done()
        if ln_prefix is None or ros_prefix is None:
            r.fail("needs 'ln' (an LN name prefix such as 'robot1.') and 'ros' (such as '/robot1/')")
        remap.append(RemapRule(ln_prefix, ros_prefix))

    def filter_of(key):
        f = auto.sub(key)
        result = Filter(f.get("allow", tuple, ("*",)), f.get("deny", tuple, ()))
        f.done()
        return result

    directions = auto.get("directions", tuple, ("ln_to_ros", "ros_to_ln"))
    for d in directions:
        if d not in DIRECTIONS_SERVICE:
            auto.fail("'directions' entries must be ln_to_ros or ros_to_ln, not %r" % d)
    config.auto = AutoSettings(
        enabled=auto.get("enabled", bool, False),
        period=auto.get("period", float, 2.0, check=lambda v: None if 0.05 <= v <= 3600 else "must be 0.05..3600 s"),
        topics=filter_of("topics"),
        services=filter_of("services"),
        directions=directions,
        ros_namespace=auto.get(
            "ros_namespace",
            str,
            "",
            check=lambda v: (
                None if not v or ros_name_problem(v) is None else "invalid ROS namespace: %s" % ros_name_problem(v)
            ),
        ),
        remap=tuple(remap),
    )
    auto.done()

    seen = {}
    for i, raw in enumerate(top.get("topics", list, []) or []):
        r = _Reader(raw, "topics[%d]" % i, source)
        common = _common_fields(r, config, "topic", "msg", DIRECTIONS_TOPIC)
        _merge_capacities(r, common["ros_type"], config, owners)
        entry = TopicEntry(
            **common,
            qos=_qos_value(r, "qos", config.qos),
            ln_port=_ln_port(r.sub("ln_port"), config.ln_port),
        )
        r.done()
        if entry.direction in ("ros_to_ln", "both") and not (entry.ln_type or entry.ros_type):
            r.fail(
                "direction %s needs 'type' (the LN definition) or 'ros_type': an LN topic can only be "
                "published with a known definition" % entry.direction
            )
        _claim_names(r, seen, "topic", entry)
        config.topics.append(entry)

    for i, raw in enumerate(top.get("services", list, []) or []):
        r = _Reader(raw, "services[%d]" % i, source)
        entry = ServiceEntry(
            **_common_fields(r, config, "service", "srv", DIRECTIONS_SERVICE),
            timeout=r.get("timeout", float, config.service_timeout, check=_positive),
        )
        r.done()
        if entry.direction == "ros_to_ln" and not (entry.ln_type or entry.ros_type):
            r.fail("direction ros_to_ln needs 'type' (the LN service definition) or 'ros_type'")
        _claim_names(r, seen, "service", entry)
        config.services.append(entry)

    top.done()
    if not config.topics and not config.services and not config.auto.enabled:
        top.fail("nothing to bridge: give 'topics', 'services' or 'auto: {enabled: true}'")
    return config


def load_config(path):
    """Config from a YAML file. Raises ConfigError."""
    try:
        with open(path, encoding="utf-8") as f:
            data = yaml.safe_load(f)
    except OSError as error:
        raise ConfigError("cannot read the configuration %s: %s" % (path, error)) from error
    except yaml.YAMLError as error:
        raise ConfigError("%s is not valid YAML: %s" % (path, error)) from error
    return parse_config(data, path)


def with_overrides(config, **changes):
    """A copy with some top-level settings changed (command-line overrides)."""
    return replace(config, **{k: v for k, v in changes.items() if v is not None})
