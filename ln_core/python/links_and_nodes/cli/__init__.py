"""`ln`: Links and Nodes on the command line.

    ln topic list | info | echo | hz | bw | pub
    ln service list | info | call
    ln param list | get | set | reset
    ln md show | find | generate
    ln client list
    ln manager status
    ln record | play | bag info | bag convert   (the ln_bag package)
    ln ros node list | topic list|info|echo|hz | service list|call   (the ROS 2 side; needs rclpy)
    ln process list | info | start | stop | restart | output
    ln state list | check | up | down
    ln group list | start | stop | restart
    ln completion bash

Every command takes --json (machine-readable output), --ln-manager HOST:PORT
(default: $LN_MANAGER) and --color auto|always|never. Errors are one line on
stderr and a non-zero exit status.

`ln` shadows the system's `ln` (coreutils) on PATH, so anything that is not
one of these commands (`ln -s a b`, `ln a b`) runs the system's `ln`.
"""

import argparse
import os
import sys

from .common import CliError, Session, describe_error

#: The first arguments that belong to this `ln`; anything else is the system's ln.
GROUPS = (
    "topic",
    "service",
    "param",
    "md",
    "client",
    "manager",
    "process",
    "state",
    "group",
    "ros",
    "completion",
    "record",
    "play",
    "bag",
)
OWN_FIRST_ARGUMENTS = GROUPS + ("__complete", "-h", "--help", "--json", "--ln-manager", "--color")
SYSTEM_LN = ("/bin/ln", "/usr/bin/ln")


class ArgumentParser(argparse.ArgumentParser):
    """Usage errors as one line that points to --help."""

    def error(self, message):
        sys.stderr.write("%s: error: %s (see '%s --help')\n" % (self.prog, message, self.prog))
        sys.exit(2)


def common_options():
    """Options every command accepts, before or after the subcommand."""
    common = ArgumentParser(add_help=False)
    common.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="machine-readable JSON output")
    common.add_argument(
        "--ln-manager",
        metavar="HOST:PORT",
        default=argparse.SUPPRESS,
        help="the ln_manager to talk to (default: $LN_MANAGER)",
    )
    common.add_argument(
        "--color",
        choices=("auto", "always", "never"),
        default=argparse.SUPPRESS,
        help="colour the output (default: auto, i.e. on a terminal unless NO_COLOR is set)",
    )
    return common


def build_parser():
    from . import bag, clients, completion, manager, md, param, processes, ros, service, topic

    common = common_options()
    parser = ArgumentParser(
        prog="ln",
        parents=[common],
        description="Links and Nodes on the command line: inspect and use the topics, services, message "
        "definitions, clients and processes of a running ln_manager.",
        epilog="Anything else (e.g. 'ln -s TARGET LINK') runs the system's ln. Each command has --help.",
    )
    groups = parser.add_subparsers(dest="group", metavar="COMMAND")
    for module in (topic, service, param, md, clients, manager, processes, ros, bag, completion):
        module.register(groups, common)
    return parser


def is_own_command(argv):
    first = argv[0] if argv else ""
    return not argv or first in OWN_FIRST_ARGUMENTS or first.split("=", 1)[0] in OWN_FIRST_ARGUMENTS


def run_system_ln(argv):
    """Replaces this process by the system's ln (coreutils)."""
    for path in SYSTEM_LN:
        if os.access(path, os.X_OK):
            os.execv(path, ["ln"] + list(argv))
    sys.stderr.write("ln: '%s' is not an ln command and there is no system ln (see 'ln --help')\n" % argv[0])
    return 127


def parse(parser, argv):
    """parser.parse_args(), except that everything after 'md generate' goes to ln_generate as it is."""
    from .md import GENERATE_COMMAND

    for i in range(len(argv) - 1):
        if argv[i] in GROUPS:
            if tuple(argv[i : i + 2]) == GENERATE_COMMAND:
                args = parser.parse_args(argv[: i + 2])
                args.arguments = argv[i + 2 :]
                return args
            break
    args, extras = parser.parse_known_args(argv)
    # 'FIELD: VALUE' arguments after options (argparse takes positionals
    # only before them when some came first)
    if extras and isinstance(getattr(args, "values", None), list) and not any(e.startswith("-") for e in extras):
        args.values.extend(extras)
    elif extras and not getattr(args, "any_arguments", False):
        parser.error("unrecognized arguments: %s" % " ".join(extras))
    return args


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if not is_own_command(argv):
        return run_system_ln(argv)
    parser = build_parser()
    args = parse(parser, argv)
    run = getattr(args, "run", None)
    if run is None:
        # `ln` or `ln topic` alone: the help of what was given
        (args.group_parser if getattr(args, "group_parser", None) else parser).print_help()
        return 2
    session = Session(args)
    try:
        status = run(session)
        session.out.flush()
        return status or 0
    except CliError as error:
        return _fail(str(error), error.status)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # `ln topic echo x | head`: the reader is gone; stay quiet, also when
        # Python flushes stdout at exit
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 0
    except Exception as error:
        if os.environ.get("LN_CLI_DEBUG"):
            raise
        from .. import LNError

        if isinstance(error, LNError):
            return _fail(describe_error(error))
        return _fail("%s: %s (LN_CLI_DEBUG=1 shows the traceback)" % (type(error).__name__, describe_error(error)))
    finally:
        try:
            session.close()
        except Exception:
            pass


def _fail(message, status=1):
    from .output import colour_wanted

    prefix = "\033[31mln: error:\033[0m" if colour_wanted("auto", sys.stderr) else "ln: error:"
    try:
        sys.stdout.flush()
    except Exception:
        pass
    sys.stderr.write("%s %s\n" % (prefix, message))
    return status
