"""ln client list"""

from .common import introspect, show_items
from .parsers import add_command, command_group

CLIENT_FIELDS = ("name", "id", "pid", "host", "host_id", "published", "subscribed", "services")


def register(groups, common):
    sub = command_group(
        groups,
        "client",
        "list the clients of the manager",
        "Clients (programs) registered with the running ln_manager.",
    )
    add_command(
        sub,
        "list",
        common,
        cmd_list,
        help="clients with pid, host, their topics and services",
        description="Every client but this command itself: name, pid, host, the topics it "
        "publishes and subscribes and the services it provides.",
    )


def other_clients(session):
    """The manager's clients without this command's own connection."""
    own = session.client().name
    return sorted((c for c in introspect(session, "list_clients") if c.name != own), key=lambda c: c.name)


def cmd_list(session):
    show_items(
        session,
        other_clients(session),
        CLIENT_FIELDS,
        ("CLIENT", "PID", "HOST", "PUBLISHES", "SUBSCRIBES", "SERVICES"),
        lambda c: (c.name, c.pid, c.host, list(c.published), list(c.subscribed), list(c.services)),
        numeric=(1,),
        empty="no clients",
    )
