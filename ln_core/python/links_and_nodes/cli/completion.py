"""ln completion bash, and the hidden `ln __complete` the script calls.

The script hands the command line to `ln __complete`, which walks the
argparse tree: subcommands and options come from it, live names (topics,
services, definitions, clients) from the manager, with a short bound when
none runs.
"""

import argparse
import shlex

BASH_SCRIPT = r"""# bash completion for ln (Links and Nodes); load with:  source <(ln completion bash)
_ln_complete() {
    local IFS=$'\n'
    local -a run=("${COMP_WORDS[0]}" __complete "${COMP_LINE:0:COMP_POINT}" "${COMP_WORDS[COMP_CWORD]}")
    command -v timeout >/dev/null 2>&1 && run=(timeout 3 "${run[@]}")
    COMPREPLY=($("${run[@]}" 2>/dev/null))
}
complete -o bashdefault -o default -F _ln_complete ln
"""

#: How long a live-name lookup may take (connecting included).
LIVE_TIMEOUT = 2.0


def register(groups, common):
    p = groups.add_parser(
        "completion",
        help="print a shell completion script",
        description="Prints the completion script for SHELL. Load it with "
        "'source <(ln completion bash)' (e.g. in ~/.bashrc).",
    )
    p.add_argument("shell", choices=("bash",), metavar="SHELL", help="bash")
    p.set_defaults(run=cmd_completion, group_parser=p)
    hidden = groups.add_parser("__complete")  # no help=: not listed
    hidden.add_argument("line")
    hidden.add_argument("word", nargs="?", default=None)
    hidden.set_defaults(run=cmd_complete)


def cmd_completion(session):
    session.out.stream.write(BASH_SCRIPT)


def cmd_complete(session):
    for candidate in complete(session.args.line, session.args.word, session):
        session.out.line(candidate)


def _split(line):
    try:
        words = shlex.split(line)
    except ValueError:  # an open quote
        words = line.split()
    if not line or line[-1].isspace():
        words.append("")
    return words


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return None


def _option(parser, word):
    return parser._option_string_actions.get(word.split("=", 1)[0])


def complete(line, bash_word, session):
    """The candidates for the last word of `line` (the text up to the cursor)."""
    from . import build_parser, is_own_command

    words = _split(line)[1:]  # without "ln"
    current = words.pop()
    if words and not is_own_command(words):
        return []  # the system's ln: bash completes file names
    parser = build_parser()
    positional = 0
    needs_value = None
    manager = None
    for word in words:
        if needs_value is not None:
            if "--ln-manager" in needs_value.option_strings:
                manager = word
            needs_value = None
            continue
        if word.startswith("-"):
            name, equals, value = word.partition("=")
            action = _option(parser, name)
            if action is not None and "--ln-manager" in action.option_strings and equals:
                manager = value
            elif action is not None and action.nargs != 0 and not equals:
                needs_value = action
            continue
        sub = _subparsers(parser)
        if sub is not None and word in sub.choices:
            parser = sub.choices[word]
            positional = 0
            if parser.get_default("passthrough"):
                return []  # ln md generate: ln_generate's arguments, file names
            continue
        positional += 1

    if needs_value is not None:
        candidates = list(needs_value.choices or []) or _live(getattr(needs_value, "completer", None), manager, session)
    elif current.startswith("-"):
        candidates = sorted(s for s in parser._option_string_actions if s.startswith("--") or len(s) == 2)
    else:
        sub = _subparsers(parser)
        if sub is not None:
            candidates = [name for name in sub.choices if not name.startswith("__")]
        else:
            args = [a for a in parser._actions if not a.option_strings and a.nargs not in ("...",)]
            action = (
                args[positional] if positional < len(args) else (args[-1] if args and args[-1].nargs == "*" else None)
            )
            candidates = (
                list(action.choices or [])
                if action is not None and action.choices
                else _live(getattr(action, "completer", None), manager, session)
            )
    chosen = sorted(c for c in candidates if c.startswith(current))
    # bash splits words at ':' and '=' (COMP_WORDBREAKS): answer for its current word
    if bash_word is not None and current.endswith(bash_word) and bash_word != current:
        cut = len(current) - len(bash_word)
        chosen = [c[cut:] for c in chosen]
    return chosen


def _live(kind, manager, session):
    """Names of topics, services, definitions, clients, parameters, processes,
    states or groups; [] when there is no manager."""
    if kind is None:
        return []
    from .common import connect
    from .md import definitions_in, local_dirs

    address = manager or session.manager_address
    if kind == "mds" and not address:
        return list(definitions_in(local_dirs()))
    if not address:
        return []
    try:
        clnt = _connect_bounded(connect, address)
    except Exception:
        return list(definitions_in(local_dirs())) if kind == "mds" else []
    try:
        if kind == "topics":
            return [t.name for t in clnt.list_topics()]
        if kind == "services":
            return [s.name for s in clnt.list_services()]
        if kind == "clients":
            return [c.name for c in clnt.list_clients() if c.name != clnt.name]
        if kind == "parameters":
            from .param import parameters

            return list(parameters(clnt))
        if kind in ("processes", "states", "groups"):
            kinds = {"processes": ("process", "state"), "states": ("state",), "groups": ("group",)}[kind]
            return [p.name for p in clnt.list_processes() if p.kind in kinds]
        if kind == "mds":
            return list(definitions_in(clnt.get_manager_status().message_definition_dirs))
    except Exception:
        return []
    finally:
        clnt.close()
    return []


def _connect_bounded(connect, address):
    """connect() that gives up after LIVE_TIMEOUT (an unreachable host must
    not hang the shell)."""
    import threading

    result = {}

    def attempt():
        try:
            result["client"] = connect(address)
        except Exception as error:
            result["error"] = error

    thread = threading.Thread(target=attempt, daemon=True)
    thread.start()
    thread.join(LIVE_TIMEOUT)
    if "client" not in result:
        raise result.get("error") or TimeoutError("no answer from %s" % address)
    return result["client"]
