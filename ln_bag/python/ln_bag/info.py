"""`ln bag info FILE`: what a recording holds, as `ros2 bag info` shows it."""

import datetime
import os
import sys

import yaml
from links_and_nodes.cli.common import CliError
from links_and_nodes.cli.output import human_bytes

from ._native import BagError
from .channels import DEFINITION, TOPIC
from .reading import Recording


def mcap_files(path):
    """The MCAP files of FILE, or of a rosbag2 bag directory (its metadata.yaml's files)."""
    if not os.path.isdir(path):
        return [path]
    metadata = os.path.join(path, "metadata.yaml")
    try:
        with open(metadata) as f:
            info = (yaml.safe_load(f) or {}).get("rosbag2_bagfile_information") or {}
    except OSError as error:
        raise BagError(
            "%s is a directory without a readable metadata.yaml (%s): not a rosbag2 bag" % (path, error.strerror)
        ) from None
    except yaml.YAMLError as error:
        raise BagError("%s: metadata.yaml is not YAML: %s" % (path, str(error).splitlines()[0])) from None
    if info.get("storage_identifier") not in (None, "mcap"):
        raise BagError("%s: storage '%s' is not supported (only mcap)" % (path, info.get("storage_identifier")))
    files = info.get("relative_file_paths") or []
    if not files:
        raise BagError("%s: metadata.yaml lists no files" % path)
    return [os.path.join(path, f) for f in files]


def _time(ns):
    stamp = datetime.datetime.fromtimestamp(ns / 1e9)
    return "%s (%d.%09d)" % (stamp.strftime("%b %d %Y %H:%M:%S.%f")[:-3], ns // 10**9, ns % 10**9)


def describe(path):
    """The information as plain data (--json prints it)."""
    files, topics, problems = [], {}, []
    start = end = messages = size = 0
    for name in mcap_files(path):
        with Recording(name) as rec:
            files.append(name)
            size += rec.size
            if rec.problem:
                problems.append(rec.problem)
            if rec.message_count:
                start = min(start, rec.start_time) if messages else rec.start_time
                end = max(end, rec.end_time)
            messages += rec.message_count
            for channel in rec.channels.values():
                schema = rec.schema_of(channel)
                entry = topics.setdefault(
                    channel.topic,
                    {
                        "topic": channel.topic,
                        "type": schema.name if schema else "",
                        "serialization_format": channel.message_encoding,
                        "count": 0,
                        "ln_topic": channel.metadata.get(TOPIC, ""),
                        "ln_definition": channel.metadata.get(DEFINITION, ""),
                    },
                )
                entry["count"] += rec.counts.get(channel.id, 0)
    duration = (end - start) / 1e9 if messages else 0.0
    for entry in topics.values():
        entry["rate"] = entry["count"] / duration if duration > 0 else 0.0
    return {
        "files": files,
        "size": size,
        "duration": duration,
        "start": start,
        "end": end,
        "messages": messages,
        "topics": sorted(topics.values(), key=lambda t: t["topic"]),
        "problems": problems,
    }


def run(cli):
    try:
        info = describe(cli.args.file)
    except BagError as error:
        raise CliError(str(error)) from None
    out = cli.out
    if cli.json:
        out.json(info)
    else:
        fields = [
            ("files", ", ".join(info["files"])),
            ("size", human_bytes(info["size"])),
            ("duration", "%.9fs" % info["duration"]),
        ]
        if info["messages"]:
            fields += [("start", _time(info["start"])), ("end", _time(info["end"]))]
        fields.append(("messages", info["messages"]))
        out.fields(fields)
        out.line()
        out.table(
            ("TOPIC", "TYPE", "COUNT", "RATE", "FORMAT", "LN TOPIC", "LN DEFINITION"),
            [
                (
                    t["topic"],
                    t["type"],
                    t["count"],
                    "%.2f Hz" % t["rate"],
                    t["serialization_format"],
                    t["ln_topic"] or "-",
                    t["ln_definition"] or "-",
                )
                for t in info["topics"]
            ],
            numeric=(2, 3),
            empty="no topics",
        )
    for problem in info["problems"]:
        sys.stderr.write(
            "ln bag info: %s ('ln bag convert' rewrites what is readable into a complete file)\n" % problem
        )
    return 0
