"""ln service list | info | call"""

import re

from . import values as V
from .common import CliError, as_dict, by_name, find_by_name, lnerror_text, print_response, show_info, show_items
from .md import field_lines
from .parsers import add_command, add_max_array, command_group
from .topic import _positive_float, fill

SERVICE_FIELDS = ("name", "interface", "signature", "provider", "group")


def register(groups, common):
    sub = command_group(groups, "service", "list, inspect and call services", "Services of the running ln_manager.")
    add_command(sub, "list", common, cmd_list, help="services with interface, provider and group")
    p = add_command(sub, "info", common, cmd_info, help="one service: interface, signature, request and response")
    p.add_argument("name", metavar="SERVICE").completer = "services"

    p = add_command(
        sub,
        "call",
        common,
        cmd_call,
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
    add_max_array(p)


def cmd_list(session):
    show_items(
        session,
        by_name(session, "list_services"),
        SERVICE_FIELDS,
        ("SERVICE", "INTERFACE", "PROVIDER", "GROUP"),
        lambda s: (s.name, s.interface, s.provider or "-", s.group or "-"),
        empty="no services",
    )


def cmd_info(session):
    service = find_by_name(by_name(session, "list_services"), session.args.name, "service", "ln service list")
    model = session.client()._model(service.interface.split("|")[0])
    info = as_dict(service, SERVICE_FIELDS)
    info["request"] = field_lines(model["fields"])
    info["response"] = field_lines(model["response_fields"])
    out = session.out
    if not show_info(
        session,
        info,
        [
            ("service", service.name),
            ("interface", service.interface),
            ("provider", service.provider or None),
            ("group", service.group or None),
            ("signature", service.signature),
        ],
    ):
        return
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
    print_response(out, response, args.max_array)
    # LN's convention (services_wrapper raises ServiceErrorResponse): a
    # non-empty error_message is a failure, though the call itself worked
    error_message = response.get("error_message")
    if isinstance(error_message, str) and error_message.strip():
        out.flush()
        raise CliError(
            "service '%s' answered with error_message: %s" % (args.name, error_message.strip().splitlines()[-1])
        )
