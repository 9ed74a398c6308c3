"""ln client list"""

from .common import as_dict, introspect

CLIENT_FIELDS = ("name", "id", "pid", "host", "host_id", "published", "subscribed", "services")


def register(groups, common):
    group = groups.add_parser(
        "client",
        help="list the clients of the manager",
        description="Clients (programs) registered with the running ln_manager.",
    )
    group.set_defaults(group_parser=group)
    sub = group.add_subparsers(dest="command", metavar="SUBCOMMAND")
    p = sub.add_parser(
        "list",
        parents=[common],
        help="clients with pid, host, their topics and services",
        description="Every client but this command itself: name, pid, host, the topics it "
        "publishes and subscribes and the services it provides.",
    )
    p.set_defaults(run=cmd_list)


def other_clients(session):
    """The manager's clients without this command's own connection."""
    own = session.client().name
    return sorted((c for c in introspect(session, "list_clients") if c.name != own), key=lambda c: c.name)


def cmd_list(session):
    clients = other_clients(session)
    out = session.out
    if session.json:
        out.json([as_dict(c, CLIENT_FIELDS) for c in clients])
        return
    out.table(
        ("CLIENT", "PID", "HOST", "PUBLISHES", "SUBSCRIBES", "SERVICES"),
        [(c.name, c.pid, c.host, list(c.published), list(c.subscribed), list(c.services)) for c in clients],
        numeric=(1,),
        empty="no clients",
    )
