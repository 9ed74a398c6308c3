"""Services (ln_spec §1.3, §4.3, §4.6, §5.5): lnbt_services compiled against
LN 2.9 and against ln_core, each against its own manager; the transcripts must
match. Covers service name mapping (--ln-map-service, -ln_map_service,
LN_MAP_SERVICES) on the calling and the providing side, signature and
interface introspection, call errors, and ln_thread_pool_setschedparam()'s
results for an unprivileged program."""

from __future__ import annotations

import os
import shutil

import lnbt_support as support


def run_services(lnbt, system, *args, env=None):
    """Runs lnbt_services to its end; (stdout lines, the program)."""
    program = support.run([system.programs["lnbt_services"], *args], lnbt.client_env(system, **(env or {})))
    return program.lines or ["<no output>"], program


def start_provider(lnbt, system, service, *ln_args, env=None):
    provider = support.Program(
        [system.programs["lnbt_services"], "provide", service, *ln_args],
        lnbt.client_env(system, **(env or {})),
        stdin_pipe=True,
    )
    assert provider.wait_for_line("ready", 15) is not None, provider.describe()
    return provider


def transcripts_for(lnbt, scenario):
    """scenario(system) -> list of lines, run for both systems."""
    return {system.label: scenario(system) for system in lnbt.systems()}


# Deliberate: a call of a service nobody provides fails with
# LNE_NO_PROVIDER_FOUND in ln_core (its manager protocol's code for "no such
# service"), with LNE_REQUEST_FAILED in LN 2.9 (the manager's generic error).
NO_PROVIDER = {"ln29": "call error LNE_REQUEST_FAILED code 0", "ln_core": "call error LNE_NO_PROVIDER_FOUND code 0"}


def no_provider_neutral(label, lines):
    """`lines` with the system's "no provider" call error written as "call error <no provider>"."""
    out = [
        line.replace(NO_PROVIDER[label], "call error <no provider>").replace(
            NO_PROVIDER[label].replace("call error ", "").replace(" code 0", ""), "<no provider>"
        )
        for line in lines
    ]
    if label == "ln_core" and out != lines:
        support.DIFFERENCES.append(
            "calling a service nobody provides: LN 2.9 LNE_REQUEST_FAILED, ln_core LNE_NO_PROVIDER_FOUND"
        )
    return out


def assert_same(transcripts):
    ref = no_provider_neutral("ln29", transcripts["ln29"])
    ours = no_provider_neutral("ln_core", transcripts["ln_core"])
    assert ours == ref, "LN 2.9:\n  " + "\n  ".join(ref) + "\nln_core:\n  " + "\n  ".join(ours)


def same_for_both(lnbt, scenario):
    """The transcripts of `scenario` for both systems, checked to be the same."""
    transcripts = transcripts_for(lnbt, scenario)
    assert_same(transcripts)
    return transcripts


# (id, name the caller uses, LN options, environment); every case should
# reach "lnbt.map.real" (reply "olleh") or show how it misses it.
CALLER_MAPPING_CASES = [
    ("plain", "lnbt.map.real", [], {}),
    ("exact", "alias", ["--ln-map-service", "^alias$", "lnbt.map.real"], {}),
    ("prefix_legacy_option", "x.map.real", ["-ln_map_service", "^x.", "lnbt."], {}),
    ("suffix", "lnbt.map.old", ["--ln-map-service", ".old$", ".real"], {}),
    ("anywhere", "lnbt.MAP.real", ["--ln-map-service", "MAP", "map"], {}),
    ("environment", "env", [], {"LN_MAP_SERVICES": "^env$|lnbt.map.real"}),
    ("environment_pairs", "second", [], {"LN_MAP_SERVICES": "^first$|nothing|^second$|lnbt.map.real"}),
    (
        "environment_then_arguments",
        "chain",
        ["--ln-map-service", ".old$", ".real"],
        {"LN_MAP_SERVICES": "^chain$|lnbt.map.old"},
    ),
    ("which_first", "q", ["--ln-map-service", "^q$", "lnbt.map.nothing"], {"LN_MAP_SERVICES": "^q$|lnbt.map.real"}),
    ("two_arguments_in_order", "r", ["--ln-map-service", "^r$", "s", "--ln-map-service", "^s$", "lnbt.map.real"], {}),
    ("topic_mapping_does_not_apply", "t", ["--ln-map-topic", "^t$", "lnbt.map.real"], {}),
]


def test_service_name_mapping_on_the_calling_side(lnbt):
    def scenario(system):
        provider = start_provider(lnbt, system, "lnbt.map.real")
        lines = []
        try:
            for case_id, name, ln_args, env in CALLER_MAPPING_CASES:
                out, _ = run_services(lnbt, system, "call", name, "hello", *ln_args, env=env)
                lines.append(f"{case_id}: {' / '.join(out)}")
        finally:
            provider.finish(10)
        return lines

    transcripts = same_for_both(lnbt, scenario)
    assert transcripts["ln29"][0] == "plain: reply olleh"


def test_exact_pattern_documented_difference(lnbt):
    """LN 2.9 maps every name that starts with X by the pattern ^X$ (to the
    whole destination); ln_core only the name X itself, as documented
    (ln_spec §5.5)."""

    def scenario(system):
        provider = start_provider(lnbt, system, "lnbt.exact.real")
        try:
            return [
                " / ".join(
                    run_services(lnbt, system, "call", name, "ab", "--ln-map-service", "^alias$", "lnbt.exact.real")[0]
                )
                for name in ("alias", "alias2")
            ]
        finally:
            provider.finish(10)

    transcripts = transcripts_for(lnbt, scenario)
    assert transcripts["ln29"] == ["reply ba", "reply ba"]
    assert transcripts["ln_core"][0] == "reply ba"
    assert transcripts["ln_core"][1] in ("reply ba", NO_PROVIDER["ln_core"])
    if transcripts["ln_core"][1] != "reply ba":
        support.DIFFERENCES.append(
            "--ln-map-service ^alias$ DST: LN 2.9 also maps 'alias2' (a prefix match), ln_core only 'alias'"
        )


def test_service_name_mapping_on_the_providing_side(lnbt):
    def scenario(system):
        providers = [
            start_provider(lnbt, system, "p1", "--ln-map-service", "^p1$", "lnbt.prov.one"),
            start_provider(lnbt, system, "p2", env={"LN_MAP_SERVICES": "^p2$|lnbt.prov.two"}),
        ]
        lines = []
        try:
            for name in ("lnbt.prov.one", "p1", "lnbt.prov.two", "p2"):
                out, _ = run_services(lnbt, system, "call", name, "abc")
                lines.append(f"{name}: {' / '.join(out)}")
            out, _ = run_services(lnbt, system, "introspect", "lnbt/echo", "lnbt.prov.one")
            lines += out
        finally:
            for provider in providers:
                provider.finish(10)
        return lines

    transcripts = same_for_both(lnbt, scenario)
    assert transcripts["ln29"][0] == "lnbt.prov.one: reply cba"


def test_signatures_and_services_by_interface(lnbt):
    def scenario(system):
        providers = [start_provider(lnbt, system, name) for name in ("lnbt.intro.a", "lnbt.intro.b")]
        lines = []
        try:
            out, _ = run_services(lnbt, system, "introspect", "lnbt/echo", "lnbt.intro.a", "lnbt.intro.none")
            lines += out
            out, _ = run_services(lnbt, system, "introspect", "lnbt/counter")
            lines += out
            out, _ = run_services(
                lnbt, system, "introspect", "lnbt/echo", "alias", "--ln-map-service", "^alias$", "lnbt.intro.b"
            )
            lines += ["mapped " + line for line in out]
        finally:
            for provider in providers:
                provider.finish(10)
        return lines

    transcripts = same_for_both(lnbt, scenario)
    assert "find lnbt/echo 2 [lnbt.intro.a|lnbt.intro.b]" in transcripts["ln29"]


def test_call_errors(lnbt):
    def scenario(system):
        provider = start_provider(lnbt, system, "lnbt.err.svc")
        lines = []
        try:
            for args in (("lnbt.err.svc", "x", "42"), ("lnbt.err.none", "x")):
                out, _ = run_services(lnbt, system, "call", *args)
                lines.append(f"{args}: {' / '.join(out)}")
        finally:
            provider.finish(10)
        return lines

    transcripts = transcripts_for(lnbt, scenario)
    # ln_core's extension: ln::exception::error_code carries the provider's
    # own code (LN 2.9 leaves it 0).
    extension = "call error LNE_USER_DEFINED_ERROR code 42"
    if transcripts["ln_core"][0].endswith(extension):
        transcripts["ln_core"][0] = transcripts["ln_core"][0].replace(
            extension, "call error LNE_USER_DEFINED_ERROR code 0"
        )
        support.DIFFERENCES.append(
            "ln::exception::error_code of a provider's own error: LN 2.9 0, ln_core the provider's code (extension)"
        )
    assert_same(transcripts)
    assert transcripts["ln29"][0].endswith("call error LNE_USER_DEFINED_ERROR code 0")


def test_thread_pool_setschedparam_results(lnbt):
    """Return codes for valid and invalid scheduling of a pool's threads,
    from a program without CAP_SYS_NICE and RLIMIT_RTPRIO 0."""
    prefix = []
    if os.geteuid() == 0:
        setpriv = shutil.which("setpriv")
        if setpriv is None:
            support.require(None, "setpriv (util-linux), to run without CAP_SYS_NICE as root")
        prefix = [setpriv, "--bounding-set=-sys_nice", "--inh-caps=-sys_nice"]

    def scenario(system):
        # LN 2.9's 2-thread pool sometimes stalls for good (bench/ln/README.md);
        # its program then ends only by our timeout (-9). That attempt says
        # nothing about setschedparam: run it again, at most four times more
        # (it stalls in about a third of the runs here; a run takes ~1 s).
        attempts = 5 if system.label == "ln29" else 1
        for attempt in range(attempts):
            program = support.run(
                [*prefix, system.programs["lnbt_services"], "sched"], lnbt.client_env(system), timeout=10
            )
            if program.returncode != -9:
                break
            if attempt + 1 < attempts:
                support.DIFFERENCES.append("LN 2.9's thread pool stalled in the sched scenario; run again")
        return program.lines or [f"<no output> {program.describe()}"]

    transcripts = transcripts_for(lnbt, scenario)
    ref, ours = transcripts["ln29"], transcripts["ln_core"]
    assert len(ours) == len(ref), f"LN 2.9: {ref}\nln_core: {ours}"
    assert ref[:4] == ["other_prio0_cpu0 OK", "pool cpus 1", "keep_all OK", "mask_only OK"], ref
    for ref_line, our_line in zip(ref, ours):
        case, ref_result = ref_line.rsplit(" ", 1)
        our_case, our_result = our_line.rsplit(" ", 1)
        assert our_case == case, f"LN 2.9: {ref}\nln_core: {ours}"
        if our_result == ref_result:
            continue
        # Deliberate: LN 2.9 returns success for scheduling it cannot apply
        # (and leaves the threads as they were); ln_core says why it failed.
        assert (ref_result, our_result) == ("OK", "LNE_CHECK_ERRNO"), (
            f"{case}: LN 2.9 {ref_result}, ln_core {our_result}"
        )
        support.DIFFERENCES.append(
            f"ln_thread_pool_setschedparam {case}: LN 2.9 OK (not applied), ln_core LNE_CHECK_ERRNO with the reason"
        )
