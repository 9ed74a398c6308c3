"""ln md show | find | generate"""

import fnmatch
import os
import shutil
import struct
import subprocess

from .common import CliError, introspect, lnerror_text, show_table
from .parsers import add_command, command_group

POINTER_SIZE = struct.calcsize("P")
KIND_NAMES = {"plain": "message", "service": "service", "event": "event"}
#: Files in definition directories that are not definitions.
NOT_DEFINITIONS = (
    ".md",
    ".txt",
    ".rst",
    ".conf",
    ".py",
    ".pyc",
    ".h",
    ".hpp",
    ".c",
    ".cpp",
    ".json",
    ".yaml",
    ".yml",
    ".cmake",
    ".bak",
    ".orig",
    ".swp",
    "~",
)
#: The words after which everything goes to ln_generate unparsed.
GENERATE_COMMAND = ("md", "generate")


def register(groups, common):
    sub = command_group(
        groups,
        "md",
        "show, find and generate message definitions",
        "Message definitions: through the ln_manager when one is reachable, "
        "else (or with --md-dir) on the local search path: --md-dir, the "
        "built-in dirs, ~/ln_message_definitions, $LN_MESSAGE_DEFINITION_DIRS.",
    )

    p = add_command(sub, "show", common, cmd_show, help="definition, size, layout with offsets, signature, hash")
    p.add_argument("name", metavar="MD").completer = "mds"
    _add_md_dir(p)

    p = add_command(
        sub,
        "find",
        common,
        cmd_find,
        help="definitions whose name matches PATTERN",
        description="Lists the definitions on the search path whose name contains PATTERN "
        "(case-insensitive), or matches it when it has wildcards (*, ?, [...]).",
    )
    p.add_argument("pattern", metavar="PATTERN", nargs="?", default="")
    _add_md_dir(p)

    p = sub.add_parser(
        "generate",
        add_help=False,
        help="generate C/C++ headers (runs ln_generate)",
        description="Runs ln_generate with the remaining arguments ('ln md generate --help' shows its options).",
    )
    p.add_argument("arguments", nargs="...", help="ln_generate's arguments")
    p.set_defaults(run=cmd_generate, passthrough=True)


def _add_md_dir(p):
    p.add_argument(
        "--md-dir",
        action="append",
        default=[],
        metavar="DIR",
        help="search this directory, locally, before the others (repeatable)",
    )


# ------------------------------------------------------------ search path


def _prefix_of_package():
    """<prefix> of an installed links_and_nodes (<prefix>/lib/pythonX.Y/site-packages/links_and_nodes)."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return os.path.normpath(os.path.join(package, "..", "..", "..", ".."))


def _expand_md_conf(dirs):
    """LN's md.conf files: each listed line is a further directory."""
    out, pending = [], list(dirs)
    while pending:
        directory = pending.pop(0)
        if directory in out or not os.path.isdir(directory):
            continue
        out.append(directory)
        conf = os.path.join(directory, "md.conf")
        if os.path.isfile(conf):
            with open(conf, encoding="utf-8", errors="replace") as f:
                for line in f:
                    line = line.split("#", 1)[0].strip()
                    if line:
                        pending.append(os.path.normpath(os.path.join(directory, os.path.expanduser(line))))
    return out


def local_dirs(extra=()):
    """LN's search order on this machine."""
    dirs = [os.path.abspath(d) for d in extra]
    share = os.path.join(_prefix_of_package(), "share")
    dirs += [
        os.path.join(share, "links_and_nodes", "message_definitions"),
        os.path.join(share, "ln_runtime", "message_definitions"),
        os.path.expanduser("~/ln_message_definitions"),
    ]
    dirs += [
        os.path.abspath(d.strip()) for d in os.environ.get("LN_MESSAGE_DEFINITION_DIRS", "").split(":") if d.strip()
    ]
    return _expand_md_conf(dirs)


def _manager_client(session):
    """The manager connection, or None when --md-dir asks for the local path
    or no manager is reachable (definitions do not need one)."""
    if session.args.md_dir or not session.manager_address:
        return None
    try:
        return session.client()
    except CliError:
        return None


# ------------------------------------------------------------------ show


def field_lines(fields):
    """'double vec[3]' per field, without the automatic x_len companions."""
    dynamic = {f[0] for f in fields if f[4]}
    return [
        "%s%s %s%s" % (spelling, "*" if is_dynamic else "", name, "[%d]" % count if count > 1 else "")
        for name, spelling, _, _, is_dynamic, count, _ in fields
        if not (name.endswith("_len") and name[:-4] in dynamic)
    ]


def struct_size(fields):
    return sum(POINTER_SIZE if dynamic else element * count for _, _, _, _, dynamic, count, element in fields)


def layout(fields, defs, base=0, prefix=""):
    """Rows {offset, size, type, field} of the packed C struct (a dynamic
    field is a host pointer after its x_len); small sub-types are expanded."""
    rows, offset = [], base
    for name, spelling, _primitive, sub, dynamic, count, element in fields:
        size = POINTER_SIZE if dynamic else element * count
        type_text = spelling + ("*" if dynamic else "") + ("[%d]" % count if count > 1 else "")
        rows.append({"offset": offset, "size": size, "type": type_text, "field": prefix + name})
        if sub and not dynamic:
            sub_fields = defs[sub]["fields"]
            if count == 1:
                rows += layout(sub_fields, defs, offset, prefix + name + ".")
            elif count * len(sub_fields) <= 16:
                for i in range(count):
                    rows += layout(sub_fields, defs, offset + i * element, "%s%s[%d]." % (prefix, name, i))
        offset += size
    return rows


def _load(session, name):
    """(model, text, source) of a definition."""
    import links_and_nodes as ln

    clnt = _manager_client(session)
    try:
        if clnt is not None:
            model = clnt._model(name)
            return model, clnt.get_message_definition_text(name), "ln_manager %s" % session.manager_address
        dirs = local_dirs(session.args.md_dir)
        model = ln._ln.model_from_dirs(name, dirs)
    except ln.LNError as error:
        raise CliError(
            "unknown message definition '%s': %s" % (name, lnerror_text(error)), "see 'ln md find'"
        ) from None
    path = next(os.path.join(d, name) for d in dirs if os.path.isfile(os.path.join(d, name)))
    with open(path, encoding="utf-8", errors="replace") as f:
        return model, f.read(), path


def cmd_show(session):
    out = session.out
    model, text, source = _load(session, session.args.name)
    defs = model.get("defs", {})
    sections = (
        [("fields", model["fields"])]
        if model["kind"] == "plain"
        else [
            ("request" if model["kind"] == "service" else "connect", model["fields"]),
            ("response" if model["kind"] == "service" else "call", model["response_fields"]),
        ]
    )
    info = {
        "name": model["name"],
        "kind": KIND_NAMES.get(model["kind"], model["kind"]),
        "hash": model["hash"],
        "size": model["size"],
        "signature": model["signature"],
        "source": source,
        "text": text,
        "sizes": {label: struct_size(fields) for label, fields in sections},
        "layout": {label: layout(fields, defs) for label, fields in sections},
    }
    if session.json:
        out.json(info)
        return
    size = (
        ("%d bytes" % model["size"])
        if model["kind"] == "plain"
        else ", ".join("%s %d bytes" % (label, n) for label, n in info["sizes"].items())
    )
    out.fields(
        [
            ("definition", model["name"]),
            ("kind", info["kind"]),
            ("size", size),
            ("hash", model["hash"]),
            ("signature", model["signature"] or '""'),
            ("source", source),
        ]
    )
    out.line()
    out.line(out.paint("text:", "bold"))
    for line in text.rstrip("\n").splitlines():
        out.line("  " + line)
    for label, rows in info["layout"].items():
        out.line()
        out.line(out.paint("layout%s:" % ("" if label == "fields" else " of the " + label), "bold"))
        if not rows:
            out.line("  (empty)")
            continue
        table = [("  %d" % r["offset"], r["size"], r["type"], "  " * r["field"].count(".") + r["field"]) for r in rows]
        out.table(("  OFFSET", "SIZE", "TYPE", "FIELD"), table, numeric=(0, 1))


# ------------------------------------------------------------------ find


def _kind_of_file(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                line = line.split("#", 1)[0].strip()
                if line:
                    return {"service": "service", "event": "event"}.get(line, "message")
    except OSError:
        pass
    return "message"


def definitions_in(dirs):
    """{name: path} of every definition file; earlier directories win."""
    found = {}
    for directory in dirs:
        for root, subdirs, files in os.walk(directory):
            subdirs[:] = sorted(d for d in subdirs if not d.startswith("."))
            for filename in sorted(files):
                if filename.startswith(".") or filename == "md.conf" or filename.endswith(NOT_DEFINITIONS):
                    continue
                path = os.path.join(root, filename)
                name = os.path.relpath(path, directory).replace(os.sep, "/")
                found.setdefault(name, path)
    return found


def search_dirs(session):
    clnt = _manager_client(session)
    if clnt is not None:
        return list(introspect(session, "get_manager_status").message_definition_dirs)
    return local_dirs(session.args.md_dir)


def matches(name, pattern):
    if not pattern:
        return True
    if any(c in pattern for c in "*?["):
        return fnmatch.fnmatchcase(name, pattern)
    return pattern.lower() in name.lower()


def cmd_find(session):
    dirs = search_dirs(session)
    pattern = session.args.pattern
    hits = [
        {"name": name, "kind": _kind_of_file(path), "path": path}
        for name, path in sorted(definitions_in(dirs).items())
        if matches(name, pattern)
    ]
    if not hits:
        raise CliError(
            "no message definition matches '%s'" % pattern,
            "searched %d director%s; see 'ln manager status'" % (len(dirs), "y" if len(dirs) == 1 else "ies"),
        )
    show_table(session, hits, ("DEFINITION", "KIND", "FILE"), [(h["name"], h["kind"], h["path"]) for h in hits])


# -------------------------------------------------------------- generate


def ln_generate_path():
    for candidate in (
        os.environ.get("LN_CORE_GENERATE"),
        os.path.join(_prefix_of_package(), "bin", "ln_generate"),
        shutil.which("ln_generate"),
    ):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    raise CliError("ln_generate not found", "put ln_core's bin/ on PATH, e.g. '. launchless_scripts/env.sh'")


def cmd_generate(session):
    return subprocess.call([ln_generate_path()] + list(session.args.arguments))
