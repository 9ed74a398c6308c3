"""ln process list|info|start|stop|restart|output, ln state list|check|up|down,
ln group list|start|stop|restart: the processes, states and groups of the
manager's .lnc config (links_and_nodes.client.list_processes() & co.)."""

import time

from .common import CliError, as_dict, describe_error
from .output import human_duration
from .parsers import add_command, command_group

INFO_FIELDS = (
    "name",
    "kind",
    "state",
    "requested",
    "pid",
    "uptime",
    "restarts",
    "ready",
    "last_exit",
    "error",
    "command",
    "depends_on",
    "members",
)
#: how often a waiting command asks the manager
POLL = 0.05


def register(groups, common):
    sub = _group(
        groups,
        common,
        "process",
        "processes",
        "the processes the manager runs (its .lnc config)",
        "Processes of the running ln_manager's config: list, inspect, start, stop, restart, read their output.",
        "processes with state, pid, uptime, restarts",
        (
            ("start", "start processes (with what they depend on) and wait until they are ready"),
            ("stop", "stop processes (what depends on them first, as configured) and wait"),
            ("restart", "stop and start processes again, and wait until they are ready"),
        ),
    )
    p = add_command(
        sub,
        "info",
        common,
        cmd_info,
        help="one process in detail, with its last output lines",
        description="Everything the manager knows about one process, and its last output lines.",
    )
    p.add_argument("name", help="process name").completer = "processes"
    p.add_argument("-n", "--lines", type=int, default=10, metavar="N", help="output lines to show (default 10)")
    p.set_defaults(kind="process")
    p = add_command(
        sub,
        "output",
        common,
        cmd_output,
        help="what a process printed; -f follows it",
        description="The output lines the manager kept of a process (or state); with -f, "
        "new lines as they come, until Ctrl-C or --duration.",
    )
    p.add_argument("name", help="process or state name").completer = "processes"
    p.add_argument("-n", "--lines", type=int, metavar="N", help="only the last N lines")
    p.add_argument("-f", "--follow", action="store_true", help="keep printing new lines")
    p.add_argument("--duration", type=float, metavar="S", help="with -f: stop following after S seconds")
    _group(
        groups,
        common,
        "state",
        "states",
        "the states the manager checks and brings up or down",
        "States of the running ln_manager's config: conditions checked by a command (check), reached by "
        "others (up, down).",
        "states and what the manager knows of them",
        (
            ("check", "run a state's check command now and show the result"),
            ("up", "bring states up (check first, then their up command) and wait"),
            ("down", "bring states down (check first, then their down command) and wait"),
        ),
    )
    _group(
        groups,
        common,
        "group",
        "groups",
        "start or stop the processes of a group together",
        "Groups of the running ln_manager's config: sets of processes and states, started (states: brought "
        "up) and stopped together.",
        "groups and their members",
        (
            ("start", "start every member and wait until all are ready"),
            ("stop", "stop every member process and wait (states stay as they are)"),
            ("restart", "restart every member process and wait until all are ready"),
        ),
    )


def _group(groups, common, kind, completer, help_text, description, list_help, actions):
    """`ln KIND list` and `ln KIND ACTION NAME...` for each of `actions`; the subparsers."""
    sub = command_group(groups, kind, help_text, description)
    p = add_command(sub, "list", common, cmd_list, help=list_help)
    p.set_defaults(kind=kind)
    for action, text in actions:
        p = add_command(sub, action, common, cmd_control, help=text, description=text[0].upper() + text[1:] + ".")
        p.add_argument("names", nargs="+", metavar="NAME", help="%s name" % kind).completer = completer
        if kind == "process" and action != "stop":
            p.add_argument("--alt", metavar="ALT_COMMAND", help="start with this alt_command of the process")
        p.add_argument("--no-wait", action="store_true", help="return once the manager accepted the request")
        p.add_argument("--timeout", type=float, default=60.0, metavar="S", help="wait at most S seconds (default 60)")
        p.set_defaults(action=action, kind=kind)
    return sub


# --------------------------------------------------------------- commands


def _all(session):
    clnt = session.client()
    if not hasattr(clnt, "list_processes"):
        raise CliError("this links_and_nodes has no client.list_processes()", "rebuild ln_core")
    return clnt.list_processes()


def _by_name(rows):
    return {row.name: row for row in rows}


def _find(rows, name, kind):
    for row in rows:
        if row.name == name:
            if kind and row.kind != kind and not (kind == "process" and row.kind == "state"):
                raise CliError("'%s' is a %s, not a %s" % (name, row.kind, kind), "see 'ln %s'" % row.kind)
            return row
    names = sorted(row.name for row in rows if not kind or row.kind == kind)
    raise CliError(
        "the manager has no %s '%s'" % (kind or "process, state or group", name),
        "it has: %s" % ", ".join(names) if names else "its config has none",
    )


def _uptime(row):
    return human_duration(row.uptime) if row.pid else "-"


def _paint_state(out, state):
    colours = {
        "ready": "green",
        "started": "green",
        "UP": "green",
        "failed": "red",
        "error": "red",
        "restarting": "yellow",
        "starting": "yellow",
        "stopping": "yellow",
        "checking": "yellow",
        "going up": "yellow",
        "going down": "yellow",
    }
    return out.paint(state, colours.get(state, ""))


def cmd_list(session):
    rows = [row for row in _all(session) if row.kind == session.args.kind]
    out = session.out
    if session.json:
        out.json([as_dict(row, INFO_FIELDS) for row in rows])
        return
    kind = session.args.kind
    if kind == "process":
        out.table(
            ("PROCESS", "STATE", "PID", "UPTIME", "RESTARTS", "LAST EXIT", "ERROR"),
            [(r.name, r.state, r.pid or "-", _uptime(r), r.restarts, r.last_exit or "-", r.error or "-") for r in rows],
            numeric=(2, 4),
            empty="no processes (the manager's config has none)",
        )
    elif kind == "state":
        out.table(
            ("STATE", "VALUE", "REQUESTED", "CHECK", "ERROR"),
            [(r.name, r.state, r.requested or "-", r.command or "-", r.error or "-") for r in rows],
            empty="no states (the manager's config has none)",
        )
    else:
        out.table(
            ("GROUP", "RUNNING", "MEMBERS"),
            [(r.name, r.state, list(r.members)) for r in rows],
            empty="no groups (the manager's config has none)",
        )


def cmd_info(session):
    row = _find(_all(session), session.args.name, None)
    clnt = session.client()
    output = clnt.get_process_output(row.name) if row.kind != "group" else None
    lines = list(output.lines[-session.args.lines :]) if output is not None and session.args.lines > 0 else []
    out = session.out
    if session.json:
        info = as_dict(row, INFO_FIELDS)
        info["output"] = lines
        out.json(info)
        return
    out.fields(
        [
            ("name", row.name),
            ("kind", row.kind),
            ("state", _paint_state(out, row.state)),
            ("requested", row.requested or "-"),
            ("pid", row.pid or "-"),
            ("uptime", _uptime(row)),
            ("restarts", row.restarts),
            ("last exit", row.last_exit or "-"),
            ("error", row.error or "-"),
            ("command", row.command or "-"),
            ("depends on", list(row.depends_on)),
            ("members", list(row.members)) if row.kind == "group" else ("ready", "yes" if row.ready else "no"),
        ]
    )
    if lines:
        out.line(out.paint("last output:", "bold"))
        for text in lines:
            out.line("  " + text)


# What `action` is waiting for: True (done), False (failed, with why), None (not yet).
def _outcome(action, row, before):
    if action in ("start", "restart") and row.kind == "process":
        if action == "restart" and before is not None and before.pid and row.pid == before.pid:
            return None, ""
        if row.state == "failed":
            return False, row.error or "failed"
        if row.pid and row.ready and not row.requested:
            return True, "%s (pid %d)" % (row.state, row.pid)
        # a run that ended without error (no_error_on_successful_stop, a one-shot
        # job): the manager no longer asks for it, so it will not come back
        if not row.pid and not row.requested and row.state == "stopped" and row.last_exit:
            return True, "ended (%s)" % row.last_exit
        return None, ""
    if action == "stop":
        if not row.pid and row.state in ("stopped", "failed") and not row.requested:
            return True, "stopped" + (" (%s)" % row.last_exit if row.last_exit else "")
        return None, ""
    if row.kind == "state":
        if row.state == "error":
            return False, row.error or "error"
        if row.requested or row.state in ("checking", "going up", "going down"):
            return None, ""
        if action == "check":
            return True, row.state
        wanted = "UP" if action == "up" else "DOWN"
        return (True, wanted) if row.state == wanted else (None, "")
    return None, ""


def _members(rows, group, action):
    """The processes (and, for start, states) a group action waits for."""
    members = []
    for name in group.members:
        row = rows.get(name)
        if row is None or (row.kind == "state" and action != "start"):
            continue
        members.append(row)
    return members


def cmd_control(session):
    args = session.args
    clnt = session.client()
    rows = _all(session)
    targets = [_find(rows, name, args.kind) for name in args.names]
    before = _by_name(rows)
    for row in targets:
        try:
            clnt.control_process(row.name, args.action, getattr(args, "alt", None))
        except Exception as error:
            raise CliError("cannot %s '%s': %s" % (args.action, row.name, describe_error(error))) from None
    if args.no_wait:
        if session.json:
            session.out.json({row.name: "requested" for row in targets})
        else:
            for row in targets:
                session.out.line("%s: %s requested" % (row.name, args.action))
        return 0
    watched = []
    for row in targets:
        if row.kind == "group":
            sub_action = "up" if args.action == "start" else args.action
            watched += [
                (m, args.action if m.kind == "process" else sub_action) for m in _members(before, row, args.action)
            ]
        else:
            watched.append((row, args.action))
    results = _wait(session, watched, before, args.timeout)
    failed = [name for name, (ok, _) in results.items() if not ok]
    if session.json:
        session.out.json({name: {"ok": ok, "result": text} for name, (ok, text) in results.items()})
    else:
        for name, (ok, text) in results.items():
            session.out.line("%s: %s" % (name, text if ok else session.out.paint(text, "red")))
    if failed:
        raise CliError("%s did not %s" % (", ".join(failed), _verb(args.action)), "see 'ln process info NAME'")
    return 0


def _verb(action):
    """The action as a verb: a state does not "up", it comes up."""
    return {"up": "come up", "down": "go down"}.get(action, action)


def _wait(session, watched, before, timeout):
    """Polls the manager until every (row, action) is done or failed, or the
    timeout passed; {name: (ok, text)}."""
    clnt = session.client()
    deadline = time.monotonic() + timeout
    results = {}
    while True:
        current = _by_name(clnt.list_processes())
        for row, action in watched:
            if row.name in results:
                continue
            now = current.get(row.name)
            if now is None:
                results[row.name] = (False, "no longer known to the manager")
                continue
            ok, text = _outcome(action, now, before.get(row.name))
            if ok is not None:
                results[row.name] = (ok, text)
        if len(results) == len(watched) or time.monotonic() >= deadline:
            break
        time.sleep(POLL)
    for row, action in watched:
        if row.name not in results:
            now = current.get(row.name, row)
            detail = now.state + (", last exit: " + now.last_exit if now.last_exit else "")
            results[row.name] = (False, "did not %s within %g s (now: %s)" % (_verb(action), timeout, detail))
    return results


def cmd_output(session):
    args = session.args
    clnt = session.client()
    out = session.out
    output = clnt.get_process_output(args.name)
    lines = list(output.lines)
    if args.lines is not None:
        lines = lines[-args.lines :] if args.lines > 0 else []
    if session.json and not args.follow:
        out.json({"name": args.name, "lines": lines, "last": output.last, "dropped": output.dropped})
        return
    for text in lines:
        out.line(text)
    if not args.follow:
        return
    out.flush()
    last = output.last
    deadline = time.monotonic() + args.duration if args.duration is not None else None
    while deadline is None or time.monotonic() < deadline:
        time.sleep(0.1)
        more = clnt.get_process_output(args.name, last)
        if more.dropped:
            out.line(out.paint("[%d lines dropped: the manager keeps only its last lines]" % more.dropped, "yellow"))
        for text in more.lines:
            out.line(text)
        if more.lines or more.dropped:
            out.flush()
        if more.lines:
            last = more.first + len(more.lines) - 1
