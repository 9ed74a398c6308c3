"""Client name selection, manager address choice and the remaining
arguments (ln_spec §5.3, §5.4): lnbt_probe compiled against LN 2.9 and
against ln_core, each against its own manager; the outputs must match."""

from __future__ import annotations

import time

import lnbt_support as support
import pytest


def probe(lnbt, system, mode, name, *args, env=None, timeout=support.PROGRAM_TIMEOUT):
    """Runs lnbt_probe; returns (exit status, stdout lines with argv[0] made
    system-neutral, the program)."""
    program = support.run(
        [system.programs["lnbt_probe"], mode, name, *args], lnbt.client_env(system, **(env or {})), timeout=timeout
    )
    exe = str(system.programs["lnbt_probe"])
    lines = [line.replace(exe, "PROBE") for line in program.lines] or ["<no output>"]
    return program.returncode, lines, program


def both(lnbt, mode, name, *args, env_for=None, **kwargs):
    """Runs the same probe on both systems; env_for(system) gives the extra
    environment (it may depend on the system's manager address)."""
    results = {}
    for system in lnbt.systems():
        env = env_for(system) if env_for else None
        results[system.label] = probe(lnbt, system, mode, name, *args, env=env, **kwargs)
    return results


def assert_same(results, context=""):
    ref, ours = results["ln29"], results["ln_core"]
    assert (ours[0], ours[1]) == (ref[0], ref[1]), (
        f"{context}\nLN 2.9:\n{ref[2].describe()}\n\nln_core:\n{ours[2].describe()}"
    )


NAME_CASES = [
    # id, code name, extra args, extra environment
    ("plain", "lnbt_plain", [], {}),
    ("with_space", "my client", [], {}),
    ("env_program_name", "lnbt_code", [], {"LN_PROGRAM_NAME": "lnbt_from_env"}),
    (
        "arg_program_name_beats_env",
        "lnbt_code",
        ["--ln-program-name", "lnbt_from_arg", "x", "y"],
        {"LN_PROGRAM_NAME": "lnbt_from_env"},
    ),
    ("legacy_arg_program_name", "lnbt_code", ["-ln_program_name", "lnbt_legacy"], {}),
    ("last_program_name_wins", "lnbt_code", ["--ln-program-name", "p1", "--ln-program-name", "p2"], {}),
    ("exact_ignores_env", "exact:lnbt_exact_env", [], {"LN_PROGRAM_NAME": "ignored"}),
    ("option_without_value_is_kept", "lnbt_novalue", ["--ln-program-name"], {}),
    (
        "map_options_are_consumed",
        "lnbt_map",
        ["x", "--ln-map-topic", "a", "b", "y", "-ln_map_service", "c", "d", "z"],
        {},
    ),
    ("gnu_equals_form_is_not_an_option", "lnbt_eq", ["--ln-program-name=eq"], {}),
    # With an exact: name LN 2.9 does not consume --ln-program-name NAME: it
    # stays in get_remaining_args().
    ("exact_keeps_program_name_option", "exact:lnbt_exact_arg", ["--ln-program-name", "other", "x"], {}),
    ("exact_keeps_legacy_program_name_option", "exact:lnbt_exact_arg2", ["-ln_program_name", "other"], {}),
]


@pytest.mark.parametrize("case", NAME_CASES, ids=[c[0] for c in NAME_CASES])
def test_name_selection(lnbt, case):
    _, name, args, env = case
    assert_same(both(lnbt, "client", name, *args, env_for=lambda s: env), f"name case {case}")


def test_duplicate_names_get_a_counter_and_exact_fails(lnbt):
    """dup, dup -> 'dup 1', dup -> 'dup 2'; exact:dup -> LNE_CLNT_NAME_IN_USE;
    LN_PROGRAM_NAME=dup counts too; after the first holder left its name is
    free again."""
    transcripts = {}
    for system in lnbt.systems():
        env = lnbt.client_env(system)
        lines = []
        holders = []
        try:
            for _ in range(2):
                holder = support.Program(
                    [system.programs["lnbt_probe"], "hold", "lnbt_dup", "30"], env, stdin_pipe=True
                )
                holders.append(holder)
                assert holder.wait_for_line("ready", 10) is not None, holder.describe()
                lines.append(next(line for line in holder.lines if line.startswith("name ")))
            for mode, name, extra in (
                ("client", "lnbt_dup", {}),
                ("client", "exact:lnbt_dup", {}),
                ("client", "lnbt_other", {"LN_PROGRAM_NAME": "lnbt_dup"}),
                ("client", "exact:lnbt_dup 1", {}),
            ):
                rc, out, _ = probe(lnbt, system, mode, name, env=extra)
                lines.append(f"{name!r} -> rc {rc} {[l for l in out if not l.startswith('args')]}")
            holders[0].finish(10)
            # The manager notices the first holder's exit; its name is free again.
            deadline = time.monotonic() + 20
            while True:
                rc, out, _ = probe(lnbt, system, "client", "exact:lnbt_dup")
                if rc == 0 or time.monotonic() > deadline:
                    break
                time.sleep(0.1)
            lines.append(f"after release -> rc {rc} {[l for l in out if not l.startswith('args')]}")
        finally:
            for holder in holders:
                holder.finish(10)
        transcripts[system.label] = lines
    assert transcripts["ln_core"] == transcripts["ln29"]
    assert transcripts["ln29"][:2] == ["name lnbt_dup", "name lnbt_dup 1"]
    assert "LNE_CLNT_NAME_IN_USE" in transcripts["ln29"][3]


def test_manager_address_argument_beats_ln_manager(lnbt):
    """--ln-manager / -ln_manager and an explicit constructor address win over
    LN_MANAGER; an empty explicit address falls back to LN_MANAGER."""
    dead = f"127.0.0.1:{support.free_port()}"
    for system in lnbt.systems():
        good = lnbt.address(system)
        for mode, args, env in (
            ("client", ["--ln-manager", good], {"LN_MANAGER": dead}),
            ("client", ["-ln_manager", good], {"LN_MANAGER": dead}),
            ("client", ["--ln-manager", good], {"LN_MANAGER": None}),
            ("client_to", [good], {"LN_MANAGER": dead}),
            ("client_to", [""], {}),
        ):
            rc, lines, program = probe(lnbt, system, mode, "lnbt_addr", *args, env=env)
            assert rc == 0 and lines[0] == "name lnbt_addr", f"{system} {mode} {args} {env}\n{program.describe()}"
            if mode == "client":
                assert lines[1] == "args PROBE|client|lnbt_addr", program.describe()


# Address forms on which LN 2.9 and ln_core differ on purpose: ln_core parses
# HOST:PORT strictly (a decimal port 1..65535 and nothing after it) where LN
# 2.9 uses atoi() on the text after the first ':' and passes the host to
# gethostbyname() unchecked. Values: (LN 2.9 result, ln_core result); "name"
# means the client connected. {port} is the manager's port.
ADDRESS_DIFFERENCES = {
    "127.0.0.1:": ("error LNE_CHECK_ERRNO", "error LNE_INVALID_MANAGER_ADDRESS"),
    "127.0.0.1:abc": ("error LNE_CHECK_ERRNO", "error LNE_INVALID_MANAGER_ADDRESS"),
    "127.0.0.1:{port}x": ("name", "error LNE_INVALID_MANAGER_ADDRESS"),
    "127.0.0.1:{port}:5": ("name", "error LNE_INVALID_MANAGER_ADDRESS"),
    "127.0.0.1 :{port}": ("name", "error LNE_UNKNOWN_HOSTNAME"),
    "[::1]:{port}": ("error LNE_INVALID_HOSTNAME", "error LNE_INVALID_MANAGER_ADDRESS"),
}

ADDRESS_CASES = [
    ("no_address", None, "error LNE_NO_MANAGER_ADDRESS"),
    ("no_colon", "localhost", "error LNE_INVALID_MANAGER_ADDRESS"),
    ("empty_host", ":{port}", "error LNE_INVALID_HOSTNAME"),
    ("host_name", "localhost:{port}", "name"),
    ("connection_refused", "127.0.0.1:{dead}", "error LNE_CHECK_ERRNO"),
]


@pytest.mark.parametrize("case", ADDRESS_CASES, ids=[c[0] for c in ADDRESS_CASES])
def test_manager_address_errors(lnbt, case):
    _, template, expected = case
    dead = support.free_port()
    results = {}
    for system in lnbt.systems():
        port = lnbt.address(system).rsplit(":", 1)[1]
        value = None if template is None else template.format(port=port, dead=dead)
        rc, lines, program = probe(lnbt, system, "client", "lnbt_address", env={"LN_MANAGER": value})
        results[system.label] = (lines[0].split(" ")[0] if lines[0].startswith("name") else lines[0], program)
        if expected == "error LNE_CHECK_ERRNO":
            assert "Connection refused" in program.stderr, program.describe()
    assert results["ln29"][0] == expected, results["ln29"][1].describe()
    assert results["ln_core"][0] == results["ln29"][0], results["ln_core"][1].describe()


@pytest.mark.parametrize("template", sorted(ADDRESS_DIFFERENCES))
def test_manager_address_documented_differences(lnbt, template):
    """Malformed addresses: LN 2.9's result is as documented; ln_core's is
    either LN 2.9's (difference gone) or the documented strict one."""
    observed = {}
    for system in lnbt.systems():
        port = lnbt.address(system).rsplit(":", 1)[1]
        rc, lines, program = probe(
            lnbt, system, "client", "lnbt_address", env={"LN_MANAGER": template.format(port=port)}
        )
        observed[system.label] = (lines[0].split(" ")[0] if lines[0].startswith("name") else lines[0], program)
    ref_expected, ours_documented = ADDRESS_DIFFERENCES[template]
    assert observed["ln29"][0] == ref_expected, observed["ln29"][1].describe()
    assert observed["ln_core"][0] in (ref_expected, ours_documented), observed["ln_core"][1].describe()
    if observed["ln_core"][0] != ref_expected:
        support.DIFFERENCES.append(
            f"LN_MANAGER={template!r}: LN 2.9 {ref_expected}, ln_core {observed['ln_core'][0]} (strict HOST:PORT)"
        )


# Deliberate: ln_core treats an empty name (in code or in LN_PROGRAM_NAME) as
# absent and falls back to the program's name; LN 2.9 registers the empty
# string as the client name.
EMPTY_NAME_CASES = [
    ("empty_code_name", "", {}, "name ", "name lnbt_probe"),
    ("empty_exact_name", "exact:", {}, "name ", "name lnbt_probe"),
    ("empty_env_program_name", "lnbt_code_empty", {"LN_PROGRAM_NAME": ""}, "name ", "name lnbt_code_empty"),
]


@pytest.mark.parametrize("case", EMPTY_NAME_CASES, ids=[c[0] for c in EMPTY_NAME_CASES])
def test_empty_names_documented_difference(lnbt, case):
    _, name, env, ref_expected, ours_documented = case
    results = both(lnbt, "client", name, env_for=lambda s: env)
    ref, ours = results["ln29"], results["ln_core"]
    assert ref[0] == 0 and ref[1][0] == ref_expected, ref[2].describe()
    assert ours[0] == 0 and ours[1][0] in (ref_expected, ours_documented), ours[2].describe()
    if ours[1][0] != ref_expected:
        support.DIFFERENCES.append(
            f"client name {name!r} env {env}: LN 2.9 {ref[1][0]!r}, ln_core {ours[1][0]!r} (empty = absent)"
        )
