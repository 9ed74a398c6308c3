"""Our ln_generate on broken message definitions, and its command-line
behaviour next to LN 2.9's.

A broken definition must give exactly one clear error line on stderr naming
the file and line (where there is one), a non-zero exit status, and no
output: no new file, and an existing output file left exactly as it was
(content, inode, mtime) -- nothing half-written, no temporary left behind.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import ln_diff_support as support
import pytest

SENTINEL = "/* an existing header that a failed run must not touch */\n"

#: name -> files (relative to the md dir; str text or bytes; None = special
#: entry made in the test), the name to generate, and what the single
#: error line must contain: the file (relative to the md dir) and line, or
#: a text for errors that have no file.
BAD = {
    "unknown_type": dict(files={"b/t": "double a\nvector3 v\n"}, name="b/t", where=("b/t", 2)),
    "count_zero": dict(files={"b/t": "double ok\ndouble x[0]\n"}, name="b/t", where=("b/t", 2)),
    "count_negative": dict(files={"b/t": "double x[-1]\n"}, name="b/t", where=("b/t", 1)),
    "count_not_a_number": dict(files={"b/t": "# c\ndouble x[abc]\n"}, name="b/t", where=("b/t", 2)),
    "count_two_dimensional": dict(files={"b/t": "double x[2][3]\n"}, name="b/t", where=("b/t", 1)),
    "count_unclosed": dict(files={"b/t": "double x[3\n"}, name="b/t", where=("b/t", 1)),
    "duplicate_field": dict(files={"b/t": "double a\nint32_t b\ndouble a\n"}, name="b/t", where=("b/t", 3)),
    "duplicate_field_in_response": dict(
        files={"b/t": "service\nrequest\ndouble a\nresponse\ndouble a\nfloat a\n"}, name="b/t", where=("b/t", 6)
    ),
    "missing_define_target": dict(
        files={"b/t": '# a comment\ndefine t as "nope/missing"\nt x\n'}, name="b/t", where=("b/t", 2)
    ),
    "define_cycle_without_pointer": dict(
        files={"b/a": 'define b_t as "b"\nb_t b\n', "b/b": 'define a_t as "a"\na_t a\n'},
        name="b/a",
        where=(("b/a", 2), ("b/b", 2)),
    ),
    "self_without_pointer": dict(files={"b/s": 'define s_t as "s"\ns_t me\n'}, name="b/s", where=("b/s", 2)),
    "field_name_with_dash": dict(files={"b/t": "double my-field\n"}, name="b/t", where=("b/t", 1)),
    "field_name_keyword": dict(files={"b/t": "double ok\nint class\n"}, name="b/t", where=("b/t", 2)),
    "non_utf8": dict(files={"b/t": b"double ok\ndouble caf\xe9\n"}, name="b/t", where=("b/t", 2)),
    "define_without_quotes": dict(files={"b/t": "define x as noquotes\nx y\n"}, name="b/t", where=("b/t", 1)),
    "pointer_array": dict(files={"b/t": "double* x[3]\n"}, name="b/t", where=("b/t", 1)),
    "line_without_blank": dict(files={"b/t": "double\n"}, name="b/t", where=("b/t", 1)),
    "len_not_an_integer": dict(files={"b/t": "double* x\ndouble x_len\n"}, name="b/t", where=("b/t", 2)),
    # Unreadable entries (the tests run as root, so chmod 000 would not stop
    # a read): a dangling symlink and a directory where a file should be.
    "dangling_symlink": dict(files={"b/t": None}, name="b/t", where="b/t"),
    "directory_instead_of_file": dict(files={"b/t": None}, name="b/t", where="b/t"),
    "define_to_dangling_symlink": dict(
        files={"b/t": 'define d as "gone"\nd x\n', "b/gone": None}, name="b/t", where=("b/t", 1)
    ),
    "define_to_directory": dict(
        files={"b/t": '\ndefine d as "dir"\nd x\n', "b/dir": None}, name="b/t", where=("b/t", 2)
    ),
    "not_found": dict(files={}, name="no/such/definition", where="no/such/definition"),
}


def _make_md_dir(root: Path, case: str, files: dict) -> Path:
    md = root / "md"
    md.mkdir()
    for rel, content in files.items():
        p = md / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if content is None:
            if "dangling" in case or rel.endswith("gone"):
                p.symlink_to(root / "does-not-exist")
            else:
                p.mkdir()
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content, encoding="utf-8")
    return md


def _check_single_error(run: support.Run, md: Path, where) -> list[str]:
    problems = support.single_error_problems(run)
    if run.stdout.strip():
        problems.append(f"unexpected stdout {run.stdout[:200]!r}")
    text = run.stderr
    if isinstance(where, str):
        if where not in text:
            problems.append(f"the error does not mention {where!r}")
    else:
        options = where if isinstance(where[0], tuple) else (where,)
        wanted = [f"{md / rel}:{line}" for rel, line in options]
        if not any(re.search(re.escape(w) + r"\b", text) for w in wanted):
            problems.append(f"the error does not say {' or '.join(wanted)}")
    return problems


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_definition(case, our_tools, tool_env, work_dir):
    spec = BAD[case]
    md = _make_md_dir(work_dir, case, spec["files"])
    out_dir = work_dir / "out"
    out_dir.mkdir()

    # 1. no output file yet: none may appear
    fresh = out_dir / "fresh.h"
    r = support.run([our_tools.ln_generate, "--md-dir", md, "-o", fresh, spec["name"]], tool_env, cwd=work_dir)
    problems = _check_single_error(r, md, spec["where"])
    if fresh.exists():
        problems.append(f"{fresh} was written")

    # 2. an existing output file stays untouched, with and without -f
    existing = out_dir / "existing.h"
    existing.write_text(SENTINEL)
    os.utime(existing, (1_000_000_000, 1_000_000_000))
    before = existing.stat()
    for force in ([], ["-f"]):
        r2 = support.run(
            [our_tools.ln_generate, *force, "--md-dir", md, "-o", existing, spec["name"]], tool_env, cwd=work_dir
        )
        if r2.returncode == 0:
            problems.append(f"with {force or 'no -f'}: exit status 0")
        after = existing.stat()
        if existing.read_text() != SENTINEL or after.st_ino != before.st_ino or after.st_mtime != before.st_mtime:
            problems.append(f"with {force or 'no -f'}: the existing output file was modified or replaced")
    leftovers = sorted(p.name for p in out_dir.iterdir() if p.name != "existing.h")
    if leftovers:
        problems.append(f"files left in the output directory: {leftovers}")
    assert not problems, f"bad definition '{case}':\n  " + "\n  ".join(problems) + "\n" + r.describe()


# ------------------------------------------------------------- CLI options

CORPUS = support.CORPUS_MD_DIR
SERVICE = "ln_core_corpus/services/with_subtypes"
EVENT = "ln_core_corpus/events/simple"
PLAIN = "ln_core_corpus/geometry/pose_stamped"


def _gen(tool, args, env, cwd):
    return support.run([tool, *args], env, cwd=cwd)


def test_up_to_date_and_force(our_tools, tool_env, work_dir):
    out = work_dir / "sub" / "msgs.h"
    args = ["--md-dir", CORPUS, "-o", out, PLAIN]
    first = _gen(our_tools.ln_generate, args, tool_env, work_dir)
    assert first.returncode == 0 and out.is_file(), first.describe()
    os.utime(out, (1_000_000_000, 1_000_000_000))
    before = out.stat()

    second = _gen(our_tools.ln_generate, args, tool_env, work_dir)
    assert second.returncode == 0, second.describe()
    expected = f"{our_tools.ln_generate}: {os.path.realpath(out)} is up to date."
    assert second.stdout.strip() == expected, f"second run without -f: expected {expected!r}\n{second.describe()}"
    after = out.stat()
    assert (after.st_ino, after.st_mtime) == (before.st_ino, before.st_mtime), "an up-to-date header was rewritten"

    forced = _gen(our_tools.ln_generate, ["-f", *args], tool_env, work_dir)
    assert forced.returncode == 0 and not forced.stdout.strip(), forced.describe()
    assert out.stat().st_mtime != before.st_mtime, "-f did not rewrite the header"

    # a changed command line changes the header (its comment): rewritten without -f
    changed = _gen(our_tools.ln_generate, ["--md-dir", CORPUS, "-o", out, PLAIN, EVENT], tool_env, work_dir)
    assert changed.returncode == 0 and "up to date" not in changed.stdout, changed.describe()
    assert "EVENTS_SIMPLE_MD_NAME" in out.read_text()


def test_up_to_date_message_matches_ln(reference, our_tools, tool_env, work_dir):
    """LN prints '<argv0>: <realpath of output> is up to date.'"""
    results = {}
    for who, tool in (("ln", reference.ln_generate), ("ours", our_tools.ln_generate)):
        out = work_dir / who / "x.h"
        out.parent.mkdir()
        link = work_dir / f"{who}_link"
        link.symlink_to(out.parent)  # the message names the resolved path
        args = ["--md-dir", CORPUS, "-o", link / "x.h", PLAIN]
        assert _gen(tool, args, tool_env, work_dir).returncode == 0
        again = _gen(tool, args, tool_env, work_dir)
        assert again.returncode == 0, again.describe()
        results[who] = again.stdout.strip().split(": ", 1)[-1].replace(str(out.parent), "<dir>")
    assert results["ours"] == results["ln"], f"up-to-date message: LN {results['ln']!r}, ours {results['ours']!r}"


def test_output_to_stdout_matches_ln(reference, our_tools, tool_env, work_dir):
    args = ["--md-dir", CORPUS, "-o", "-", SERVICE, EVENT, PLAIN]
    ln = _gen(reference.ln_generate, args, tool_env, work_dir)
    ours = _gen(our_tools.ln_generate, args, tool_env, work_dir)
    assert ln.returncode == 0, ln.describe()
    assert ours.returncode == 0, ours.describe()
    assert not list(work_dir.iterdir()), f"-o - wrote files: {list(work_dir.iterdir())}"
    problems = support.header_differences(ln.stdout, ours.stdout)
    assert not problems, "-o -: headers differ\n  " + "\n  ".join(problems)


def test_default_output_name(our_tools, tool_env, work_dir):
    r = _gen(our_tools.ln_generate, ["--md-dir", CORPUS, PLAIN], tool_env, work_dir)
    assert r.returncode == 0, r.describe()
    header = work_dir / "ln_messages.h"
    assert header.is_file(), f"no ln_messages.h in the working directory: {list(work_dir.iterdir())}"
    assert "#ifndef LN_MESSAGES_H" in header.read_text()


def _compare_with_ln(reference, our_tools, tool_env, work_dir, args, what):
    outs = {}
    for who, tool in (("ln", reference.ln_generate), ("ours", our_tools.ln_generate)):
        d = work_dir / who
        d.mkdir()
        r = _gen(tool, [*args, "-o", d / "ln_messages.h"], tool_env, d)
        assert r.returncode == 0, f"{what}: {who} failed\n{r.describe()}"
        outs[who] = (d / "ln_messages.h").read_text(encoding="utf-8")
    mapping = dict(v.split("=", 1) for o, v in zip(args, args[1:]) if o == "--map-service-base")
    problems = support.header_differences(outs["ln"], outs["ours"], mapping)
    assert not problems, f"{what}: headers differ from LN 2.9's\n  " + "\n  ".join(problems)
    return outs


def test_recursive_matches_ln(reference, our_tools, tool_env, work_dir):
    # LN treats every file below DIR as a definition (an md.conf too), so the
    # directory compared here has none; its definitions import from CORPUS.
    outs = _compare_with_ln(
        reference,
        our_tools,
        tool_env,
        work_dir,
        ["--recursive", support.CORPUS_EXTRA_DIR, "--md-dir", CORPUS],
        f"--recursive {support.CORPUS_EXTRA_DIR}",
    )
    names = set(support.split_sections(outs["ours"]))
    for n in support.definitions_below(support.CORPUS_EXTRA_DIR):
        assert n in names, f"--recursive: {n} not generated"


def test_recursive_skips_md_conf(reference, our_tools, tool_env, work_dir):
    """ln_core skips md.conf files below a --recursive dir, but still
    follows them; LN 2.9 tries to parse md.conf as a definition and fails."""
    md = work_dir / "md"
    (md / "r").mkdir(parents=True)
    (work_dir / "extra" / "x").mkdir(parents=True)
    (md / "md.conf").write_text("../extra\n")
    (md / "r" / "one").write_text('define e as "x/e"\ne thing\n')
    (md / "r" / "two").write_text("service\nrequest\nchar* q\n")
    (work_dir / "extra" / "x" / "e").write_text("double v\n")
    ln = _gen(reference.ln_generate, ["--recursive", md, "-o", "-"], tool_env, work_dir)
    support.REPORT["LN 2.9 --recursive over a dir with md.conf"] = (
        "works" if ln.returncode == 0 else "fails: " + (ln.stderr.strip().splitlines() or ["?"])[-1][:120]
    )
    r = _gen(our_tools.ln_generate, ["--recursive", md, "-o", "-"], tool_env, work_dir)
    assert r.returncode == 0, r.describe()
    assert support.section_order(r.stdout) == ["x/e", "r/one", "r/two"], support.section_order(r.stdout)


def test_mds_from_file(reference, our_tools, tool_env, work_dir):
    """--mds-from-file: one name per line, '#' comments, blanks and
    surrounding blanks ignored, './' stripped. (LN 2.9's own --mds-from-file
    crashes under Python 3 -- it splits bytes with a str -- so ours is
    compared with LN given the same names as arguments.)"""
    names_file = work_dir / "names.txt"
    names_file.write_text(f"# definitions to generate\n\n  {SERVICE}  \n./{EVENT}\n#{PLAIN}\n{PLAIN}\n")
    ln_crash = _gen(
        reference.ln_generate, ["--md-dir", CORPUS, "--mds-from-file", names_file, "-o", "-"], tool_env, work_dir
    )
    ours = _gen(
        our_tools.ln_generate, ["--md-dir", CORPUS, "--mds-from-file", names_file, "-o", "-"], tool_env, work_dir
    )
    ln = _gen(reference.ln_generate, ["--md-dir", CORPUS, "-o", "-", SERVICE, EVENT, PLAIN], tool_env, work_dir)
    assert ours.returncode == 0, ours.describe()
    assert ln.returncode == 0, ln.describe()
    problems = support.header_differences(ln.stdout, ours.stdout)
    assert not problems, "--mds-from-file: headers differ\n  " + "\n  ".join(problems)
    support.REPORT["LN 2.9 --mds-from-file"] = (
        "works"
        if ln_crash.returncode == 0
        else "crashes ("
        + (ln_crash.stderr.strip().splitlines() or ["?"])[-1]
        + "); ours compared with LN given the names"
    )


@pytest.mark.parametrize(
    "options",
    [
        pytest.param(
            ["--map-service-base", f"{SERVICE}=renamed_service", "--map-service-base", f"{EVENT}=renamed_event"],
            id="map-service-base",
        ),
        pytest.param(
            [
                "--map-service-base",
                "ln_core_corpus/geometry/pose=renamed_subtype",
                "--map-service-base",
                f"{PLAIN}=renamed_plain",
            ],
            id="map-service-base-plain",
        ),
        pytest.param(["--wrapping-ns", "outer", "--wrapping-ns", "inner"], id="wrapping-ns"),
        pytest.param(["--prefix-ns-define", "MY_PREFIX_NS"], id="prefix-ns-define"),
        pytest.param(
            ["--wrapping-ns", "w", "--prefix-ns-define", "P_NS", "--map-service-base", f"{SERVICE}=svc"],
            id="all-together",
        ),
    ],
)
def test_naming_options_match_ln(reference, our_tools, tool_env, work_dir, options):
    outs = _compare_with_ln(
        reference,
        our_tools,
        tool_env,
        work_dir,
        ["--md-dir", CORPUS, *options, SERVICE, EVENT, PLAIN],
        " ".join(options),
    )
    # the options must have had a visible effect
    text = outs["ours"]
    for opt, value in zip(options[::2], options[1::2]):
        token = value.split("=", 1)[-1]
        if opt == "--map-service-base" and "plain" in value:
            continue  # LN ignores the mapping for plain definitions
        assert token in text, f"{opt} {value}: {token!r} does not appear in our header"


def test_name_given_as_file_path_matches_ln(reference, our_tools, tool_env, work_dir):
    """A positional name that is not found on the search path but is an
    existing file path (relative to the working directory) is used as it is:
    LN 2.9 names the definition by the path as given ("defs/geo/pose", after
    stripping '.' and '/' at both ends), and its relative imports by
    dirname(that)/import."""
    geo = work_dir / "defs" / "geo"
    geo.mkdir(parents=True)
    (geo / "pose").write_text('define v as "vec"\nv position\ndouble yaw\n')
    (geo / "vec").write_text("double x\ndouble y\n")
    outs = {}
    for who, tool in (("ln", reference.ln_generate), ("ours", our_tools.ln_generate)):
        r = _gen(tool, ["-o", "-", "./defs/geo/pose"], tool_env, work_dir)
        assert r.returncode == 0, f"{who} failed on a file-path name\n{r.describe()}"
        outs[who] = r.stdout
    ln_names = support.section_order(outs["ln"])
    our_names = support.section_order(outs["ours"])
    assert our_names == ln_names, f"definition names differ: LN {ln_names}, ours {our_names}"
    problems = support.header_differences(outs["ln"], outs["ours"])
    assert not problems, "file-path name: headers differ from LN 2.9's\n  " + "\n  ".join(problems)


def test_search_path_order_matches_ln(reference, our_tools, work_dir):
    """--md-dir, ~/ln_message_definitions, $LN_MESSAGE_DEFINITION_DIRS and
    md.conf redirects (relative and '~' entries): the same file wins in LN
    2.9 and in ours (the hash differs per file, so MD_NAME tells)."""
    home = work_dir / "home"
    files = {
        "explicit/o/a": "double a_explicit\n",
        "home/ln_message_definitions/o/a": "double a_home\n",
        "home/ln_message_definitions/o/b": "double b_home\n",
        "envdir/o/a": "double a_env\n",
        "envdir/o/b": "double b_env\n",
        "envdir/o/c": "double c_env\n",
        "envdir/md.conf": "# redirects\n../confdir\n~/more\n",
        "confdir/o/c": "double c_conf\n",
        "confdir/o/d": "double d_conf\n",
        "more/o/e": "double e_more\n",
        "home/more/o/e": "double e_home_more\n",
        "home/more/o/f": "double f_home_more\n",
    }
    for rel, text in files.items():
        p = work_dir / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    env = support.tool_environment(home)
    env["LN_MESSAGE_DEFINITION_DIRS"] = f"{work_dir / 'nonexistent'}:{work_dir / 'envdir'}"
    names = ["o/a", "o/b", "o/c", "o/d", "o/e", "o/f"]
    outs = {}
    for who, tool in (("ln", reference.ln_generate), ("ours", our_tools.ln_generate)):
        r = _gen(tool, ["--md-dir", work_dir / "explicit", "-o", "-", *names], env, work_dir)
        assert r.returncode == 0, f"{who} failed\n{r.describe()}"
        outs[who] = r.stdout
    problems = support.header_differences(outs["ln"], outs["ours"])
    assert not problems, "search path order differs from LN 2.9's\n  " + "\n  ".join(problems)


@pytest.mark.parametrize("output", ["msgs.h", "sub.dir/x.y.h", "msgs.hpp", "my-msgs.h", "2msgs.h"])
def test_include_guard(reference, our_tools, tool_env, work_dir, output):
    """The guard is the output's basename upper-cased with '.' -> '_' (as LN
    2.9); where that is no C identifier (LN writes '#ifndef MY-MSGS_H'), ours
    must still produce a valid one."""
    guards = {}
    for who, tool in (("ln", reference.ln_generate), ("ours", our_tools.ln_generate)):
        d = work_dir / who
        d.mkdir()
        r = _gen(tool, ["--md-dir", CORPUS, "-o", output, PLAIN], tool_env, d)
        assert r.returncode == 0, r.describe()
        m = re.search(r"^#ifndef (\S+)", (d / output).read_text(), re.M)
        guards[who] = m.group(1) if m else None
    ln_valid = re.fullmatch(r"[A-Za-z_]\w*", guards["ln"] or "") is not None
    assert guards["ours"] and re.fullmatch(r"[A-Za-z_]\w*", guards["ours"]), f"invalid guard {guards['ours']!r}"
    if ln_valid:
        assert guards["ours"] == guards["ln"], f"-o {output}: guard LN {guards['ln']} ours {guards['ours']}"
