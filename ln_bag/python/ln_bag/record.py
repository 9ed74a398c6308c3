"""`ln record`: LN topics into an MCAP file (or a rosbag2 bag directory).

The Python side finds the topics (the manager's topic list, polled so that
topics appearing later are recorded too), gets their definitions' texts from
the manager and maps them (TopicMapping); the compiled Recorder reads,
converts and writes on threads of its own, so Python only shows progress.
"""

import fnmatch
import math
import os
import signal
import sys
import time

from links_and_nodes.cli.common import CliError, introspect
from links_and_nodes.cli.output import human_bytes, human_duration
from msg_mapping.manager import load_fetching

from . import rosbag2
from ._native import BagError, McapWriter, Recorder, TopicMapping
from .channels import channel_metadata, ns_from_seconds, ros_topic_for
from .ln29 import call_payload

#: Subscriptions hold this much of a topic's traffic (at the rate the manager measured) ...
BUFFER_SECONDS = 0.5
#: ... but at least this many packets, and at most this many bytes per topic.
MIN_BUFFERS = 16
MAX_BUFFER_BYTES = 32 << 20
#: Buffers for a topic whose rate is not known yet.
UNKNOWN_RATE_BUFFERS = 512
DISCOVERY_PERIOD = 1.0
PROGRESS_PERIOD = 0.5


def buffers_for(rate, packet_size):
    """Subscription buffers for a topic of `rate` packets/s (0: unknown)."""
    wanted = UNKNOWN_RATE_BUFFERS if not rate else max(MIN_BUFFERS, math.ceil(rate * BUFFER_SECONDS))
    by_memory = max(2, MAX_BUFFER_BYTES // max(1, packet_size))
    return int(min(wanted, by_memory))


class Selection:
    """Which topics to record: names or globs given, or --all minus --exclude."""

    def __init__(self, patterns, everything, excludes):
        self.patterns = list(patterns)
        self.everything = everything
        self.excludes = list(excludes)

    def wants(self, topic):
        if any(fnmatch.fnmatchcase(topic, e) for e in self.excludes):
            return False
        return self.everything or any(fnmatch.fnmatchcase(topic, p) for p in self.patterns)

    def wants_service(self, service):
        return not any(fnmatch.fnmatchcase(service, e) for e in self.excludes)

    def missing(self, seen):
        """Exact names given that the manager does not list yet."""
        return [p for p in self.patterns if not any(c in p for c in "*?[") and p not in seen]


class Definitions:
    """LN definition texts as the manager has them, shared by all topics."""

    def __init__(self, clnt):
        self.clnt = clnt
        self.texts = {}
        self.fetched = set()

    def mapping(self, md_name, part=""):
        def fetch(missing):
            self.texts[missing] = self.clnt.get_message_definition_text(missing)

        return load_fetching(lambda name: TopicMapping(name, dict(self.texts), part=part), md_name, fetch, self.fetched)


def output_paths(args):
    """(MCAP file, rosbag2 directory or None); refuses to overwrite recordings."""
    if args.rosbag2 and args.output:
        raise CliError("give either -o FILE.mcap or --rosbag2 DIR, not both")
    if args.rosbag2:
        directory = args.rosbag2.rstrip("/") or args.rosbag2
        if os.path.exists(directory):
            raise CliError("%s already exists" % directory, "rosbag2 bags are new directories; choose another name")
        return os.path.join(directory, rosbag2.mcap_name(directory)), directory
    path = args.output or time.strftime("ln_record_%Y_%m_%d-%H_%M_%S.mcap")
    if os.path.exists(path) and not args.overwrite:
        raise CliError("%s already exists" % path, "choose another name or pass --overwrite")
    return path, None


class Session:
    """One recording: writer, recorder, the topics added so far."""

    def __init__(self, cli, path):
        self.cli = cli
        self.args = cli.args
        self.path = path
        self.clnt = cli.client()
        self.definitions = Definitions(self.clnt)
        self.selection = Selection(self.args.topics, self.args.all, self.args.exclude)
        self.topics = {}  # LN topic -> ROS type
        self.failed = {}  # LN topic -> why it is not recorded
        self.waiting_said = set()
        self.progress = Progress(sys.stderr.isatty() and not cli.json)
        self.services = None
        try:
            self.writer = McapWriter(path)
            self.recorder = Recorder(
                self.writer,
                cli.manager_address,
                client_name="ln_record",
                max_messages=self.args.count or 0,
                max_seconds=self.args.duration or 0.0,
            )
        except BagError as error:
            raise CliError(str(error)) from None

    def discover(self):
        seen = set()
        for topic in introspect(self.cli, "list_topics"):
            seen.add(topic.name)
            if topic.name in self.topics or topic.name in self.failed or not self.selection.wants(topic.name):
                continue
            self.add(topic)
        for name in self.selection.missing(seen):
            if name not in self.waiting_said:
                self.waiting_said.add(name)
                self.note("waiting for topic '%s' to appear" % name)

    def add(self, topic):
        md_name = topic.message_definition.split("|")[0]
        try:
            mapping = self.definitions.mapping(md_name)
            if topic.hash and mapping.ln_hash != topic.hash:
                raise BagError(
                    "the manager's text of '%s' has hash %s, but the topic uses %s"
                    % (md_name, mapping.ln_hash, topic.hash)
                )
            buffers = self.args.buffers or buffers_for(topic.rate, mapping.packet_size)
            self.recorder.add_topic(
                topic.name,
                ros_topic_for(topic.name),
                mapping,
                channel_metadata(topic.name, mapping, topic.publisher),
                buffers,
            )
        except Exception as error:
            self.failed[topic.name] = str(error).strip().splitlines()[0]
            self.note("not recording topic '%s': %s" % (topic.name, self.failed[topic.name]))
            return
        self.topics[topic.name] = mapping.ros_type

    def note(self, text):
        self.progress.clear()
        sys.stderr.write("ln record: %s\n" % text)
        sys.stderr.flush()


class ServiceCallWriter:
    """Writes service calls as LN's service logging reports them: the request
    and the response of a call each go to the channel NAME/_request or
    NAME/_response of its service (created on first use, definition from the
    manager), sequence = the request id, publish_time = when the caller
    (request) or the provider (response) completed it."""

    def __init__(self, session):
        self.session = session
        self.channels = {}  # (service, interface, part) -> (channel id, mapping)
        self.counts = {}  # service -> messages recorded (requests + responses)

    def record(self, service, interface, client, item_type, flags, request_id, completion_time, payload):
        log_time = time.time_ns()
        part, flat = call_payload(item_type, flags, payload, "service '%s'" % service)
        key = (service, interface, part)
        if key not in self.channels:
            mapping = self.session.definitions.mapping(interface, part)
            metadata = channel_metadata(service, mapping, client if part == "response" else None, part)
            self.channels[key] = (
                self.session.recorder.add_channel(ros_topic_for(service, part), mapping, metadata),
                mapping,
            )
        channel, mapping = self.channels[key]
        self.session.recorder.post_message(
            channel, request_id & 0xFFFFFFFF, log_time, ns_from_seconds(completion_time), mapping.ln_to_cdr(flat)
        )
        self.counts[service] = self.counts.get(service, 0) + 1


class ServiceCalls(ServiceCallWriter):
    """--services: the manager's service logging (ln_register_as_service_logger)
    sends every call's request and response to a service of ours (interface
    ln/log_service, as for LN 2.9's lnrecorder), served by a thread pool."""

    GROUP = "ln_record_log_service"

    def __init__(self, session):
        ServiceCallWriter.__init__(self, session)
        clnt = session.clnt
        self.name = clnt.name + ".log_service"
        self.failed = {}  # service -> why its calls are not recorded
        self.provider = clnt.get_service_provider(self.name, "ln/log_service")
        self.provider.set_handler(self.handle)
        self.provider.do_register(self.GROUP)
        clnt.handle_service_group_in_thread_pool(self.GROUP, "ln_record")
        clnt.register_as_service_logger(self.name, "*")

    def handle(self, request, req, resp):
        import numpy as np

        service = str(req.service_name)
        if service not in self.failed and self.session.selection.wants_service(service):
            try:
                self.record(
                    service,
                    str(req.service_interface),
                    str(req.client_name),
                    int(req.item_type),
                    int(req.flags),
                    int(req.request_id),
                    float(req.completion_time),
                    np.asarray(req.data, dtype=np.uint8).tobytes(),
                )
            except Exception as error:
                self.failed[service] = str(error).strip().splitlines()[0]
                self.session.note("not recording calls of service '%s': %s" % (service, self.failed[service]))
        resp.error_message = ""
        request.respond()
        return 0


class Progress:
    """A block of lines on a terminal (stderr), redrawn in place."""

    MAX_TOPIC_LINES = 12

    def __init__(self, enabled):
        self.enabled = enabled
        self.lines = 0

    def clear(self):
        if self.enabled and self.lines:
            sys.stderr.write("\033[%dF\033[J" % self.lines)
            self.lines = 0

    def show(self, path, seconds, stats):
        if not self.enabled:
            return
        total = sum(s["messages"] for s in stats)
        size = sum(s["bytes"] for s in stats)
        lost = sum(s["lost"] for s in stats)
        lines = [
            "recording %s  %s  %d messages  %s  %d topics  lost %d"
            % (path, human_duration(seconds), total, human_bytes(size), len(stats), lost)
        ]
        shown = sorted(stats, key=lambda s: (-s["lost"], s["topic"]))[: self.MAX_TOPIC_LINES]
        width = max((len(s["topic"]) for s in shown), default=0)
        for s in shown:
            error = "  (%s)" % s["error"] if s["error"] else ""
            lines.append(
                "  %-*s  %9d msgs  %10s  lost %d%s"
                % (width, s["topic"], s["messages"], human_bytes(s["bytes"]), s["lost"], error)
            )
        if len(stats) > len(shown):
            lines.append("  ... %d more topics" % (len(stats) - len(shown)))
        self.clear()
        sys.stderr.write("\n".join(lines) + "\n")
        sys.stderr.flush()
        self.lines = len(lines)


def run(cli):
    """ln record."""
    args = cli.args
    if not args.topics and not args.all:
        raise CliError("no topics to record", "name topics (globs allowed) or pass --all")
    if args.topics and args.all:
        raise CliError("give topic names or --all, not both", "with --all, leave topics out with --exclude GLOB")
    path, bag_dir = output_paths(args)
    if bag_dir:
        os.makedirs(bag_dir)
    # A file size limit makes write() fail (EFBIG) instead of killing us.
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    session = None
    try:
        session = Session(cli, path)
        if args.services:
            session.services = ServiceCalls(session)
    except Exception as error:
        # nothing is recorded yet: no empty file or bag stays behind
        if session is not None:
            session.recorder.stop()
            try:
                session.writer.close()
            except BagError:
                pass
            os.unlink(path)
        if bag_dir and not os.listdir(bag_dir):
            os.rmdir(bag_dir)
        if session is not None and not isinstance(error, CliError):
            from links_and_nodes.cli.common import describe_error

            raise CliError(
                "--services: cannot record service calls: %s" % describe_error(error),
                "the manager's service logging (ln_register_as_service_logger) is needed",
            ) from None
        raise
    previous_term = signal.signal(signal.SIGTERM, _interrupt)
    started = time.monotonic()
    interrupted = False
    try:
        session.discover()
        session.recorder.start()
        next_discovery = time.monotonic() + DISCOVERY_PERIOD
        while not session.recorder.wait(PROGRESS_PERIOD):
            session.progress.show(path, time.monotonic() - started, session.recorder.stats())
            if time.monotonic() >= next_discovery:
                session.discover()
                next_discovery = time.monotonic() + DISCOVERY_PERIOD
    except KeyboardInterrupt:
        interrupted = True
    finally:
        signal.signal(signal.SIGTERM, previous_term)
        session.recorder.stop()
        session.progress.clear()
    seconds = time.monotonic() - started
    stats = session.recorder.stats()
    failure = session.recorder.error
    try:
        session.writer.close()
    except BagError as error:
        failure = str(error)
    if bag_dir and not failure:
        rosbag2.write_metadata(bag_dir, path)
    report(cli, path, bag_dir, seconds, stats, session, interrupted, session.writer.written)
    if failure:
        raise CliError(failure)
    return 0


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def report(cli, path, bag_dir, seconds, stats, session, interrupted, written):
    out = cli.out
    summary = {
        "file": path,
        "rosbag2": bag_dir,
        "seconds": round(seconds, 3),
        "interrupted": interrupted,
        "file_bytes": written["file_bytes"],
        "write_seconds": round(written["write_seconds"], 6),
        "messages": sum(s["messages"] for s in stats),
        "bytes": sum(s["bytes"] for s in stats),
        "lost": sum(s["lost"] for s in stats),
        "topics": [dict(s, type=session.topics.get(s["topic"], "")) for s in stats],
        "not_recorded": session.failed,
    }
    if session.services:
        summary["services"] = dict(session.services.counts)
        summary["not_recorded"] = dict(session.failed, **session.services.failed)
    if cli.json:
        out.json(summary)
        return
    out.line(
        "recorded %d messages (%s) of %d topics in %s to %s%s"
        % (
            summary["messages"],
            human_bytes(summary["bytes"]),
            len(stats),
            human_duration(seconds),
            bag_dir or path,
            ", lost %d" % summary["lost"] if summary["lost"] else "",
        )
    )
    if stats:
        out.table(
            ("TOPIC", "TYPE", "MESSAGES", "BYTES", "LOST"),
            [
                (s["topic"], session.topics.get(s["topic"], ""), s["messages"], human_bytes(s["bytes"]), s["lost"])
                for s in sorted(stats, key=lambda s: s["topic"])
            ],
            numeric=(2, 3, 4),
        )
