"""ln ros node list | topic list|info|echo|hz | service list|call

The ROS 2 side of a mixed system, for setups without the `ros2` command (the
PyPI ROS 2 has no ros2cli). It needs rclpy only when used: `ln` itself stays
importable without ROS, and `ln ros ...` without rclpy is a one-line error.

The command joins the ROS graph as a hidden node (`_ln_cli_<pid>`: names
starting with '_' are hidden, as ros2cli's own are) on $ROS_DOMAIN_ID, and
gives discovery --spin-time seconds (default 3) before it answers from the
graph; echo, hz and call wait as long for their topic or service to appear.
"""

import importlib
import os
import time

from . import values as V
from .common import CliError, no_message, parse_field_values, print_response, show_info, show_table
from .common import positive_float as _positive_float
from .parsers import add_command, add_count_options, add_max_array, command_group
from .topic import RateMeter, add_report_options, add_timeout_option, every_period, rate_line, show_report


def register(groups, common):
    kinds = command_group(
        groups,
        "ros",
        "the ROS 2 graph: nodes, topics, services (needs rclpy)",
        "Inspect and use the ROS 2 side (ROS 2 Jazzy's rclpy; the PyPI "
        "ROS 2 has no 'ros2' command). Uses $ROS_DOMAIN_ID.",
        dest="ros_kind",
        metavar="KIND",
    )

    commands = []

    def command(sub, name, run, **kwargs):
        commands.append(add_command(sub, name, common, run, **kwargs))
        return commands[-1]

    def subcommands(kind, what):
        return command_group(kinds, kind, "ROS %s" % what, "%s of the ROS graph." % what.capitalize())

    sub = subcommands("node", "nodes")
    p = command(sub, "list", cmd_node_list, help="nodes of the ROS graph (hidden ones with --all)")
    p.add_argument("--all", "-a", action="store_true", help="also hidden nodes (names starting with '_')")

    sub = subcommands("topic", "topics")
    command(sub, "list", cmd_topic_list, help="topics with type, publishers and subscribers")
    p = command(sub, "info", cmd_topic_info, help="one topic: type, publishers and subscribers with QoS")
    p.add_argument("name", metavar="TOPIC")
    p = command(
        sub,
        "echo",
        cmd_topic_echo,
        help="print the messages of a topic",
        description="Subscribes to TOPIC (QoS: best available, so it matches reliable and "
        "best-effort, volatile and transient-local publishers) and prints each "
        "message (YAML-like; --json: one JSON object per line).",
    )
    p.add_argument("name", metavar="TOPIC")
    p.add_argument("--type", "-t", metavar="TYPE", help="pkg/msg/Type (default: the topic's, from the graph)")
    add_count_options(p, "print")
    add_timeout_option(p)
    add_max_array(p)
    p = command(
        sub,
        "hz",
        cmd_topic_hz,
        help="measure the rate of a topic",
        description="Subscribes to TOPIC and prints its rate and the intervals between "
        "messages every --period seconds, over the last --window messages.",
    )
    p.add_argument("name", metavar="TOPIC")
    p.add_argument("--type", "-t", metavar="TYPE", help="pkg/msg/Type (default: the topic's, from the graph)")
    add_report_options(p)

    sub = subcommands("service", "services")
    p = command(sub, "list", cmd_service_list, help="services with their types and servers")
    p.add_argument("--all", "-a", action="store_true", help="also every node's parameter and type-description services")
    p = command(
        sub,
        "call",
        cmd_service_call,
        help="call a service and print the response",
        description="Calls SERVICE with a request given as 'field: value' pairs (YAML flow "
        "style, as for 'ln service call'; fields not given keep their defaults) "
        "and prints the response.",
        epilog="example: ln ros service call /robot/reset 'force: true'",
    )
    p.add_argument("name", metavar="SERVICE")
    p.add_argument("values", nargs="*", metavar="'FIELD: VALUE ...'", help="request fields")
    p.add_argument("--type", "-t", metavar="TYPE", help="pkg/srv/Type (default: the service's, from the graph)")
    p.add_argument(
        "--timeout",
        type=_positive_float,
        default=10.0,
        metavar="SECONDS",
        help="give up after this long, waiting for the server included (default 10)",
    )
    add_max_array(p)

    for p in commands:
        # A new participant learns the others' nodes in 2-3 s (DDS discovery plus ROS's
        # ros_discovery_info); without ros2cli's daemon every command is such a newcomer.
        p.add_argument(
            "--spin-time",
            type=_positive_float,
            default=3.0,
            metavar="SECONDS",
            help="how long to let discovery find the others before answering (default 3)",
        )


# ------------------------------------------------------------------ the node

# ROS's per-node infrastructure services, left out of 'service list' unless --all.
_NODE_SERVICES = (
    "/describe_parameters",
    "/get_parameter_types",
    "/get_parameters",
    "/list_parameters",
    "/set_parameters",
    "/set_parameters_atomically",
    "/get_type_description",
)
# rmw's name for a node whose participant is discovered but whose node names have not arrived yet.
_UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"


class RosGraph:
    """A hidden rclpy node of its own context; closed by the session."""

    def __init__(self, spin_time):
        try:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
        except ImportError as error:
            raise CliError(
                "'ln ros' needs ROS 2 Jazzy's Python packages (rclpy), which this Python cannot import (%s)" % error,
                "source launchless_scripts/env.sh",
            ) from None
        self.rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context, args=["ln"])
        self.node = rclpy.create_node(
            "_ln_cli_%d" % os.getpid(), context=self.context, start_parameter_services=False, enable_rosout=False
        )
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.spin_time = spin_time
        self._started = time.monotonic()

    def settle(self):
        """Gives discovery the rest of --spin-time (counted from the node's start)."""
        remaining = self.spin_time - (time.monotonic() - self._started)
        if remaining > 0:
            self.spin(remaining)

    def spin(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, deadline - time.monotonic())))

    def named(self, fetch, node_name):
        """fetch() again until every entry's node has its name, within --spin-time: discovery shows
        a participant before its node names arrive (as rmw's _NODE_NAME_UNKNOWN_). Entries still
        unnamed then are left out."""
        deadline = time.monotonic() + self.spin_time
        entries = fetch()
        while any(node_name(e) == _UNKNOWN_NODE for e in entries) and time.monotonic() < deadline:
            self.spin(0.1)
            entries = fetch()
        return [e for e in entries if node_name(e) != _UNKNOWN_NODE]

    def own(self, fq_name):
        return fq_name == self.fq_name(self.node.get_namespace(), self.node.get_name())

    @staticmethod
    def fq_name(namespace, name):
        return (namespace.rstrip("/") + "/" + name) if namespace != "/" else "/" + name

    def topic_type(self, topic, given, kind="msg", wait=0.0):
        """The topic's (or service's) type: `given`, else the one the graph shows within
        --spin-time (or `wait` seconds, if longer)."""
        if given:
            return given
        names = self.node.get_topic_names_and_types() if kind == "msg" else self.node.get_service_names_and_types()
        what = "topic" if kind == "msg" else "service"
        deadline = time.monotonic() + max(self.spin_time, wait or 0.0)
        while True:
            types = dict(names).get(topic)
            if types:
                break
            if time.monotonic() >= deadline:
                raise CliError("unknown ROS %s '%s'" % (what, topic), "see 'ln ros %s list'" % what)
            self.spin(0.1)
            names = self.node.get_topic_names_and_types() if kind == "msg" else self.node.get_service_names_and_types()
        if len(types) > 1:
            raise CliError(
                "ROS %s '%s' has several types (%s)" % (what, topic, ", ".join(types)), "choose one with --type"
            )
        return types[0]

    def close(self):
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            self.rclpy.shutdown(context=self.context)


def _graph(session):
    graph = getattr(session, "ros_graph", None)
    if graph is None:
        graph = session.ros_graph = RosGraph(session.args.spin_time)
        close = session.close

        def close_both():
            try:
                graph.close()
            finally:
                close()

        session.close = close_both
    return graph


def _absolute(name):
    return name if name.startswith("/") else "/" + name


def import_type(type_name):
    """The rclpy class of 'pkg/msg/Type' / 'pkg/srv/Type' ('pkg/Type' means msg)."""
    parts = type_name.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or not all(parts):
        raise CliError("'%s' is not a ROS type like pkg/msg/Type" % type_name)
    try:
        return getattr(importlib.import_module("%s.%s" % (parts[0], parts[1])), parts[2])
    except (ImportError, AttributeError) as error:
        raise CliError(
            "ROS type '%s' is not installed here (%s)" % (type_name, error), "build and source its package"
        ) from None


# --------------------------------------------------------------- messages as data


def to_plain(message):
    """A ROS message as plain data (dicts, lists, numbers, text)."""
    if hasattr(message, "get_fields_and_field_types"):
        return {name: to_plain(getattr(message, name)) for name in message.get_fields_and_field_types()}
    if isinstance(message, (bytes, bytearray)):
        return list(message)
    if hasattr(message, "tolist"):  # numpy arrays and scalars
        return message.tolist()
    if isinstance(message, (list, tuple)) or type(message).__name__ == "array":  # array.array
        return [to_plain(v) for v in message]
    return message


def assign(message, values, type_name):
    """Sets parse_fields() output on a ROS message, converting each value for its
    field; CliError naming the field on a wrong name or value."""
    for key, value in values.items():
        try:
            steps = V.parse_path(key)
        except ValueError as error:
            raise CliError(str(error)) from None
        _assign_path(message, steps, value, type_name)


def _slot_types(message):
    return dict(zip(message.get_fields_and_field_types(), type(message).SLOT_TYPES))


def _assign_path(message, steps, value, type_name):
    name, rest = steps[0], steps[1:]
    fields = message.get_fields_and_field_types()
    if name not in fields:
        raise CliError(
            "'%s' has no field '%s'; fields: %s" % (type_name, name, ", ".join(fields)),
            "see 'ln ros topic info' / the .msg",
        )
    slot = _slot_types(message)[name]
    where = "field '%s' of '%s'" % (name, type_name)
    if not rest:
        _set(message, name, _convert(slot, value, getattr(message, name), where), where)
        return
    if isinstance(rest[0], int):
        if not hasattr(slot, "value_type"):
            raise CliError("%s is not an array" % where)
        current = list(getattr(message, name))
        if not -len(current) <= rest[0] < len(current):
            raise CliError("%s has %d element(s), no [%d]" % (where, len(current), rest[0]))
        if rest[1:]:
            _assign_path(current[rest[0]], rest[1:], value, _type_name(slot.value_type))
        else:
            current[rest[0]] = _convert(slot.value_type, value, current[rest[0]], where)
        _set(message, name, current, where)
        return
    if not hasattr(slot, "namespaces"):
        raise CliError("%s has no sub-fields" % where)
    _assign_path(getattr(message, name), rest, value, _type_name(slot))


def _set(message, name, value, where):
    try:
        setattr(message, name, value)
    except (AssertionError, TypeError, ValueError) as error:  # rosidl's setters check types and ranges
        raise CliError("%s: %s" % (where, str(error).strip() or "value does not fit")) from None


def _type_name(slot):
    return "/".join(list(slot.namespaces) + [slot.name])


def _convert(slot, value, current, where):
    """`value` (from parse_fields) as the field of ROS type `slot` needs it."""
    if hasattr(slot, "value_type"):  # arrays and sequences
        if not isinstance(value, list):
            raise CliError("%s is an array: give [a, b, ...]" % where)
        element = slot.value_type
        return [_convert(element, v, None, "%s[%d]" % (where, i)) for i, v in enumerate(value)]
    if hasattr(slot, "namespaces"):  # a nested message
        if not isinstance(value, dict):
            raise CliError("%s is a %s: give {field: value, ...}" % (where, _type_name(slot)))
        target = current if current is not None else _message_class(slot)()
        assign(target, value, _type_name(slot))
        return target
    kind = getattr(slot, "typename", "string")  # BasicType; strings have no typename
    if kind in ("string", "wstring"):
        if isinstance(value, (list, dict)):
            raise CliError("%s expects text" % where)
        return str(value)
    if isinstance(value, (list, dict)):
        raise CliError("%s expects a single value" % where)
    if kind == "boolean":
        text = str(value).strip().lower()
        if text not in ("true", "false", "1", "0"):
            raise CliError("%s: expects true or false, got '%s'" % (where, value))
        return text in ("true", "1")
    try:
        number = V._number(V.Bare(value) if not isinstance(value, V.Bare) else value, where)
    except ValueError as error:
        raise CliError(str(error)) from None
    if kind in ("float", "double", "long double"):
        return float(number)
    if kind in ("octet", "uint8", "char") and isinstance(number, float):
        raise CliError("%s: expects a whole number, got '%s'" % (where, value))
    if isinstance(number, float):
        if not number.is_integer():
            raise CliError("%s: expects a whole number, got '%s'" % (where, value))
        number = int(number)
    return int(number)


def _message_class(slot):
    return getattr(importlib.import_module(".".join(slot.namespaces)), slot.name)


# ----------------------------------------------------------------- commands


def cmd_node_list(session):
    graph = _graph(session)
    graph.settle()
    nodes = sorted(
        graph.fq_name(ns, name)
        for name, ns in graph.named(graph.node.get_node_names_and_namespaces, lambda entry: entry[0])
    )
    nodes = [n for n in nodes if not graph.own(n) and (session.args.all or not n.rsplit("/", 1)[-1].startswith("_"))]
    show_table(session, nodes, ("NODE",), [(n,) for n in nodes], empty="no nodes")


def _endpoints(fetch, name, graph):
    out = []
    for i in graph.named(lambda: fetch(name), lambda info: info.node_name):
        node = graph.fq_name(i.node_namespace, i.node_name)
        if graph.own(node):
            continue
        qos = i.qos_profile  # (discovery does not carry the history depth of others' endpoints)
        out.append(
            {
                "node": node,
                "type": i.topic_type,
                "reliability": qos.reliability.name.lower(),
                "durability": qos.durability.name.lower(),
            }
        )
    return out


def cmd_topic_list(session):
    graph = _graph(session)
    graph.settle()
    rows = []
    for name, types in sorted(graph.node.get_topic_names_and_types()):
        publishers = _endpoints(graph.node.get_publishers_info_by_topic, name, graph)
        subscribers = _endpoints(graph.node.get_subscriptions_info_by_topic, name, graph)
        rows.append({"name": name, "types": types, "publishers": len(publishers), "subscribers": len(subscribers)})
    show_table(
        session,
        rows,
        ("TOPIC", "TYPE", "PUBS", "SUBS"),
        [(r["name"], ", ".join(r["types"]), r["publishers"], r["subscribers"]) for r in rows],
        numeric=(2, 3),
        empty="no topics",
    )


def cmd_topic_info(session):
    graph = _graph(session)
    graph.settle()
    name = _absolute(session.args.name)
    types = dict(graph.node.get_topic_names_and_types()).get(name)
    if not types:
        raise CliError("unknown ROS topic '%s'" % name, "see 'ln ros topic list'")
    info = {
        "name": name,
        "types": types,
        "publishers": _endpoints(graph.node.get_publishers_info_by_topic, name, graph),
        "subscribers": _endpoints(graph.node.get_subscriptions_info_by_topic, name, graph),
    }
    out = session.out
    if not show_info(
        session,
        info,
        [
            ("topic", name),
            ("type", ", ".join(types)),
            ("publishers", len(info["publishers"])),
            ("subscribers", len(info["subscribers"])),
        ],
    ):
        return
    for role in ("publishers", "subscribers"):
        if info[role]:
            out.line(out.paint(role + ":", "bold"))
            for e in info[role]:
                out.line("  %s  (%s, %s)" % (e["node"], e["reliability"], e["durability"]))


def _subscribe(session, callback):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    graph = _graph(session)
    name = _absolute(session.args.name)
    # a topic that should carry messages within --timeout may also appear within it
    type_name = graph.topic_type(name, session.args.type, wait=getattr(session.args, "timeout", None) or 0.0)
    cls = import_type(type_name)
    qos = QoSProfile(
        depth=100, reliability=ReliabilityPolicy.BEST_AVAILABLE, durability=DurabilityPolicy.BEST_AVAILABLE
    )
    graph.node.create_subscription(cls, name, callback, qos)
    return graph, name, type_name


def cmd_topic_echo(session):
    args, out = session.args, session.out
    received = []
    graph, name, _ = _subscribe(session, received.append)
    limit = 1 if args.once else args.count
    shown = 0
    waited_since = time.monotonic()
    while limit is None or shown < limit:
        graph.executor.spin_once(timeout_sec=0.1)
        if not received:
            if args.timeout and time.monotonic() - waited_since > args.timeout:
                raise no_message("ROS topic '%s'" % name, "for", args.timeout, "ln ros topic info %s" % name)
            continue
        waited_since = time.monotonic()
        while received and (limit is None or shown < limit):
            plain = to_plain(received.pop(0))
            if out.json_mode:
                out.json(plain, compact=True)
            else:
                out.record(plain, args.max_array)
                out.line("---")
            out.flush()
            shown += 1


def cmd_topic_hz(session):
    args, out = session.args, session.out
    meter = RateMeter(args.window)

    def on_message(_message):
        meter.add(time.monotonic(), meter.total, 0)  # ROS has no sequence numbers here: one per arrival

    graph, name, _ = _subscribe(session, on_message)

    def spin(seconds):
        graph.executor.spin_once(timeout_sec=min(0.1, seconds))

    def report():
        report = meter.report()
        if report is not None:
            report.pop("lost", None)
            report["topic"] = name
        show_report(out, report, {"topic": name, "rate": 0.0, "received": 0}, lambda r: rate_line(out, r))

    every_period(session, meter, spin, report, "ROS topic '%s'" % name, "ln ros topic info %s" % name)


def cmd_service_list(session):
    graph = _graph(session)
    graph.settle()
    servers = {}
    for node_name, namespace in graph.named(graph.node.get_node_names_and_namespaces, lambda entry: entry[0]):
        fq = graph.fq_name(namespace, node_name)
        if graph.own(fq):
            continue
        try:
            for service, _types in graph.node.get_service_names_and_types_by_node(node_name, namespace):
                servers.setdefault(service, []).append(fq)
        except Exception:  # the node left between the two questions
            continue
    rows = []
    for name, types in sorted(graph.node.get_service_names_and_types()):
        if not session.args.all and name.endswith(_NODE_SERVICES):
            continue
        rows.append({"name": name, "types": types, "servers": sorted(servers.get(name, []))})
    show_table(
        session,
        rows,
        ("SERVICE", "TYPE", "SERVERS"),
        [(r["name"], ", ".join(r["types"]), r["servers"]) for r in rows],
        empty="no services",
    )


def cmd_service_call(session):
    args, out = session.args, session.out
    graph = _graph(session)
    name = _absolute(args.name)
    start = time.monotonic()
    type_name = graph.topic_type(name, args.type, kind="srv", wait=args.timeout)
    cls = import_type(type_name)
    request = cls.Request()
    assign(request, parse_field_values(args.values), type_name + "_Request")
    client = graph.node.create_client(cls, name)
    while not client.service_is_ready():
        if time.monotonic() - start >= args.timeout:
            raise CliError(
                "no server for ROS service '%s' within %g s" % (name, args.timeout), "see 'ln ros service list'"
            )
        graph.spin(0.05)
    future = client.call_async(request)
    while not future.done():
        if time.monotonic() - start >= args.timeout:
            client.remove_pending_request(future)
            raise CliError("ROS service '%s' did not answer within %g s" % (name, args.timeout))
        graph.executor.spin_once(timeout_sec=0.05)
    if future.exception() is not None:
        raise CliError("ROS service '%s' failed: %s" % (name, future.exception()))
    response = to_plain(future.result())
    print_response(out, response, args.max_array)
    # std_srvs-style responses report failure in the answer itself
    if response.get("success") is False:
        out.flush()
        message = response.get("message")
        raise CliError(
            "ROS service '%s' answered success: false%s"
            % (name, ": %s" % message.strip() if isinstance(message, str) and message.strip() else "")
        )
