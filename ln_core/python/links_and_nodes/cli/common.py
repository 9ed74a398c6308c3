"""What every `ln` command shares: the session (options, output, the
connection to the manager) and errors that become one line for the user."""

import argparse
import math
import os
import re

from .output import Output

#: The name `ln` registers under (the manager makes it unique: "ln_cli 1", ...).
CLIENT_NAME = "ln_cli"


class CliError(Exception):
    """A failure the user can act on: printed as one line, exit status 1."""

    def __init__(self, message, hint=None, status=1):
        Exception.__init__(self, message)
        self.hint = hint
        self.status = status

    def __str__(self):
        text = self.args[0]
        return "%s (%s)" % (text, self.hint) if self.hint else text


class Session:
    """Parsed arguments, the output, and a connection made on first use."""

    def __init__(self, args):
        self.args = args
        self.out = Output(json_mode=getattr(args, "json", False), colour=getattr(args, "color", "auto"))
        self._client = None

    @property
    def json(self):
        return self.out.json_mode

    @property
    def manager_address(self):
        return getattr(self.args, "ln_manager", None) or os.environ.get("LN_MANAGER") or None

    def client(self):
        """The links_and_nodes.client of this command (connects once)."""
        if self._client is None:
            self._client = connect(self.manager_address)
        return self._client

    def close(self):
        if self._client is not None:
            try:
                self._client.close()
            finally:
                self._client = None


def connect(address, name=CLIENT_NAME):
    import links_and_nodes as ln

    if not address:
        raise CliError("no ln_manager address", "set LN_MANAGER=HOST:PORT or pass --ln-manager HOST:PORT")
    try:
        return ln.client(name, address)
    except ln.LNError as error:
        if error.code in (
            ln.LNE_INVALID_MANAGER_ADDRESS,
            ln.LNE_INVALID_HOSTNAME,
            ln.LNE_UNKNOWN_HOSTNAME,
            ln.LNE_HOST_WRONG_NET,
        ):
            raise CliError(
                "invalid ln_manager address '%s': %s" % (address, lnerror_text(error)),
                "give HOST:PORT in LN_MANAGER or --ln-manager",
            ) from None
        raise CliError(
            "cannot reach the ln_manager at %s: %s" % (address, lnerror_text(error)),
            "is it running? check LN_MANAGER or --ln-manager",
        ) from None


def _first_line(error):
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__


def lnerror_text(error):
    """What an LNError says specifically, without the generic description of
    its code ("f(): LNE_X - what LNE_X means - see ln_get_error_message(): ...")."""
    text = re.sub(r"^cannot create client '[^']*': ", "", _first_line(error))
    marker = "see ln_get_error_message(): "
    if marker in text:
        return text.split(marker, 1)[1]
    match = re.match(r"^(?:.*?: )?(LNE_\w+) - (.*)$", text)
    return match.group(2) if match else text


def describe_error(error):
    """One line for an exception from links_and_nodes."""
    from .. import LNError

    return lnerror_text(error) if isinstance(error, LNError) else _first_line(error)


def introspect(session, method):
    """The answer of a manager introspection request of links_and_nodes.client
    (list_topics, list_services, list_clients, get_manager_status)."""
    clnt = session.client()
    request = getattr(clnt, method, None)
    if request is None:
        raise CliError(
            "this links_and_nodes has no client.%s()" % method,
            "the manager introspection API is missing; rebuild ln_core",
        )
    return request()


def by_name(session, method):
    """The answer of introspect(session, method), sorted by name."""
    return sorted(introspect(session, method), key=lambda item: item.name)


def as_dict(obj, names):
    return {name: getattr(obj, name) for name in names}


def find_by_name(items, name, what, list_command):
    for item in items:
        if item.name == name:
            return item
    raise CliError("unknown %s '%s'" % (what, name), "see '%s'" % list_command)


def positive_int(text):
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("'%s' is not a whole number" % text) from None
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1, got %s" % text)
    return value


def positive_float(text):
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("'%s' is not a number" % text) from None
    if not value > 0 or math.isinf(value):
        raise argparse.ArgumentTypeError("must be a positive number, got %s" % text)
    return value


def parse_field_values(texts):
    """values.parse_fields() of 'field: value' arguments; CliError on bad syntax."""
    from . import values

    try:
        return values.parse_fields(texts)
    except values.ValueSyntaxError as error:
        raise CliError(
            "malformed field values %s" % error,
            "write 'field: value, list: [1, 2], sub: {x: 1}'; quote text with spaces",
        ) from None


def no_message(topic, how_long, seconds, info_command):
    """The error of a command that waited in vain for a message on `topic`."""
    return CliError("no message on %s %s %g s" % (topic, how_long, seconds), "is it published? see '%s'" % info_command)


def print_response(out, response, max_array):
    """A service's response (plain data) as 'ln service call' and 'ln ros service call' print it."""
    if out.json_mode:
        out.json(response)
    elif response:
        out.record(response, max_array)
    else:
        out.line(out.paint("(empty response)", "dim"))


def show_table(session, data, headers, rows, **options):
    """A list command's answer: `data` as JSON (--json), or the table of `rows`
    (options: those of Output.table)."""
    if session.json:
        session.out.json(data)
    else:
        session.out.table(headers, rows, **options)


def show_items(session, items, fields, headers, row, **options):
    """A list command's answer on manager objects: their `fields` as JSON
    (--json), or a table with the row(item) of each."""
    show_table(session, [as_dict(i, fields) for i in items], headers, [row(i) for i in items], **options)


def show_info(session, info, pairs):
    """An info command's answer: `info` as JSON (--json), or the (label, value)
    pairs. True when it printed the pairs, for a command that adds more lines."""
    if session.json:
        session.out.json(info)
        return False
    session.out.fields(pairs)
    return True
