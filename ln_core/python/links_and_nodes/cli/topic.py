"""ln topic list | info | echo | hz | bw | pub"""

import csv
import math
import time
from collections import deque

from . import values as V
from .common import (
    CliError,
    as_dict,
    by_name,
    find_by_name,
    introspect,
    lnerror_text,
    no_message,
    parse_field_values,
    show_info,
    show_items,
)
from .common import positive_float as _positive_float
from .common import positive_int as _positive_int
from .output import human_bytes, human_rate
from .parsers import add_command, add_count_options, add_max_array, command_group

TOPIC_FIELDS = ("name", "message_definition", "hash", "message_size", "publisher", "subscribers", "packets", "rate")


def register(groups, common):
    sub = command_group(
        groups, "topic", "list, inspect, echo, measure and publish topics", "Topics of the running ln_manager."
    )
    add_command(
        sub,
        "list",
        common,
        cmd_list,
        help="topics with definition, publisher, subscribers, rate",
        description="Every topic the manager knows: its message definition, publisher, number "
        "of subscribers and rate (packets/s, measured by the manager).",
    )
    p = add_command(sub, "info", common, cmd_info, help="one topic in detail")
    p.add_argument("name", metavar="TOPIC").completer = "topics"

    p = add_command(
        sub,
        "echo",
        common,
        cmd_echo,
        help="print the messages of a topic",
        description="Subscribes to TOPIC and prints each message (YAML-like; --json: one JSON "
        "object per line; --csv: a header line, then one line per message).",
    )
    p.add_argument("name", metavar="TOPIC").completer = "topics"
    _add_read_options(p)
    add_count_options(p, "print")
    p.add_argument("--field", "-f", metavar="PATH", help="print only this field, e.g. pose.position[2]")
    p.add_argument("--csv", action="store_true", help="comma-separated values, one line per message")
    add_timeout_option(p)
    add_max_array(p, "--json/--csv")
    p.add_argument("--rate", type=_positive_float, metavar="HZ", help="at most this many messages per second")

    for name, run, what in (("hz", cmd_hz, "the rate and jitter"), ("bw", cmd_bw, "the bandwidth")):
        p = add_command(
            sub,
            name,
            common,
            run,
            help="measure %s of a topic" % what,
            description="Subscribes to TOPIC and prints %s every --period seconds, over the "
            "last --window messages (lost packets are counted too)." % what,
        )
        p.add_argument("name", metavar="TOPIC").completer = "topics"
        _add_read_options(p)
        add_report_options(p)

    p = add_command(
        sub,
        "pub",
        common,
        cmd_pub,
        help="publish messages on a topic",
        description="Publishes a message on TOPIC, given as 'field: value' pairs (YAML flow "
        "style: 'time: 1.5, vec: [1, 2, 3], origin: {x: 1}', or a path as the key: "
        "'corners[1].x: 7'); fields not given are 0. Values are checked against the "
        "message definition before anything is published. Without --once/--count "
        "it publishes until interrupted.",
        epilog="example: ln topic pub counter.counts 'time: 1.5, num_counts: 3' --rate 10",
    )
    p.add_argument("name", metavar="TOPIC").completer = "topics"
    p.add_argument("values", nargs="*", metavar="'FIELD: VALUE ...'", help="field values (default: all 0)")
    p.add_argument(
        "--type", "-t", metavar="MD", help="message definition (default: the topic's, if it exists)"
    ).completer = "mds"
    p.add_argument(
        "--rate", "-r", type=_positive_float, default=1.0, metavar="HZ", help="messages per second (default 1)"
    )
    add_count_options(p, "publish")
    p.add_argument(
        "--wait",
        type=float,
        default=2.0,
        metavar="SECONDS",
        help="with --once/--count: wait this long for a subscriber first (default 2)",
    )


def add_timeout_option(p):
    """--timeout of the commands that print the messages of a topic (echo)."""
    p.add_argument(
        "--timeout", type=_positive_float, metavar="SECONDS", help="fail if no message arrives for this long"
    )


def add_report_options(p):
    """--window, --period, --count, --duration of the commands that measure a topic (hz, bw)."""
    p.add_argument(
        "--window", "-w", type=_positive_int, default=100, metavar="N", help="messages to average over (default 100)"
    )
    p.add_argument(
        "--period", type=_positive_float, default=1.0, metavar="SECONDS", help="seconds between reports (default 1)"
    )
    p.add_argument("--count", "-n", type=_positive_int, metavar="N", help="exit after N reports")
    p.add_argument(
        "--duration", "-d", type=_positive_float, metavar="SECONDS", help="measure this long, print one report and exit"
    )


def _add_read_options(p):
    p.add_argument(
        "--type",
        "-t",
        metavar="MD",
        help="message definition, to subscribe before the topic exists (default: the topic's)",
    ).completer = "mds"
    p.add_argument(
        "--buffers",
        type=_positive_int,
        default=1,
        metavar="N",
        help="subscriber buffers (default 1: always the newest message)",
    )


# --------------------------------------------------------------- list/info


def cmd_list(session):
    show_items(
        session,
        by_name(session, "list_topics"),
        TOPIC_FIELDS,
        ("TOPIC", "DEFINITION", "PUBLISHER", "SUBS", "RATE"),
        lambda t: (t.name, t.message_definition, t.publisher or "-", t.subscribers, human_rate(t.rate)),
        numeric=(3, 4),
        empty="no topics",
    )


def cmd_info(session):
    topic = find_by_name(by_name(session, "list_topics"), session.args.name, "topic", "ln topic list")
    clients = introspect(session, "list_clients")
    own = session.client().name
    subscribers = sorted(c.name for c in clients if topic.name in c.subscribed and c.name != own)
    info = as_dict(topic, TOPIC_FIELDS)
    info["subscriber_names"] = subscribers
    show_info(
        session,
        info,
        [
            ("topic", topic.name),
            ("definition", topic.message_definition),
            ("hash", topic.hash),
            ("size", "%d bytes" % topic.message_size),
            ("publisher", topic.publisher or None),
            ("subscribers", "%d%s" % (topic.subscribers, ": " + ", ".join(subscribers) if subscribers else "")),
            ("rate", human_rate(topic.rate)),
            ("packets", topic.packets),
        ],
    )


# -------------------------------------------------------------- subscribing


def _topic_definition(clnt, topic):
    import links_and_nodes as ln

    try:
        return clnt.get_message_definition_for_topic(topic)[0]
    except ln.LNError as error:
        if error.code in (ln.LNE_PORT_NOT_FOUND, ln.LNE_NO_PROVIDER_FOUND):
            raise CliError("unknown topic '%s'" % topic, "see 'ln topic list'") from None
        raise


def subscribe(session):
    """(port, message definition name) for the topic of the command."""
    import links_and_nodes as ln

    args = session.args
    clnt = session.client()
    md_name = args.type or _topic_definition(clnt, args.name)
    rate = getattr(args, "rate", None) or -1
    try:
        port = clnt.subscribe(args.name, md_name, rate=rate, buffers=args.buffers)
    except ln.LNError as error:
        raise CliError("cannot subscribe to topic '%s': %s" % (args.name, lnerror_text(error))) from None
    return port, md_name


def cmd_echo(session):
    args, out = session.args, session.out
    port, md_name = subscribe(session)
    steps = None
    if args.field:
        try:
            steps = V.parse_path(args.field)
            V.select(port.packet, steps)  # fails now for a wrong path, not at the first message
        except (ValueError, KeyError, IndexError) as error:
            raise CliError(
                "topic '%s' (%s): %s" % (args.name, md_name, str(error).strip("'\"")), "see 'ln md show %s'" % md_name
            ) from None
    limit = 1 if args.once else args.count
    writer = csv.writer(out.stream, lineterminator="\n") if args.csv else None
    received = 0
    waited_since = time.monotonic()
    while limit is None or received < limit:
        packet = port.read(0.2)
        if packet is None:
            if args.timeout and time.monotonic() - waited_since > args.timeout:
                raise no_message("topic '%s'" % args.name, "for", args.timeout, "ln topic info %s" % args.name)
            continue
        waited_since = time.monotonic()
        plain = V.select(packet, steps) if steps else V.to_plain(packet)
        if out.json_mode:
            out.json(plain, compact=True)
        elif writer is not None:
            columns = V.flatten(plain, args.field or "")
            if received == 0:
                writer.writerow([name for name, _ in columns])
            writer.writerow([value for _, value in columns])
        elif isinstance(plain, (dict, list)):
            out.record(plain, args.max_array)
            out.line("---")
        else:
            out.record(plain)
        out.flush()
        received += 1


# -------------------------------------------------------------- hz and bw


class RateMeter:
    """Rate and interval statistics over the last `window` messages, from
    receive times and the publisher's sequence numbers; messages received
    and lost since the start."""

    def __init__(self, window):
        self.samples = deque(maxlen=window + 1)  # (receive time, sequence)
        self.intervals = deque(maxlen=window)
        self.total = 0
        self.lost = 0

    def add(self, now, sequence, lost):
        """One message; `lost`: those skipped since the previous one (sample_info.lost)."""
        if self.samples and sequence == self.samples[-1][1] + 1:
            self.intervals.append(now - self.samples[-1][0])
        self.samples.append((now, sequence))
        self.total += 1
        self.lost += lost

    def report(self):
        if len(self.samples) < 2:
            return None
        (t0, s0), (t1, s1) = self.samples[0], self.samples[-1]
        rate = (s1 - s0) / (t1 - t0) if t1 > t0 else 0.0
        intervals = list(self.intervals)
        if intervals:
            mean = sum(intervals) / len(intervals)
            jitter = math.sqrt(sum((i - mean) ** 2 for i in intervals) / len(intervals))
            low, high = min(intervals), max(intervals)
        else:
            mean = jitter = low = high = None
        return {
            "rate": rate,
            "mean": mean,
            "min": low,
            "max": high,
            "jitter": jitter,
            "window": len(self.samples) - 1,
            "received": self.total,
            "lost": self.lost,
        }


def _ms(seconds):
    return "-" if seconds is None else "%.3f ms" % (seconds * 1e3)


def every_period(session, meter, wait, report, topic, info_command):
    """The loop of hz and bw: wait(seconds) feeds `meter` until a report is due,
    then report() prints one; every --period, or once after --duration, and
    --count times at most. `topic`, `info_command`: for the error when
    --duration passed without a message."""
    args = session.args
    next_report = time.monotonic() + (args.duration or args.period)
    reports = 0
    while True:
        remaining = next_report - time.monotonic()
        if remaining > 0:
            wait(remaining)
            continue
        if args.duration and meter.total == 0:
            raise no_message(topic, "within", args.duration, info_command)
        report()
        session.out.flush()
        reports += 1
        if args.duration or (args.count and reports >= args.count):
            return
        next_report += args.period


def show_report(out, report, empty, text):
    """One report of hz or bw: `empty` (JSON) or 'no new messages' before there
    are two messages, else the report as JSON or as the line text(report)."""
    if out.json_mode:
        out.json(report or empty, compact=True)
    elif report is None:
        out.line("no new messages")
    else:
        out.line(text(report))


def rate_line(out, report):
    """The line of 'hz': rate, interval statistics, window (and lost, where the report has it)."""
    text = "rate: %s  min: %s  max: %s  jitter: %s  window: %d" % (
        out.paint("%.3f Hz" % report["rate"], "bold"),
        _ms(report["min"]),
        _ms(report["max"]),
        _ms(report["jitter"]),
        report["window"],
    )
    return text + ("  lost: %d" % report["lost"] if "lost" in report else "")


def _measure(session, show):
    """Reads the topic and calls show(report) every period (hz and bw)."""
    args = session.args
    port, _ = subscribe(session)
    meter = RateMeter(args.window)
    size = port.packet._size

    def read(seconds):
        packet = port.read(min(0.2, seconds))
        if packet is not None:
            sequence, lost, _ = port.sample_info  # lost: skipped since the previous read
            meter.add(time.monotonic(), sequence, lost)

    def report():
        report = meter.report()
        if report is not None:
            report.update(topic=args.name, message_size=size, bandwidth=report["rate"] * size)
        show(report)

    every_period(session, meter, read, report, "topic '%s'" % args.name, "ln topic info %s" % args.name)


def cmd_hz(session):
    out = session.out
    empty = {"topic": session.args.name, "rate": 0.0, "received": 0}
    _measure(session, lambda report: show_report(out, report, empty, lambda r: rate_line(out, r)))


def cmd_bw(session):
    out = session.out
    empty = {"topic": session.args.name, "bandwidth": 0.0, "received": 0}

    def text(report):
        return "bandwidth: %s  (%s messages at %.3f Hz)  window: %d" % (
            out.paint(human_bytes(report["bandwidth"], per_second=True), "bold"),
            human_bytes(report["message_size"]),
            report["rate"],
            report["window"],
        )

    _measure(session, lambda report: show_report(out, report, empty, text))


# ----------------------------------------------------------------- publish


def packet_from_values(clnt, md_name, texts, what):
    """A packet of `md_name` filled from 'field: value' texts (validated)."""
    import links_and_nodes as ln

    try:
        _, cls = clnt._topic_model(md_name)
    except ln.LNError as error:
        raise CliError("%s: %s" % (what, lnerror_text(error)), "see 'ln md find'") from None
    packet = cls(name=md_name)
    fill(packet, texts, md_name)
    return packet


def fill(part, texts, md_name):
    """Assigns 'field: value' texts to a packet part; CliError on bad input."""
    fields = parse_field_values(texts)
    try:
        V.assign_fields(part, fields)
    except (AttributeError, TypeError, ValueError) as error:
        raise CliError(str(error), "see 'ln md show %s'" % md_name) from None


def cmd_pub(session):
    import links_and_nodes as ln

    args, out = session.args, session.out
    clnt = session.client()
    md_name = args.type
    if not md_name:
        try:
            md_name = clnt.get_message_definition_for_topic(args.name)[0]
        except ln.LNError:
            raise CliError(
                "topic '%s' does not exist yet, so its message definition is unknown" % args.name,
                "give it with --type MD",
            ) from None
    packet = packet_from_values(clnt, md_name, args.values, "topic '%s'" % args.name)
    try:
        port = clnt.publish(args.name, md_name)
    except ln.LNError as error:
        raise CliError("cannot publish topic '%s': %s" % (args.name, lnerror_text(error))) from None
    port.packet._assign(packet, md_name)
    limit = 1 if args.once else args.count
    if limit:
        _wait_for_subscriber(port, args.wait)
    if not out.json_mode:
        out.line(
            "publishing %s (%s) at %g Hz%s"
            % (
                args.name,
                md_name,
                args.rate,
                ", %d message%s" % (limit, "s" * (limit > 1)) if limit else " until interrupted",
            )
        )
        out.flush()
    sent = 0
    next_time = time.monotonic()
    try:
        while limit is None or sent < limit:
            port.write()
            sent += 1
            if limit is not None and sent >= limit:
                break
            next_time += 1.0 / args.rate
            time.sleep(max(0.0, next_time - time.monotonic()))
        # give subscribers a moment to read the last message before the topic goes
        time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    if out.json_mode:
        out.json(
            {"topic": args.name, "message_definition": md_name, "published": sent, "message": V.to_plain(port.packet)}
        )
    else:
        out.line("published %d message%s" % (sent, "s" * (sent != 1)))


def _wait_for_subscriber(port, seconds):
    """Until the topic has a subscriber (at most `seconds`), then a short
    moment for it to attach: LN delivers nothing written before that."""
    deadline = time.monotonic() + max(0.0, seconds)
    while not port.has_subscriber():
        if time.monotonic() >= deadline:
            return
        time.sleep(0.01)
    time.sleep(0.2)
