"""Which ROS type carries an LN definition, and the codec between them.

Three ways an LN definition reaches ROS (msg_mapping provides all of them):

1. generated interfaces: `ln_ros2_gen` made a ROS package for it; its
   share/<pkg>/ln_mapping.json (found on AMENT_PREFIX_PATH) names the ROS type
   and the LN hash it was generated from. The codec comes from LnToRos;
2. rules: a msg_mapping rule file maps it onto a standard ROS message
   (RuleCodec);
3. (ROS -> LN) a ROS type with neither is unknown: reported and skipped.

A type is only bridged when the installed interface was generated from the
same definition the LN side uses (same hash); otherwise the message bytes
would be misread, so it is reported as stale instead.
"""

import glob
import importlib
import json
import logging
import os
import threading
import time
from dataclasses import dataclass

import msg_mapping
from msg_mapping.manager import load_fetching
from msg_mapping.rules import compile_rules, load_rules

log = logging.getLogger("ln_ros2_bridge.types")


class UnknownType(Exception):
    """No usable ROS type for an LN definition (or the reverse); the entry is skipped."""


@dataclass
class TopicType:
    ln_name: str
    ros_type: str
    msg_class: type
    codec: object          # msg_mapping Codec or RuleCodec: ln_to_cdr(buf), cdr_to_ln(buf)
    ln_size: int
    via: str               # "generated" or "rule"

    def cdr_to_ln_into(self, cdr, out):
        into = getattr(self.codec, "cdr_to_ln_into", None)
        if into is not None:
            return into(cdr, out)
        data = self.codec.cdr_to_ln(cdr)
        out[:len(data)] = data
        return len(data)


@dataclass
class ServiceType:
    ln_name: str
    ros_type: str
    srv_class: type
    request: object        # Codec for the request (LN flat <-> CDR)
    response: object       # Codec for the response
    via: str = "generated"


def _import_ros_type(ros_type):
    """The rclpy class of "pkg/msg/Type" or "pkg/srv/Type"."""
    package, kind, name = ros_type.split("/")
    try:
        cls = getattr(importlib.import_module("%s.%s" % (package, kind)), name)
        # Loads the C type support now, so a package that is only half there fails here.
        cls.__class__.__import_type_support__()
        return cls
    except (ImportError, AttributeError) as error:
        raise UnknownType("ROS type %s cannot be imported (%s): is its package built and sourced?"
                          % (ros_type, error)) from error


class TypeRegistry:
    """Resolves LN definitions <-> ROS types; thread-safe; caches what it found."""

    def __init__(self, definition_dirs=(), rule_files=(), share_dirs=None, fetch_definition=None):
        self._lock = threading.RLock()
        self._fetch_definition = fetch_definition   # name -> None; adds a dir or text (from the LN manager)
        self._fetched = set()
        self._dirs = list(definition_dirs)
        self._sources = {}                 # LN name -> definition text (from the manager)
        self._share_dirs = share_dirs
        self._rule_files = list(rule_files)
        self._library = None
        self._generator = None
        self._rules = {}                   # LN name -> [RuleCodec]
        self._index = {}                   # LN name -> ln_mapping.json entry (+ "package")
        self._by_ros = {}                  # ROS type -> LN name
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
        return load_fetching(lambda name: self._library.load(name), ln_name, self._fetch_definition,
                             self._fetched)

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

    def _load_rules(self):
        ros = msg_mapping.RosToLn(msg_mapping.ros_share_dirs())
        for path in self._rule_files:
            try:
                for codec in compile_rules(load_rules(path), self._library, ros):
                    self._rules.setdefault(codec.ln_name, []).append(codec)
                    self._by_ros.setdefault(codec.ros_name, codec.ln_name)
            except msg_mapping.MappingError as error:
                raise UnknownType(str(error)) from error

    def ln_name_for_ros(self, ros_type):
        """The LN definition a ROS type was generated from (or is rule-mapped to), or None."""
        with self._lock:
            if ros_type not in self._by_ros:
                self.rescan()
            return self._by_ros.get(ros_type)

    # -- resolution ----------------------------------------------------------
    def topic_type(self, ln_name=None, ros_type=None):
        """The TopicType for an LN message definition and/or a ROS type. Raises UnknownType."""
        if ln_name is None:
            ln_name = self.ln_name_for_ros(ros_type)
            if ln_name is None:
                raise UnknownType("ROS type %s has no LN counterpart (no generated interface records it "
                                  "and no rule maps it)" % ros_type)
        key = (ln_name, ros_type)
        with self._lock:
            if key in self._topic_cache:
                return self._topic_cache[key]
            for rule in self._rules.get(ln_name, []):
                if ros_type in (None, rule.ros_name):
                    result = TopicType(ln_name, rule.ros_name, _import_ros_type(rule.ros_name), rule,
                                       rule.ln_size, "rule")
                    break
            else:
                entry = self._generated(ln_name, "message", ros_type)
                codec = self._codec(ln_name)
                result = TopicType(ln_name, entry["ros_type"], _import_ros_type(entry["ros_type"]), codec,
                                   codec.fixed_ln_size, "generated")
            self._topic_cache[key] = result
            return result

    def service_type(self, ln_name=None, ros_type=None):
        """The ServiceType for an LN service definition and/or a ROS service type. Raises UnknownType."""
        if ln_name is None:
            ln_name = self.ln_name_for_ros(ros_type)
            if ln_name is None:
                raise UnknownType("ROS service type %s has no LN counterpart (no generated interface "
                                  "records it)" % ros_type)
        key = (ln_name, ros_type)
        with self._lock:
            if key in self._service_cache:
                return self._service_cache[key]
            entry = self._generated(ln_name, "service", ros_type)
            result = ServiceType(ln_name, entry["ros_type"], _import_ros_type(entry["ros_type"]),
                                 self._codec(ln_name, "request"), self._codec(ln_name, "response"))
            self._service_cache[key] = result
            return result

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
            raise UnknownType("LN definition %s has no generated ROS interface on AMENT_PREFIX_PATH "
                              "(make one with: ln_ros2_gen --md-dir DIR --out WS/src %s; colcon build)"
                              % (ln_name, ln_name))
        if entry.get("kind") != kind:
            raise UnknownType("LN definition %s is a %s, not a %s" % (ln_name, entry.get("kind"), kind))
        if ros_type is not None and ros_type != entry["ros_type"]:
            raise UnknownType("LN definition %s is generated as %s, not %s" % (ln_name, entry["ros_type"], ros_type))
        if entry.get("ln_hash") and entry["ln_hash"] != current:
            raise UnknownType("ROS interface %s (in %s) was generated from another version of %s "
                              "(hash %.12s, now %.12s): regenerate it with ln_ros2_gen and rebuild"
                              % (entry["ros_type"], entry["path"], ln_name, entry["ln_hash"], current))
        return entry

    def _codec(self, ln_name, part=""):
        try:
            self._load(ln_name)
            self._generator.add(self._library, ln_name)
            return self._generator.codec(ln_name, part)
        except UnknownType:
            raise
        except Exception as error:   # DefinitionError/MappingError (or LNError, see _load)
            raise UnknownType("no codec for LN definition %s: %s" % (ln_name, error)) from error
