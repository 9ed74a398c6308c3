"""`ln play FILE`: a recording published back into LN topics, with its original timing.

Which LN topic and definition a channel is played as:
* recorded by `ln record` (LN metadata): the LN topic and definition it was
  recorded from, with the recorded definition texts (handed to the manager
  where it does not know them);
* a ROS 2 channel (cdr + ros2msg schema) whose type was generated from an LN
  definition: that definition -- the one the running LN topic (LN name of the
  ROS topic: /a/b/c -> a.b.c) uses, or the one an installed ln_mapping.json
  (ln_ros2_gen) names -- when its ROS fields are the schema's;
* any other ROS 2 message type: msg_mapping's ROS -> LN definition
  (ros2/<pkg>/msg/<Type>, fixed-size, from the .msg texts in the recording's
  schema), handed to the manager.
"""

import glob
import json
import os
import shutil
import sys
import tempfile
import time

from links_and_nodes.cli.common import CliError, lnerror_text
from links_and_nodes.cli.output import human_duration
from msg_mapping.names import ln_name_for

from ._native import BagError, TopicMapping
from .channels import TOPIC, is_ln_channel, mapping_from_metadata, seconds_from_ns
from .info import mcap_files
from .reading import Recording

PROGRESS_PERIOD = 0.5
#: Messages further ahead than this are not waited for in one piece (Ctrl-C stays responsive).
MAX_SLEEP = 0.2


class Skipped(Exception):
    """A channel that cannot be played (said once, the others play)."""


def _fields(schema_text):
    """The field lines of a ros2msg schema without comments and blank lines: what
    must agree for two schemas to describe the same bytes."""
    lines = []
    for line in schema_text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            lines.append(" ".join(line.split()))
    return lines


def _split_schema(name, text):
    """{"pkg/msg/Type": .msg text} of a ros2msg schema (the type and every type it appends)."""
    texts, current, lines = {}, name, []
    for line in text.splitlines():
        if line.startswith("===") and set(line.strip()) == {"="}:
            texts[current] = "\n".join(lines) + "\n"
            current, lines = None, []
        elif current is None and line.startswith("MSG:"):
            current = line[4:].strip()
        else:
            lines.append(line)
    if current is not None:
        texts[current] = "\n".join(lines) + "\n"
    return texts


def installed_ln_names(ros_type):
    """LN definitions an installed ln_ros2_gen package (share/<pkg>/ln_mapping.json) generated `ros_type` from."""
    import msg_mapping

    names = []
    for share in msg_mapping.ros_share_dirs():
        for path in sorted(glob.glob(os.path.join(share, "*", "ln_mapping.json"))):
            try:
                with open(path, encoding="utf-8") as f:
                    entries = json.load(f).get("interfaces", [])
            except (OSError, ValueError):
                continue
            names += [e["ln_name"] for e in entries if e.get("ros_type") == ros_type and e.get("ln_name")]
    return names


class Player:
    """The channels of one recording, each resolved to an LN topic, definition and codec."""

    def __init__(self, cli, rec):
        self.cli, self.rec = cli, rec
        self.clnt = cli.client()
        self.topics = {}  # channel id -> (LN topic, definition, decode, port)
        self.skipped = {}  # ROS topic -> why
        self.texts = {}  # LN texts fetched from the manager
        self.capacities = {}
        self.put = set()  # definitions handed to the manager
        self._ros_dirs = None

    # -------------------------------------------------------------- resolving
    def resolve(self, channel):
        schema = self.rec.schema_of(channel)
        if is_ln_channel(channel.metadata):
            mapping = mapping_from_metadata(channel.metadata, "%s: channel %s" % (self.rec.path, channel.topic))
            self.ensure_known(mapping.texts, mapping.ln_name, mapping.ln_hash)
            return channel.metadata[TOPIC], mapping.ln_name + "|" + mapping.ln_hash, mapping.cdr_to_ln
        if channel.message_encoding != "cdr" or schema is None or schema.encoding != "ros2msg":
            raise Skipped(
                "messages in '%s' with %s schema: only ROS 2 CDR (ros2msg) can be played"
                % (channel.message_encoding, schema.encoding if schema else "no")
            )
        ln_topic = ln_name_for(channel.topic)
        schema_text = schema.data.decode("utf-8", "replace")
        for md_name in self.ln_candidates(ln_topic, schema.name):
            mapping = self.ln_mapping(md_name)
            if (
                mapping is not None
                and mapping.ros_type == schema.name
                and _fields(mapping.schema) == _fields(schema_text)
            ):
                return ln_topic, mapping.ln_name + "|" + mapping.ln_hash, mapping.cdr_to_ln
        return (ln_topic,) + self.ros_to_ln(schema.name, schema_text)

    def ln_candidates(self, ln_topic, ros_type):
        candidates = []
        try:
            candidates.append(self.clnt.get_message_definition_for_topic(ln_topic)[0])
        except Exception:
            pass
        return candidates + installed_ln_names(ros_type)

    def ln_mapping(self, md_name):
        """TopicMapping of an LN definition as the manager has it, or None."""
        from msg_mapping.manager import load_fetching

        def fetch(missing):
            self.texts[missing] = self.clnt.get_message_definition_text(missing)

        try:
            return load_fetching(lambda name: TopicMapping(name, dict(self.texts)), md_name, fetch, set())
        except Exception:
            return None

    def ros_to_ln(self, ros_type, schema_text):
        """(LN definition, decode) of msg_mapping's LN form of a ROS message type,
        from the .msg texts the recording carries."""
        import msg_mapping

        if self._ros_dirs is None:
            self._ros_dirs = tempfile.mkdtemp(prefix="ln_play_msgs-")
        for full, text in _split_schema(ros_type, schema_text).items():
            package, _, name = full.partition("/")
            name = name.rsplit("/", 1)[-1]
            directory = os.path.join(self._ros_dirs, package, "msg")
            os.makedirs(directory, exist_ok=True)
            with open(os.path.join(directory, name + ".msg"), "w") as f:
                f.write(text)
        try:
            ros = msg_mapping.RosToLn([self._ros_dirs], capacities=self.capacities)
            ln_name = ros.add(ros_type)["ln_name"]
            codec = ros.codec(ros_type)
            texts = ros.definitions()
        except Exception as error:
            raise Skipped("ROS type %s has no LN form: %s" % (ros_type, str(error).splitlines()[0])) from None
        mapping_hash = self.ensure_known(texts, ln_name, None)
        return ln_name + "|" + mapping_hash, codec.cdr_to_ln

    def ensure_known(self, texts, md_name, md_hash):
        """Hands `texts` (name -> definition text) to the manager where it does not
        have them; returns the hash the manager has for md_name."""
        for name in sorted(texts):
            if name in self.put:
                continue
            try:
                known = self.clnt.get_message_definition_text(name)
            except Exception:
                known = None
            if known is None:
                try:
                    self.clnt.put_message_definition(name, texts[name])
                except Exception as error:
                    raise Skipped(
                        "the manager does not take definition '%s': %s" % (name, lnerror_text(error))
                    ) from error
            self.put.add(name)
        manager_hash = self.clnt.get_message_definition(md_name)[2]
        if md_hash and manager_hash != md_hash:
            raise Skipped(
                "the manager's definition '%s' has hash %s, the recording's %s (the definition changed "
                "since the recording; an LN system with the recorded one is needed)" % (md_name, manager_hash, md_hash)
            )
        return manager_hash

    def prepare(self, wanted):
        import links_and_nodes as ln

        for channel in sorted(self.rec.channels.values(), key=lambda c: c.topic):
            names = {channel.topic, channel.metadata.get(TOPIC, ""), ln_name_for(channel.topic)}
            if wanted is not None and not names & wanted:
                continue
            try:
                ln_topic, md_name, decode = self.resolve(channel)
                try:
                    port = self.clnt.publish(ln_topic, md_name)
                except ln.LNError as error:
                    raise Skipped("cannot publish LN topic '%s': %s" % (ln_topic, lnerror_text(error))) from None
            except (Skipped, BagError) as error:
                self.skipped[channel.topic] = str(error)
                self.note("not playing %s: %s" % (channel.topic, error))
                continue
            self.topics[channel.id] = [ln_topic, md_name.split("|")[0], decode, port, 0]
        if wanted is not None:
            known = {
                n
                for c in self.rec.channels.values()
                for n in (c.topic, c.metadata.get(TOPIC, ""), ln_name_for(c.topic))
            }
            for name in sorted(wanted - known):
                self.note("the recording has no topic '%s'" % name)

    def note(self, text):
        sys.stderr.write("ln play: %s\n" % text)
        sys.stderr.flush()

    def close(self):
        if self._ros_dirs:
            shutil.rmtree(self._ros_dirs, ignore_errors=True)

    def wait_for_subscribers(self, seconds):
        """Until every port has a subscriber, at most `seconds` (LN delivers
        nothing written before a subscriber is attached)."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if all(t[3].has_subscriber() for t in self.topics.values()):
                return
            time.sleep(0.02)

    # ---------------------------------------------------------------- playing
    def play_once(self, start_ns, rate, progress):
        """Publishes every message from start_ns on; returns False when interrupted."""
        wall_start = None
        bad = {}
        for channel, message in self.rec.messages(channel_ids=list(self.topics), start_time=start_ns):
            if wall_start is None:
                wall_start, first = time.monotonic(), message.log_time
            due = wall_start + (message.log_time - first) / 1e9 / rate
            while True:
                now = time.monotonic()
                if now >= due:
                    break
                time.sleep(min(MAX_SLEEP, due - now))
                progress.maybe_show(self)
            topic = self.topics[channel.id]
            try:
                packet = topic[2](message.data)
            except Exception as error:
                if channel.topic not in bad:
                    self.note(
                        "skipping messages of %s that do not convert: %s" % (channel.topic, str(error).splitlines()[0])
                    )
                bad[channel.topic] = bad.get(channel.topic, 0) + 1
                continue
            stamp = seconds_from_ns(message.publish_time) if message.publish_time else None
            topic[3].port.write(packet, stamp)
            topic[4] += 1
            progress.count += 1
        return True


class Progress:
    def __init__(self, enabled, path, duration):
        self.enabled, self.path, self.duration = enabled, path, duration
        self.count = 0
        self.started = time.monotonic()
        self.next = self.started + PROGRESS_PERIOD

    def maybe_show(self, player):
        if not self.enabled or time.monotonic() < self.next:
            return
        self.next = time.monotonic() + PROGRESS_PERIOD
        sys.stderr.write(
            "\rplaying %s  %s of %s  %d messages\033[K"
            % (self.path, human_duration(time.monotonic() - self.started), human_duration(self.duration), self.count)
        )
        sys.stderr.flush()

    def clear(self):
        if self.enabled:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()


def capacities(items):
    out = {}
    for item in items:
        key, sep, value = item.rpartition("=")
        if not sep or not key or not value.isdigit():
            raise CliError("--capacity %r: expected TYPE.FIELD=N" % item, "e.g. sensor_msgs/msg/Image.data=6220800")
        out[key] = int(value)
    return out


def run(cli):
    args = cli.args
    try:
        files = mcap_files(args.file)
        if len(files) != 1:
            raise BagError("%s has %d files; ln play plays bags of one file" % (args.file, len(files)))
        rec = Recording(files[0])
    except BagError as error:
        raise CliError(str(error)) from None
    if rec.problem:
        sys.stderr.write("ln play: %s; playing what is readable\n" % rec.problem)
    player = Player(cli, rec)
    player.capacities = capacities(args.capacity)
    interrupted = False
    try:
        player.prepare(set(args.topics) if args.topics else None)
        if not player.topics:
            raise CliError(
                "nothing to play in %s" % args.file,
                "see 'ln bag info %s'" % args.file if not args.topics else "check --topics",
            )
        player.wait_for_subscribers(args.wait)
        start_ns = rec.start_time + int(args.start * 1e9)
        progress = Progress(sys.stderr.isatty() and not cli.json, args.file, (rec.end_time - start_ns) / 1e9)
        try:
            while True:
                player.play_once(start_ns, args.rate, progress)
                if not args.loop:
                    break
        except KeyboardInterrupt:
            interrupted = True
        except BagError as error:
            raise CliError(str(error)) from None
        finally:
            progress.clear()
        time.sleep(0.1)  # subscribers read the last messages before the topics go away
    finally:
        player.close()
        rec.close()
    summary = {
        "file": args.file,
        "messages": progress.count,
        "interrupted": interrupted,
        "topics": [{"ln_topic": t[0], "definition": t[1], "messages": t[4]} for t in player.topics.values()],
        "skipped": player.skipped,
    }
    if cli.json:
        cli.out.json(summary)
    else:
        cli.out.line(
            "played %d messages of %d topics from %s%s"
            % (progress.count, len(player.topics), args.file, " (interrupted)" if interrupted else "")
        )
    return 0
