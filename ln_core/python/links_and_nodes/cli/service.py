"""ln service list | info | call"""

import re

from . import values as V
from .common import CliError, as_dict, find_by_name, introspect, lnerror_text
from .md import field_lines
from .topic import _positive_float, fill

SERVICE_FIELDS = ("name", "interface", "signature", "provider", "group")


def register(groups, common):
    group = groups.add_parser(
        "service", help="list, inspect and call services", description="Services of the running ln_manager."
    )
    group.set_defaults(group_parser=group)
    sub = group.add_subparsers(dest="command", metavar="SUBCOMMAND")

    p = sub.add_parser("list", parents=[common], help="services with interface, provider and group")
    p.set_defaults(run=cmd_list)

    p = sub.add_parser("info", parents=[common], help="one service: interface, signature, request and response")
    p.add_argument("name", metavar="SERVICE").completer = "services"
    p.set_defaults(run=cmd_info)

    p = sub.add_parser(
        "call",
        parents=[common],
        help="call a service and print the response",
        description="Calls SERVICE with a request given as 'field: value' pairs (YAML flow "
        "style, as for 'ln topic pub'; fields not given are 0 or empty) and prints "
        "the response, or the provider's error.",
        epilog="example: ln service call area_service.compute_circle_area 'radius: 2'",
    )
    p.add_argument("name", metavar="SERVICE").completer = "services"
    p.add_argument("values", nargs="*", metavar="'FIELD: VALUE ...'", help="request fields (default: all 0)")
    p.add_argument(
        "--timeout",
        type=_positive_float,
        metavar="SECONDS",
        help="give up after this long (default: wait for the response)",
    )
    p.add_argument(
        "--max-array",
        type=int,
        default=32,
        metavar="N",
        help="show at most N values of an array (default 32; 0: all; not for --json)",
    )
    p.set_defaults(run=cmd_call)


def service_table(session):
    return sorted(introspect(session, "list_services"), key=lambda s: s.name)


def cmd_list(session):
    services = service_table(session)
    out = session.out
    if session.json:
        out.json([as_dict(s, SERVICE_FIELDS) for s in services])
        return
    out.table(
        ("SERVICE", "INTERFACE", "PROVIDER", "GROUP"),
        [(s.name, s.interface, s.provider or "-", s.group or "-") for s in services],
        empty="no services",
    )


def cmd_info(session):
    service = find_by_name(service_table(session), session.args.name, "service", "ln service list")
    model = session.client()._model(service.interface.split("|")[0])
    info = as_dict(service, SERVICE_FIELDS)
    info["request"] = field_lines(model["fields"])
    info["response"] = field_lines(model["response_fields"])
    out = session.out
    if session.json:
        out.json(info)
        return
    out.fields(
        [
            ("service", service.name),
            ("interface", service.interface),
            ("provider", service.provider or None),
            ("group", service.group or None),
            ("signature", service.signature),
        ]
    )
    for section in ("request", "response"):
        out.line(out.paint(section + ":", "bold"))
        for text in info[section] or ["(empty)"]:
            out.line("  " + text)


def cmd_call(session):
    import links_and_nodes as ln

    args, out = session.args, session.out
    clnt = session.client()
    try:
        svc = clnt.get_service(args.name)
    except ln.LNError as error:
        if error.code == ln.LNE_NO_PROVIDER_FOUND:
            raise CliError("no provider for service '%s'" % args.name, "see 'ln service list'") from None
        raise CliError("service '%s': %s" % (args.name, lnerror_text(error))) from None
    fill(svc.req, args.values, svc.interface)
    try:
        svc.call_with_timeout(timeout=args.timeout or 0)
    except ln.LNError as error:
        if error.code == ln.LNE_SVC_TIMEOUT:
            raise CliError("service '%s' did not answer within %g s" % (args.name, args.timeout)) from None
        text = re.sub(r"^call of service '[^']*' failed: ", "", lnerror_text(error))
        raise CliError("service '%s' failed: %s" % (args.name, text)) from None
    response = V.to_plain(svc.resp)
    if out.json_mode:
        out.json(response)
    elif response:
        out.record(response, args.max_array)
    else:
        out.line(out.paint("(empty response)", "dim"))
    # LN's convention (services_wrapper raises ServiceErrorResponse): a
    # non-empty error_message is a failure, though the call itself worked
    error_message = response.get("error_message")
    if isinstance(error_message, str) and error_message.strip():
        out.flush()
        raise CliError(
            "service '%s' answered with error_message: %s" % (args.name, error_message.strip().splitlines()[-1])
        )
