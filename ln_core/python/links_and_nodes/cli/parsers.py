"""How the `ln` commands declare themselves and the options several share (argparse)."""

from .common import positive_int


def command_group(groups, name, help, description, dest="command", metavar="SUBCOMMAND"):
    """`ln NAME SUBCOMMAND ...`: the parser of NAME (alone, it prints its --help)
    and returns the subparsers its subcommands are added to."""
    group = groups.add_parser(name, help=help, description=description)
    group.set_defaults(group_parser=group)
    return group.add_subparsers(dest=dest, metavar=metavar)


def add_command(sub, name, common, run, **kwargs):
    """A (sub)command with the common options that runs `run(session)`;
    kwargs go to add_parser (help, description, epilog)."""
    p = sub.add_parser(name, parents=[common], **kwargs)
    p.set_defaults(run=run)
    return p


def add_max_array(p, not_for="--json"):
    p.add_argument(
        "--max-array",
        type=int,
        default=32,
        metavar="N",
        help="show at most N values of an array (default 32; 0: all; not for %s)" % not_for,
    )


def add_count_options(p, verb):
    """--once and --count of the commands that print or publish messages."""
    p.add_argument("--once", action="store_true", help="%s one message and exit (same as --count 1)" % verb)
    p.add_argument("--count", "-n", type=positive_int, metavar="N", help="exit after N messages")
