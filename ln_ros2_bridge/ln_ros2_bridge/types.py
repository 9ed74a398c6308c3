"""Which ROS type carries an LN definition, and the codec between them.

Three ways a type is carried (msg_mapping provides all of them):

1. generated interfaces: `ln_ros2_gen` made a ROS package for an LN
   definition; its share/<pkg>/ln_mapping.json (found on AMENT_PREFIX_PATH)
   names the ROS type and the LN hash it was generated from. The codec comes
   from LnToRos;
2. rules: a msg_mapping rule file maps an LN definition onto a standard ROS
   message (RuleCodec);
3. derived: any installed ROS type (geometry_msgs/msg/Twist, std_srvs/srv/Trigger,
   ...) gets the LN definition msg_mapping's RosToLn derives from it --
   ros2/<pkg>/msg/<Type>, fixed-size for topics with capacities for strings and
   sequences (ros_capacities), ros2/<pkg>/srv/<Type> for services -- and the
   bridge gives the LN manager that definition (`definitions`), so LN programs
   can use the topic or service with nothing generated.

A type is only bridged when the installed interface was generated from, or
derives, the same definition the LN side uses (same hash); otherwise the
message bytes would be misread, so it is reported instead.
"""

import glob
import importlib
import json
import logging
import os
import re
import threading
import time
from dataclasses import dataclass, field

from msg_mapping.manager import load_fetching
from msg_mapping.rules import compile_rules, load_rules

import msg_mapping

log = logging.getLogger("ln_ros2_bridge.types")


class UnknownType(Exception):
    """No usable ROS type for an LN definition (or the reverse); the entry is skipped."""


@dataclass
class TopicType:
    ln_name: str
    ros_type: str
    msg_class: type
    codec: object  # msg_mapping Codec or RuleCodec: ln_to_cdr(buf), cdr_to_ln(buf)
    ln_size: int
    via: str  # "generated", "rule" or "derived"
    definitions: tuple = ()  # derived: ((LN name, text, hash), ...) the LN manager must know, used ones first

    def cdr_to_ln_into(self, cdr, out):
        into = getattr(self.codec, "cdr_to_ln_into", None)
        if into is not None:
            return into(cdr, out)
        data = self.codec.cdr_to_ln(cdr)
        out[: len(data)] = data
        return len(data)


@dataclass
class ServiceType:
    ln_name: str
    ros_type: str
    srv_class: type
    request: object  # Codec for the request (LN flat <-> CDR)
    response: object  # Codec for the response
    via: str = "generated"
    definitions: tuple = ()


@dataclass(frozen=True)
class RosCapacities:
    """LN capacities of unbounded strings and sequences in definitions derived from
    ROS types: defaults, and per field "pkg/msg/Type.field" (elements, or bytes of a
    string) / "pkg/msg/Type.field[]" (bytes of each string of a string array)."""

    string: int = 255
    sequence: int = 64
    fields: dict = field(default_factory=dict)


DERIVED_PREFIX = "ros2"
_DERIVED_NAME = re.compile(r"^%s/([A-Za-z]\w*)/(msg|srv)/([A-Za-z]\w*)$" % DERIVED_PREFIX)
_DEFINE = re.compile(r'^\s*define\s+\w+\s+as\s+"([^"]+)"', re.MULTILINE)


def _import_ros_type(ros_type):
    """The rclpy class of "pkg/msg/Type" or "pkg/srv/Type"."""
    package, kind, name = ros_type.split("/")
    try:
        cls = getattr(importlib.import_module("%s.%s" % (package, kind)), name)
        # Loads the C type support now, so a package that is only half there fails here.
        cls.__class__.__import_type_support__()
        return cls
    except (ImportError, AttributeError) as error:
        raise UnknownType(
            "ROS type %s cannot be imported (%s): is its package built and sourced?" % (ros_type, error)
        ) from error


class TypeRegistry:
    """Resolves LN definitions <-> ROS types; thread-safe; caches what it found."""

    def __init__(
        self, definition_dirs=(), rule_files=(), share_dirs=None, fetch_definition=None, capacities=RosCapacities()
    ):
        self._lock = threading.RLock()
        self._capacities = capacities
        self._derived = None  # msg_mapping.RosToLn, made at first use
        self._unmapped = {}  # ROS type -> why it has no LN counterpart
        self._fetch_definition = fetch_definition  # name -> None; adds a dir or text (from the LN manager)
        self._fetched = set()
        self._dirs = list(definition_dirs)
        self._sources = {}  # LN name -> definition text (from the manager)
        self._share_dirs = share_dirs
        self._rule_files = list(rule_files)
        self._library = None
        self._generator = None
        self._rules = {}  # LN name -> [RuleCodec]
        self._index = {}  # LN name -> ln_mapping.json entry (+ "package")
        self._by_ros = {}  # ROS type -> LN name
        self._indexed_at = 0.0
        self._topic_cache = {}
        self._service_cache = {}
        self._rebuild_library()
        self.rescan(force=True)
        if self._rule_files:
            self._load_rules()

    # -- LN definitions -------------------------------------------------------
    def _rebuild_library(self):
        self._library = msg_mapping.Library(self._dirs, True)
        for name, text in self._sources.items():
            self._library.add_source(name, text)
        self._generator = msg_mapping.LnToRos()
        self._topic_cache.clear()
        self._service_cache.clear()

    def add_definition_dir(self, directory):
        with self._lock:
            if directory and directory not in self._dirs and os.path.isdir(directory):
                self._dirs.append(directory)
                self._rebuild_library()
                log.info("LN definitions: also searching %s", directory)

    def add_definition_text(self, name, text):
        with self._lock:
            if self._sources.get(name) != text:
                self._sources[name] = text
                self._rebuild_library()

    def forget_fetched(self):
        with self._lock:
            self._fetched.clear()

    def _load(self, ln_name):
        """The definition's model; missing definitions (and what they import) are
        fetched from the LN manager first, each name at most once."""
        if self._fetch_definition is None:
            return self._library.load(ln_name)
        return load_fetching(lambda name: self._library.load(name), ln_name, self._fetch_definition, self._fetched)

    def ln_hash(self, ln_name):
        with self._lock:
            return self._load(ln_name)["hash"]

    def has_definition(self, ln_name):
        try:
            self.ln_hash(ln_name)
            return True
        except Exception:
            return False

    # -- generated interfaces -----------------------------------------------
    def rescan(self, force=False):
        """Re-reads every ln_mapping.json (at most every 2 s unless forced)."""
        with self._lock:
            if not force and time.monotonic() - self._indexed_at < 2.0:
                return
            self._indexed_at = time.monotonic()
            index, by_ros = {}, {}
            share_dirs = self._share_dirs if self._share_dirs is not None else msg_mapping.ros_share_dirs()
            for share in share_dirs:
                for path in sorted(glob.glob(os.path.join(share, "*", "ln_mapping.json"))):
                    try:
                        with open(path, encoding="utf-8") as f:
                            mapping = json.load(f)
                    except (OSError, ValueError) as error:
                        log.warning("ignoring unreadable %s: %s", path, error)
                        continue
                    for entry in mapping.get("interfaces", []):
                        if entry.get("ln_name") and entry["ln_name"] not in index:
                            index[entry["ln_name"]] = dict(entry, package=mapping.get("package", ""), path=path)
                            by_ros[entry["ros_type"]] = entry["ln_name"]
            self._index, self._by_ros = index, by_ros

    def _derivation(self):
        """The RosToLn that derives LN definitions from ROS types (with the capacities)."""
        if self._derived is None:
            caps = self._capacities
            self._derived = msg_mapping.RosToLn(
                msg_mapping.ros_share_dirs(), DERIVED_PREFIX, caps.string, caps.sequence, dict(caps.fields)
            )
        return self._derived

    def _load_rules(self):
        ros = self._derivation()  # rules go through the ROS type's fixed LN form: same capacities
        for path in self._rule_files:
            try:
                for codec in compile_rules(load_rules(path), self._library, ros):
                    self._rules.setdefault(codec.ln_name, []).append(codec)
                    self._by_ros.setdefault(codec.ros_name, codec.ln_name)
            except msg_mapping.MappingError as error:
                raise UnknownType(str(error)) from error

    def ln_name_for_ros(self, ros_type):
        """The LN definition a ROS type was generated from, is rule-mapped to, or derives
        (any installed type); None when it has none (see why_unmapped)."""
        with self._lock:
            if ros_type not in self._by_ros:
                self.rescan()
            if ros_type in self._by_ros:
                return self._by_ros[ros_type]
            try:
                return self._derive(ros_type)[0]["ln_name"]
            except UnknownType as error:
                self._unmapped[ros_type] = str(error)
                return None

    def why_unmapped(self, ros_type):
        return self._unmapped.get(ros_type, "ROS type %s has no LN counterpart" % ros_type)

    # -- derived from ROS types --------------------------------------------------
    @staticmethod
    def derived_ros_type(ln_name):
        """ "pkg/msg/Type" when `ln_name` has the form of a definition derived from it."""
        match = _DERIVED_NAME.match(ln_name or "")
        return "%s/%s/%s" % match.groups() if match else None

    def _derive(self, ros_type):
        """(RosToLn's interface dict, the definitions it needs). Raises UnknownType."""
        ros = self._derivation()
        try:
            info = ros.add(ros_type)
        except (msg_mapping.MappingError, msg_mapping.DefinitionError) as error:
            raise UnknownType("ROS type %s cannot be mapped to LN: %s" % (ros_type, _one_line(error))) from error
        return info, self._definitions(info["ln_name"], ros.definitions())

    @staticmethod
    def _definitions(ln_name, texts):
        """((name, text, hash), ...) of `ln_name` and every definition it uses, used ones first."""
        order, seen = [], set()

        def visit(name):
            if name in seen or name not in texts:
                return
            seen.add(name)
            for used in _DEFINE.findall(texts[name]):
                visit(used)
            order.append(name)

        visit(ln_name)
        library = msg_mapping.Library([], False)
        for name in order:
            library.add_source(name, texts[name])
        return tuple((name, texts[name], library.load(name)["hash"]) for name in order)

    def _check_derived(self, ln_name, ros_type, requested_ros_type, info):
        if requested_ros_type is not None and requested_ros_type != ros_type:
            raise UnknownType(
                "LN definition %s is derived from the ROS type %s, not %s" % (ln_name, ros_type, requested_ros_type)
            )
        if info["ln_name"] != ln_name:
            raise UnknownType("ROS type %s derives the LN definition %s, not %s" % (ros_type, info["ln_name"], ln_name))

    def _derived_topic(self, ln_name, ros_type, requested_ros_type):
        info, definitions = self._derive(ros_type)
        self._check_derived(ln_name, ros_type, requested_ros_type, info)
        if info["kind"] != "message":
            raise UnknownType("%s is a ROS service type, a topic needs a message type" % ros_type)
        codec = self._derivation().codec(ros_type)
        return TopicType(
            ln_name, ros_type, _import_ros_type(ros_type), codec, codec.fixed_ln_size, "derived", definitions
        )

    def _derived_service(self, ln_name, ros_type, requested_ros_type):
        info, definitions = self._derive(ros_type)
        self._check_derived(ln_name, ros_type, requested_ros_type, info)
        if info["kind"] != "service":
            raise UnknownType("%s is a ROS message type, a service needs a service type" % ros_type)
        ros = self._derivation()
        return ServiceType(
            ln_name,
            ros_type,
            _import_ros_type(ros_type),
            ros.codec(ros_type, False, "request"),
            ros.codec(ros_type, False, "response"),
            "derived",
            definitions,
        )

    # -- resolution ----------------------------------------------------------
    def topic_type(self, ln_name=None, ros_type=None):
        """The TopicType for an LN message definition and/or a ROS type. Raises UnknownType."""

        def make(ln_name, derived_from):
            for rule in self._rules.get(ln_name, []):
                if ros_type in (None, rule.ros_name):
                    return TopicType(
                        ln_name, rule.ros_name, _import_ros_type(rule.ros_name), rule, rule.ln_size, "rule"
                    )
            if derived_from is not None:
                return self._derived_topic(ln_name, derived_from, ros_type)
            entry = self._generated(ln_name, "message", ros_type)
            codec = self._codec(ln_name)
            return TopicType(
                ln_name, entry["ros_type"], _import_ros_type(entry["ros_type"]), codec, codec.fixed_ln_size, "generated"
            )

        return self._resolved(self._topic_cache, ln_name, ros_type, make)

    def service_type(self, ln_name=None, ros_type=None):
        """The ServiceType for an LN service definition and/or a ROS service type. Raises UnknownType."""

        def make(ln_name, derived_from):
            if derived_from is not None:
                return self._derived_service(ln_name, derived_from, ros_type)
            entry = self._generated(ln_name, "service", ros_type)
            return ServiceType(
                ln_name,
                entry["ros_type"],
                _import_ros_type(entry["ros_type"]),
                self._codec(ln_name, "request"),
                self._codec(ln_name, "response"),
            )

        return self._resolved(self._service_cache, ln_name, ros_type, make)

    def _resolved(self, cache, ln_name, ros_type, make):
        """cache[(ln_name, ros_type)], made once by make(ln_name, derived_from): derived_from is the
        ROS type an LN definition without a generated interface is derived from (else None). Without
        ln_name, the LN definition mapped to ros_type."""
        if ln_name is None:
            ln_name = self.ln_name_for_ros(ros_type)
            if ln_name is None:
                raise UnknownType(self.why_unmapped(ros_type))
        key = (ln_name, ros_type)
        with self._lock:
            if key not in cache:
                derived_from = self.derived_ros_type(ln_name) if ln_name not in self._index else None
                cache[key] = make(ln_name, derived_from)
            return cache[key]

    def _generated(self, ln_name, kind, ros_type):
        try:
            current = self.ln_hash(ln_name)
        except Exception as error:
            raise UnknownType("LN definition %s cannot be loaded: %s" % (ln_name, error)) from error
        entry = self._index.get(ln_name)
        if entry is None:
            self.rescan()
            entry = self._index.get(ln_name)
        if entry is None:
            raise UnknownType(
                "LN definition %s has no generated ROS interface on AMENT_PREFIX_PATH "
                "(make one with: ln_ros2_gen --md-dir DIR --out WS/src %s; colcon build)" % (ln_name, ln_name)
            )
        if entry.get("kind") != kind:
            raise UnknownType("LN definition %s is a %s, not a %s" % (ln_name, entry.get("kind"), kind))
        if ros_type is not None and ros_type != entry["ros_type"]:
            raise UnknownType("LN definition %s is generated as %s, not %s" % (ln_name, entry["ros_type"], ros_type))
        if entry.get("ln_hash") and entry["ln_hash"] != current:
            raise UnknownType(
                "ROS interface %s (in %s) was generated from another version of %s "
                "(hash %.12s, now %.12s): regenerate it with ln_ros2_gen and rebuild"
                % (entry["ros_type"], entry["path"], ln_name, entry["ln_hash"], current)
            )
        return entry

    def _codec(self, ln_name, part=""):
        try:
            self._load(ln_name)
            self._generator.add(self._library, ln_name)
            return self._generator.codec(ln_name, part)
        except UnknownType:
            raise
        except Exception as error:  # DefinitionError/MappingError (or LNError, see _load)
            raise UnknownType("no codec for LN definition %s: %s" % (ln_name, error)) from error


def _one_line(error):
    return " ".join(str(error).split())
