"""ln param list | get | set | reset: the parameters clients provide
(parameter blocks, LN 2.9's or ln_core's), as LN 2.9's manager shows them
in its parameters tab."""

from .common import CliError, lnerror_text, show_info, show_table
from .output import format_number, format_scalar
from .parsers import add_command, command_group

PROVIDER_PREFIX = "ln.parameters.query_dict."


def register(groups, common):
    sub = command_group(
        groups,
        "param",
        "list, read and override parameters",
        "Parameters that clients provide (parameter blocks). Names are full "
        "names ('controller.gain'); LN_PARAMETER_PREFIX is not applied.",
    )

    p = add_command(sub, "list", common, cmd_list, help="parameters with their value, override and provider")
    p.add_argument(
        "prefix", nargs="?", default="", metavar="PREFIX", help="only the parameters below this group (default: all)"
    )

    p = add_command(sub, "get", common, cmd_get, help="a parameter: value in effect, input, override, description")
    p.add_argument("name", metavar="PARAMETER").completer = "parameters"

    p = add_command(
        sub,
        "set",
        common,
        cmd_set,
        help="override a parameter",
        description="Overrides PARAMETER with VALUE, written as in Python: 2.5, true, "
        "[1, 2, 3], [[1, 0], [0, 1]]. Waits until the provider's next update "
        "applied it, unless --no-wait.",
        epilog="example: ln param set controller.gain 2.5",
    )
    p.add_argument("name", metavar="PARAMETER").completer = "parameters"
    p.add_argument("value", metavar="VALUE")
    p.add_argument("--no-wait", action="store_true", help="return without waiting for the provider's update")

    p = add_command(sub, "reset", common, cmd_reset, help="end the override of a parameter")
    p.add_argument("name", metavar="PARAMETER").completer = "parameters"
    p.add_argument("--no-wait", action="store_true", help="return without waiting for the provider's update")


def parameters(clnt, prefix=""):
    """{full name: value dict} of every provider (values as query_dict answers them)."""
    from .._parameters import parameters_proxy

    proxy = parameters_proxy(clnt, prefix, allow_empty=True, use_parameter_prefix=False)
    found = {}
    for _, _, value in proxy._all_parameters():
        found[value["full_name"]] = value
    return dict(sorted(found.items()))


def provider(value):
    service = value["service"]
    return service[len(PROVIDER_PREFIX) :] if service.startswith(PROVIDER_PREFIX) else service


def plain(value):
    """numpy values as lists and numbers."""
    tolist = getattr(value, "tolist", None)
    return tolist() if tolist is not None else value


def in_effect(value):
    return value["output"] if value["override_enabled"] else value["input"]


def text(value):
    value = plain(value)
    if isinstance(value, list):
        return "[%s]" % ", ".join(text(v) for v in value)
    return format_number(value) if isinstance(value, float) else format_scalar(value)


def record(name, value):
    return {
        "name": name,
        "value": plain(in_effect(value)),
        "input": plain(value["input"]),
        "output": plain(value["output"]),
        "override_enabled": bool(value["override_enabled"]),
        "description": value.get("description", ""),
        "provider": provider(value),
    }


def find(session, name):
    value = parameters(session.client(), name).get(name)
    if value is None:
        raise CliError("unknown parameter '%s'" % name, "see 'ln param list'")
    return value


def cmd_list(session):
    found = parameters(session.client(), session.args.prefix)
    show_table(
        session,
        [record(name, value) for name, value in found.items()],
        ("PARAMETER", "VALUE", "OVERRIDE", "PROVIDER", "DESCRIPTION"),
        [
            (
                name,
                text(in_effect(value)),
                "yes (input %s)" % text(value["input"]) if value["override_enabled"] else "-",
                provider(value),
                value.get("description") or "-",
            )
            for name, value in found.items()
        ],
        empty="no parameters" + (" below '%s'" % session.args.prefix if session.args.prefix else ""),
    )


def cmd_get(session):
    name = session.args.name
    info = record(name, find(session, name))
    show_info(
        session,
        info,
        [
            ("parameter", name),
            ("value", text(info["value"])),
            ("input", text(info["input"])),
            ("override", "yes" if info["override_enabled"] else "no"),
            ("provider", info["provider"]),
            ("description", info["description"] or None),
        ],
    )


def override(session, name, text_value):
    import links_and_nodes as ln

    value = find(session, name)
    service = value["service"].replace("query_dict", "override_dict_single")
    svc = session.client().get_service(service, "ln/parameters/override_dict_single")
    svc.req.parameter_name = name
    svc.req.override_data = text_value
    svc.req.wait_step = 0 if session.args.no_wait else 1
    try:
        svc()
    except ln.LNError as error:
        raise CliError("parameter '%s': %s" % (name, lnerror_text(error))) from None
    if svc.resp.error:
        # the provider's answer names the parameter (LN 2.9's: on its last line)
        raise CliError(svc.resp.error.strip().splitlines()[-1].strip())


def cmd_set(session):
    value = session.args.value.strip()
    if not value:
        raise CliError("no value", "give one, e.g. 2.5 or [1, 2]; 'ln param reset' ends an override")
    override(session, session.args.name, value)
    if session.json:
        session.out.json(record(session.args.name, find(session, session.args.name)))


def cmd_reset(session):
    override(session, session.args.name, "")
    if session.json:
        session.out.json(record(session.args.name, find(session, session.args.name)))
