"""ln manager status"""

from .common import as_dict, introspect
from .output import human_duration

STATUS_FIELDS = ("version", "pid", "address", "uptime", "clients", "topics", "services", "message_definition_dirs")


def register(groups, common):
    group = groups.add_parser(
        "manager", help="the state of the ln_manager", description="The running ln_manager itself."
    )
    group.set_defaults(group_parser=group)
    sub = group.add_subparsers(dest="command", metavar="SUBCOMMAND")
    p = sub.add_parser("status", parents=[common], help="version, pid, address, uptime, counts, definition dirs")
    p.set_defaults(run=cmd_status)


def cmd_status(session):
    status = introspect(session, "get_manager_status")
    out = session.out
    info = as_dict(status, STATUS_FIELDS)
    info["message_definition_dirs"] = list(status.message_definition_dirs)
    if session.json:
        out.json(info)
        return
    out.fields(
        [
            ("address", status.address),
            ("version", status.version),
            ("pid", status.pid),
            ("uptime", human_duration(status.uptime)),
            ("clients", "%d (this command included)" % status.clients),
            ("topics", status.topics),
            ("services", status.services),
        ]
    )
    out.line(out.paint("message definition dirs:", "bold"))
    for directory in info["message_definition_dirs"] or ["(none)"]:
        out.line("  " + directory)
