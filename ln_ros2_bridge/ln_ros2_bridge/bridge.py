"""The bridge: keeps the set of running topic and service bridges equal to what
the configuration asks for, given what the LN manager and the ROS graph show.

A reconciler thread does everything that creates or removes endpoints, once
per `auto.period`, and at once when the LN manager reports a change (a
publisher or provider of a topic or service it knows came or went; see
ln_introspection). Topic data never passes through it: each topic is a
compiled path with a thread of its own (topics.py), which the reconciler
polls twice a second for what it did (logged, and published on /diagnostics).
Each pass:

1. (re)connect to the LN manager when there is no connection or it is gone;
2. read the LN side (topics with publisher, services with provider) and the
   ROS side (topics with publishers, services with servers, per node);
3. desired = explicit entries (always on; `both` picks the side that has a
   publisher) + automatic entries (what exists on one side and passes the
   filters);
4. start what is desired and missing, stop what is running and no longer
   desired. A failure (unknown type, name taken) is reported once and retried
   every RETRY seconds.

Loop prevention: an LN topic or service whose publisher/provider is a bridge
client (loop_prevention.bridge_names) is never bridged to ROS, a ROS topic or
service whose only publishers/servers are bridge nodes is never bridged to LN,
and a ROS->LN subscription drops the messages of bridge publishers, telling them
apart from other publishers on the same topic by the sender of each message (see
RosToLnTopic). Two bridges on one LN instance and ROS domain therefore
never echo; when both could bridge the same thing automatically, a claim registered
with the LN manager decides who does (see _should_take).
"""

import logging
import threading
import time
from dataclasses import dataclass, replace

from .config import BUILTIN_DENY_LN, BUILTIN_DENY_ROS, ServiceEntry, TopicEntry, ln_to_ros_name, ros_to_ln_name
from .diagnostics import Diagnostics
from .ln_adapter import LnConnection
from .ln_introspection import IntrospectionError, open_introspection
from .services import LnToRosService, RosToLnService
from .topics import LnToRosTopic, RosToLnTopic
from .types import RosCapacities, TypeRegistry, UnknownType

log = logging.getLogger("ln_ros2_bridge")


@dataclass
class RosGraph:
    nodes: list  # fully qualified node names
    topics: dict  # ROS topic -> list of type names
    publishers: dict  # ROS topic -> [node fq name] of its publishers
    servers: dict  # ROS service -> [(node fq name, type)]


class Bridge:
    SETTLE = 1.5  # seconds: how long ROS discovery is given before automatic decisions (see _should_take)
    RETRY = 5.0  # seconds before an entry that failed to start is tried again
    POLL = 0.5  # seconds between looks at what the topic paths did

    def __init__(self, config, node, connect=None):
        self.config = config
        self.node = node
        self.types = TypeRegistry(
            config.ln_definition_dirs,
            config.rule_files,
            fetch_definition=self._fetch_definition,
            capacities=RosCapacities(config.string_capacity, config.sequence_capacity, dict(config.capacities)),
        )
        self._connect = connect or (lambda: LnConnection(config.ln_client_name, config.ln_manager))
        self.ln = None
        self._introspection = None
        self.active = {}  # key -> running bridge object
        self._reported = {}  # key -> last failure text (reported once)
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._broken = threading.Event()
        self._thread = None
        self._ln_retry_at = 0.0
        self._ln_retry_delay = 0.2
        self.node_fq_name = self._fq(node.get_namespace(), node.get_name())
        self._started_at = time.monotonic()
        self._waiting_since = {}  # automatic entry -> when it was first seen waiting for another bridge
        self._retry_at = {}  # entry that failed to start -> when to try again
        self._claims = {}  # automatic entry -> the LN service that claims it (see _should_take)
        self._claims_supported = True
        self._claim_type_ready = False
        self._failed = {}  # desired entry that does not run -> (entry, why), for the diagnostics
        self.diagnostics = Diagnostics(node)

    # -- life cycle -------------------------------------------------------------
    def start(self):
        self._thread = threading.Thread(target=self._run, name="bridge-reconciler", daemon=True)
        self._thread.start()

    def stop(self):
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        with self._lock:
            self._stop_all()
            self._disconnect_ln()

    def wake(self):
        """Reconcile now rather than at the next period."""
        self._wake.set()

    def _run(self):
        polled_at = 0.0
        while not self._stop.is_set():
            try:
                self.reconcile()
            except Exception:  # a bug in one pass must not end the bridge
                log.exception("reconciliation failed; retrying at the next period")
            period = self.config.auto.period
            introspection = self._introspection
            deadline = time.monotonic() + period
            while not self._stop.is_set() and time.monotonic() < deadline:
                if time.monotonic() - polled_at >= self.POLL:
                    polled_at = time.monotonic()
                    try:
                        self.poll()
                    except Exception:
                        log.exception("reading the topic paths' reports failed")
                if self._wake.wait(min(0.05, max(0.0, deadline - time.monotonic()))):
                    self._wake.clear()
                    break
                if introspection is not None and introspection.changed.is_set():
                    introspection.changed.clear()
                    break
                if self._broken.is_set():
                    break

    def poll(self):
        """Reads what each topic path did (logging its drops), notices paths that
        stopped, and publishes the diagnostics when they are due."""
        with self._lock:
            reports = {}
            for key, bridge in self.active.items():
                if key[0] != "topic":
                    continue
                report = reports[key] = bridge.poll()
                if report["failed"] and not self._broken.is_set():
                    log.warning("%s stopped (%s); the bridge will reconnect", bridge.describe(), report["failure"])
                    self._broken.set()
            self.diagnostics.update(self, reports)

    # -- LN connection ----------------------------------------------------------
    def _ensure_ln(self):
        if self._broken.is_set():
            self._broken.clear()
            if self.ln is not None:
                log.warning("LN connection lost: stopping the bridges that use it and reconnecting")
                self._stop_all()
                self._disconnect_ln()
        if self.ln is not None:
            try:
                self.ln.ping(2.0)
                if getattr(self._introspection, "error", None) is not None:
                    raise IntrospectionError(str(self._introspection.error))
                return True
            except Exception as error:
                log.warning(
                    "LN manager unreachable (%s): stopping the bridges that use it, reconnecting", str(error).strip()
                )
                self._stop_all()
                self._disconnect_ln()
        if time.monotonic() < self._ln_retry_at:
            return False
        try:
            self.ln = self._connect()
            self._introspection = open_introspection(
                self.ln, [t.ln for t in self.config.topics], [s.ln for s in self.config.services]
            )
            self.ln.data_client()
            self._broken.clear()
            self._ln_retry_delay = 0.2
            log.info(
                "connected to the LN manager at %s as %r (%s)", self.ln.manager_address, self.ln.name, self.ln.flavor
            )
            for name in sorted(self.ln.own_names):
                if not self.config.is_bridge_name(name):
                    log.error(
                        "the LN manager named this client %r, which loop_prevention.bridge_names does not "
                        "match: other bridges would re-bridge its topics (use a pattern such as 'name*')",
                        name,
                    )
            return True
        except Exception as error:
            self._disconnect_ln()
            self._ln_retry_at = time.monotonic() + self._ln_retry_delay
            self._ln_retry_delay = min(self._ln_retry_delay * 2, 5.0)
            self._report(
                ("ln-connect",),
                "cannot connect to the LN manager at %s: %s"
                % (self.config.ln_manager or "$LN_MANAGER", str(error).strip()),
            )
            return False

    def _disconnect_ln(self):
        if self._introspection is not None:
            try:
                self._introspection.close()
            except Exception:
                pass
        self._introspection = None
        if self.ln is not None:
            try:
                self.ln.close()
            except Exception:
                pass
        self.ln = None
        self.types.forget_fetched()  # a restarted manager may know other definitions
        self._retry_at.clear()
        self._claims.clear()  # they ended with the connection
        self._claim_type_ready = False
        self._failed.clear()

    # -- one pass ------------------------------------------------------------------
    def reconcile(self):
        with self._lock:
            if not self._ensure_ln():
                return
            try:
                ln_topics, ln_services = self._introspection.snapshot()
            except IntrospectionError as error:
                log.warning("cannot read the LN manager's topics and services: %s", error)
                self._broken.set()
                return
            graph = self._ros_graph()
            desired = self._desired(ln_topics, ln_services, graph)
            for key in [k for k in self.active if k not in desired]:
                self._stop_one(key)
            for key in [k for k in self._claims if k not in desired]:
                self._release_claim(key)
            now = time.monotonic()
            for key in [k for k in self._failed if k not in desired]:
                del self._failed[key]
            for key, entry in desired.items():
                if key not in self.active and now >= self._retry_at.get(key, 0.0):
                    self._start_one(key, entry)

    def _fetch_definition(self, name):
        """Makes a definition the manager knows available to the codecs (called by
        the type registry for names it cannot find): LN 2.9 says where the file is
        (its directory joins the search path), ln_core sends the text."""
        if self.ln is None or self._introspection is None:
            return
        if self.ln.flavor == "ln29":
            path = self._introspection.definition_file(name)
            if path and path.endswith(name):
                self.types.add_definition_dir(path[: -len(name)].rstrip("/"))
        else:
            self.types.add_definition_text(name, self.ln.client.get_message_definition_text(name))

    # -- the ROS graph ---------------------------------------------------------------
    @staticmethod
    def _fq(namespace, name):
        return (namespace.rstrip("/") + "/" + name) if namespace else "/" + name

    def _ros_graph(self):
        node = self.node
        topics = dict(node.get_topic_names_and_types())
        publishers = {}
        for name in topics:
            if self._ros_denied(name):
                continue
            publishers[name] = [
                self._fq(i.node_namespace, i.node_name) for i in node.get_publishers_info_by_topic(name)
            ]
        nodes = [self._fq(namespace, name) for name, namespace in node.get_node_names_and_namespaces()]
        servers = {}
        if self.config.auto.enabled:  # who serves what: needed for automatic services either way
            for name, namespace in node.get_node_names_and_namespaces():
                fq = self._fq(namespace, name)
                try:
                    for service, types in node.get_service_names_and_types_by_node(name, namespace):
                        servers.setdefault(service, []).append((fq, types[0] if types else ""))
                except Exception:  # the node vanished between the two queries
                    continue
        return RosGraph(nodes, topics, publishers, servers)

    @staticmethod
    def _ros_denied(name):
        import fnmatch

        return any(fnmatch.fnmatchcase(name, p) for p in BUILTIN_DENY_ROS)

    def _is_bridge_node(self, fq_name):
        return self.config.is_bridge_name(fq_name)

    def _is_bridge_client(self, name):
        """An LN client of a bridge: matching bridge_names, or one of ours (LN 2.9
        may have numbered our data client's name)."""
        return self.config.is_bridge_name(name) or name in self.ln.own_names

    def _should_take(self, key, ros_name, others, graph):
        """Whether this bridge should carry an automatic entry that other bridges on this
        LN instance and ROS domain could carry too (`others`: the nodes that already
        publish/serve its ROS name; LN->ROS only). For ROS->LN entries this also keeps
        two bridges from publishing one LN topic at once (LN 2.9's manager then never
        answers the second publish).

        * another bridge already carries it: leave it (if both do, the one sorting first
          keeps it);
        * otherwise the bridges settle it through the LN manager, which registers a
          service name only once: whoever registers the claim (an LN service named after
          the ROS domain and name) carries the entry. The claim ends with the bridge's LN
          connection, so another bridge takes over when one goes away.
        * LN where the claim cannot be registered: the bridge whose node name sorts first
          gets SETTLE seconds to take it, and nothing is taken in the first SETTLE seconds
          (discovery) -- a heuristic that avoids most, not all, start-up races."""
        other_bridges = [n for n in others if self._is_bridge_node(n) and n != self.node_fq_name]
        if other_bridges:
            return key in self.active and self.node_fq_name < min(other_bridges)
        if key in self.active:
            return True
        if self._claims_supported:
            claimed = self._claim(key, ros_name)
            if claimed is not None:
                return claimed
        now = time.monotonic()
        if now - self._started_at < self.SETTLE:
            return False
        if any(self._is_bridge_node(n) and n < self.node_fq_name for n in graph.nodes):
            first_seen = self._waiting_since.setdefault(key, now)
            return now - first_seen >= self.SETTLE
        return True

    CLAIM_DEFINITION = "ln_ros2_bridge/claim"
    CLAIM_TEXT = (
        "# ln_ros2_bridge: an LN service of this type marks which bridge carries an entry\n"
        "service\nrequest\nuint8_t unused\nresponse\nuint8_t unused\n"
    )
    CLAIM_PREFIX = "ln_ros2_bridge_claims"

    def _claim(self, key, ros_name):
        """True: we hold the claim on `key` now; False: another bridge does; None: claims
        do not work with this LN (then _claims_supported turns False)."""
        if key in self._claims:
            return True
        name = "%s.%s.d%d%s" % (
            self.CLAIM_PREFIX,
            key[0],
            self.node.context.get_domain_id(),
            ros_name.replace("/", "."),
        )
        client = self.ln.client
        try:
            if not self._claim_type_ready:
                client.put_message_definition(self.CLAIM_DEFINITION, self.CLAIM_TEXT)
                self._claim_type_ready = True
            service = client.get_service_provider(name, self.CLAIM_DEFINITION)
            service.set_handler(lambda request, req, resp: 0)  # nobody calls it
        except Exception as error:
            log.info(
                "LN cannot hold claims (%s): two bridges on this LN instance settle automatic "
                "entries by node name instead",
                " ".join(str(error).split()),
            )
            self._claims_supported = False
            return None
        try:
            service.do_register(self.CLAIM_PREFIX)
        except Exception:  # the name is taken: another bridge carries it
            client.release_service(service)
            return False
        self._claims[key] = service
        return True

    def _release_claim(self, key):
        service = self._claims.pop(key, None)
        if service is not None and self.ln is not None:
            try:
                self.ln.client.release_service(service)
            except Exception as error:
                log.debug("releasing the claim on %s: %s", key, error)

    # -- what should run ---------------------------------------------------------------
    def _desired(self, ln_topics, ln_services, graph):
        config, auto = self.config, self.config.auto
        ln_topic = {t.name: t for t in ln_topics}
        ln_service = {s.name: s for s in ln_services}
        desired = {}

        def ln_publisher(name):
            t = ln_topic.get(name)
            return t.publisher if t else ""

        def ros_sources(ros_name):
            return [n for n in graph.publishers.get(ros_name, []) if not self._is_bridge_node(n)]

        explicit_ln_topics, explicit_ln_services = set(), set()
        for entry in config.topics:
            explicit_ln_topics.add(entry.ln)
            direction = entry.direction
            if direction == "both":  # the side that has a (non-bridge) publisher feeds the other
                publisher = ln_publisher(entry.ln)
                if publisher and not self._is_bridge_client(publisher):
                    direction = "ln_to_ros"
                elif ros_sources(entry.ros):
                    direction = "ros_to_ln"
                else:
                    current = self._current_direction("topic", entry.ln)
                    if current is None:
                        continue
                    direction = current
            desired[("topic", entry.ln, direction)] = replace(entry, direction=direction)
        for entry in config.services:
            explicit_ln_services.add(entry.ln)
            desired[("service", entry.ln, entry.direction)] = entry

        if not auto.enabled:
            return desired

        def accepted(filter_, ln_name, ros_name, builtin_ln_deny=BUILTIN_DENY_LN):
            import fnmatch

            if any(fnmatch.fnmatchcase(ln_name, p) for p in builtin_ln_deny) or self._ros_denied(ros_name):
                return False
            allowed = any(fnmatch.fnmatchcase(n, p) for p in filter_.allow for n in (ln_name, ros_name))
            denied = any(fnmatch.fnmatchcase(n, p) for p in filter_.deny for n in (ln_name, ros_name))
            return allowed and not denied

        if "ln_to_ros" in auto.directions:
            for t in ln_topics:
                if not t.publisher or self._is_bridge_client(t.publisher) or t.name in explicit_ln_topics:
                    continue
                ros_name = ln_to_ros_name(t.name, auto)
                if not accepted(auto.topics, t.name, ros_name):
                    continue
                key = ("topic", t.name, "ln_to_ros")
                if not self._should_take(key, ros_name, graph.publishers.get(ros_name, []), graph):
                    continue
                desired[("topic", t.name, "ln_to_ros")] = TopicEntry(
                    t.name,
                    ros_name,
                    "ln_to_ros",
                    ln_type=t.md_name,
                    qos=config.qos,
                    ln_port=config.ln_port,
                    origin="auto",
                )
            for s in ln_services:
                if self._is_bridge_client(s.provider) or s.name in explicit_ln_services:
                    continue
                ros_name = ln_to_ros_name(s.name, auto)
                if not accepted(auto.services, s.name, ros_name):
                    continue
                servers = [n for n, _ in graph.servers.get(ros_name, [])]
                if any(not self._is_bridge_node(n) for n in servers):
                    continue  # a ROS node serves that name itself
                if not self._should_take(("service", s.name, "ln_to_ros"), ros_name, servers, graph):
                    continue
                desired[("service", s.name, "ln_to_ros")] = ServiceEntry(
                    s.name, ros_name, "ln_to_ros", ln_type=s.interface, timeout=config.service_timeout, origin="auto"
                )

        if "ros_to_ln" in auto.directions:
            for ros_name, types in graph.topics.items():
                if ros_name not in graph.publishers or not ros_sources(ros_name) or len(types) != 1:
                    continue
                ln_name = ros_to_ln_name(ros_name, auto)
                if ln_name in explicit_ln_topics or ("topic", ln_name, "ln_to_ros") in desired:
                    continue
                if not accepted(auto.topics, ln_name, ros_name):
                    continue
                publisher = ln_publisher(ln_name)
                if publisher and not (
                    publisher in self.ln.own_names and ("topic", ln_name, "ros_to_ln") in self.active
                ):
                    continue  # LN has a publisher already (LN allows one)
                ln_type = self.types.ln_name_for_ros(types[0])
                if ln_type is None:
                    self._report(
                        ("ros-type", types[0]),
                        "ROS topic %s: %s; not bridged" % (ros_name, self.types.why_unmapped(types[0])),
                        level=logging.INFO,
                    )
                    continue
                if not self._should_take(("topic", ln_name, "ros_to_ln"), ros_name, [], graph):
                    continue  # another bridge publishes it into LN (LN allows one publisher)
                desired[("topic", ln_name, "ros_to_ln")] = TopicEntry(
                    ln_name,
                    ros_name,
                    "ros_to_ln",
                    ln_type=ln_type,
                    ros_type=types[0],
                    qos=replace(config.qos, reliability="best_available", durability="best_available"),
                    ln_port=config.ln_port,
                    origin="auto",
                )
            for ros_name, servers in graph.servers.items():
                if self._ros_denied(ros_name) or all(self._is_bridge_node(n) for n, _ in servers):
                    continue
                ln_name = ros_to_ln_name(ros_name, auto)
                if ln_name in explicit_ln_services or ("service", ln_name, "ln_to_ros") in desired:
                    continue
                if not accepted(auto.services, ln_name, ros_name):
                    continue
                existing = ln_service.get(ln_name)
                if existing and existing.provider not in self.ln.own_names:
                    continue
                ros_type = servers[0][1]
                ln_type = self.types.ln_name_for_ros(ros_type)
                if ln_type is None:
                    self._report(
                        ("ros-type", ros_type),
                        "ROS service %s: %s; not bridged" % (ros_name, self.types.why_unmapped(ros_type)),
                        level=logging.INFO,
                    )
                    continue
                if not self._should_take(("service", ln_name, "ros_to_ln"), ros_name, [], graph):
                    continue  # another bridge provides it in LN
                desired[("service", ln_name, "ros_to_ln")] = ServiceEntry(
                    ln_name,
                    ros_name,
                    "ros_to_ln",
                    ln_type=ln_type,
                    ros_type=ros_type,
                    timeout=config.service_timeout,
                    origin="auto",
                )
        return desired

    def _current_direction(self, kind, ln_name):
        for key in self.active:
            if key[0] == kind and key[1] == ln_name:
                return key[2]
        return None

    # -- starting and stopping -------------------------------------------------------
    def _start_one(self, key, entry):
        kind = key[0]
        try:
            if kind == "topic":
                topic_type = self._topic_type_for(entry)
                self.ln.ensure_definitions(topic_type.definitions)
                if entry.direction == "ln_to_ros":
                    bridge = LnToRosTopic(self.node, self.ln, entry, topic_type)
                else:
                    bridge = RosToLnTopic(self.node, self.ln, entry, topic_type, self.config.bridge_names)
            else:
                service_type = self._service_type_for(entry)
                self.ln.ensure_definitions(service_type.definitions)
                cls = LnToRosService if entry.direction == "ln_to_ros" else RosToLnService
                bridge = cls(self.node, self.ln, entry, service_type)
        except UnknownType as error:
            self._not_started(key, entry, "%s %s: %s; not bridged" % (kind, entry.ln, error))
            return
        except Exception as error:  # LN refused (name taken, ...), ROS refused (bad name, ...)
            self._not_started(
                key,
                entry,
                "%s %s (%s, ROS %s): cannot bridge: %s"
                % (kind, entry.ln, entry.direction, entry.ros, " ".join(str(error).split())),
            )
            return
        self.active[key] = bridge
        self._failed.pop(key, None)
        self._reported.pop(key, None)
        self._waiting_since.pop(key, None)
        type_name = getattr(bridge, "topic_type", None) or getattr(bridge, "service_type", None)
        log.info(
            "bridging %s %s %s %s (%s <-> %s, %s)",
            kind,
            entry.ln,
            "->" if entry.direction == "ln_to_ros" else "<-",
            entry.ros,
            type_name.ln_name,
            type_name.ros_type,
            entry.origin,
        )

    def _not_started(self, key, entry, why):
        self._report(key, why)
        self._failed[key] = (entry, why)
        self._retry_at[key] = time.monotonic() + self.RETRY
        self._release_claim(key)  # another bridge may be able to

    def _topic_type_for(self, entry):
        ln_type = entry.ln_type
        if ln_type is None and entry.ros_type is None:
            ln_type = self._ln_topic_definition(entry.ln)
        return self.types.topic_type(ln_type, entry.ros_type)

    def _service_type_for(self, entry):
        ln_type = entry.ln_type
        if ln_type is None and entry.ros_type is None:
            ln_type = self._ln_service_interface(entry.ln)
        return self.types.service_type(ln_type, entry.ros_type)

    def _ln_topic_definition(self, topic):
        for t in self._introspection.topics():
            if t.name == topic and t.md_name:
                return t.md_name
        raise UnknownType(
            "LN topic %s is unknown to the manager (yet); give 'type' to bridge it before it exists" % topic
        )

    def _ln_service_interface(self, service):
        for s in self._introspection.services():
            if s.name == service and s.interface:
                return s.interface
        raise UnknownType(
            "LN service %s has no provider (yet); give 'type' to bridge it before one registers" % service
        )

    def _stop_one(self, key):
        self._release_claim(key)
        bridge = self.active.pop(key)
        try:
            bridge.close()
        except Exception as error:
            log.warning("stopping %s: %s", key, error)
        log.info("stopped bridging %s %s (%s)", key[0], key[1], key[2])

    def _stop_all(self):
        for key in list(self.active):
            self._stop_one(key)

    def _report(self, key, text, level=logging.WARNING):
        if self._reported.get(key) != text:
            self._reported[key] = text
            log.log(level, text)

    def failed_entries(self):
        """{key: (entry, why)} of the desired entries that do not run."""
        with self._lock:
            return dict(self._failed)

    # -- status ------------------------------------------------------------------------
    def status(self):
        with self._lock:
            return {
                "ln": None if self.ln is None else {"name": self.ln.name, "flavor": self.ln.flavor},
                "bridges": [
                    {
                        "kind": k[0],
                        "ln": k[1],
                        "direction": k[2],
                        "ros": b.entry.ros,
                        "origin": b.entry.origin,
                        "count": b.count,
                        "errors": b.errors,
                    }
                    for k, b in sorted(self.active.items())
                ],
                "problems": dict((" ".join(map(str, k)), v) for k, v in self._reported.items()),
            }
