"""ln manager status"""

from .common import as_dict, introspect, show_info
from .output import human_duration
from .parsers import add_command, command_group

STATUS_FIELDS = ("version", "pid", "address", "uptime", "clients", "topics", "services", "message_definition_dirs")


def register(groups, common):
    sub = command_group(groups, "manager", "the state of the ln_manager", "The running ln_manager itself.")
    add_command(sub, "status", common, cmd_status, help="version, pid, address, uptime, counts, definition dirs")


def cmd_status(session):
    status = introspect(session, "get_manager_status")
    out = session.out
    info = as_dict(status, STATUS_FIELDS)
    info["message_definition_dirs"] = list(status.message_definition_dirs)
    if not show_info(
        session,
        info,
        [
            ("address", status.address),
            ("version", status.version),
            ("pid", status.pid),
            ("uptime", human_duration(status.uptime)),
            ("clients", "%d (this command included)" % status.clients),
            ("topics", status.topics),
            ("services", status.services),
        ],
    ):
        return
    out.line(out.paint("message definition dirs:", "bold"))
    for directory in info["message_definition_dirs"] or ["(none)"]:
        out.line("  " + directory)
