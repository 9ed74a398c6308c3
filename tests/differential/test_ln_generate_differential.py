"""ln_core's ln_generate / ln_md_info against LN 2.9's ln_generate.

For every message definition LN 2.9 ships (all files below its three share
directories), every definition of our corpus (corpus/md and, through its
md.conf, corpus/md_extra) and the elevator example's definitions, both
generators run on the same names with the same --md-dir options, and we
compare per definition:

  (a) <ID>_MD_NAME            "name|sha256"
  (b) the signature macros    <ID>_SIGNATURE, <ID>_CONNECT_SIGNATURE, <ID>_CALL_SIGNATURE
                              (and their lower-case aliases)
  (c) the generated names     macros, C struct tags and typedefs (exactly equal), C++
                              namespaces/classes/typedefs/methods (LN's all present in ours;
                              ours may add the C++ alias of a plain type, a documented choice
                              of ln_spec.md section 8.2)
  (d) the layout              a C probe built from ln_md_info's JSON prints sizeof and
                              offsetof of every generated struct and member; compiled as C11
                              once against LN's header (LN's include dir) and once against
                              ours (stub ln/ includes), the numbers must equal the JSON.

Runs are batched: one generator run and one probe compile per header set.
"""

from __future__ import annotations

import ln_diff_support as support
import pytest
from ln_diff_support import REPORT

# ------------------------------------------------------------------ sets


def definition_sets(ref: support.Reference | None) -> list[support.DefinitionSet]:
    sets = []
    if ref is not None:
        ln_dirs = ref.md_dirs()
        for sub, d in zip(support.LN29_MD_SUBDIRS, ln_dirs):
            # LN's own definitions refer to each other across these dirs
            # (lnrecorder/* imports ln/string), so all of them are given, the
            # one under test first.
            dirs = (d,) + tuple(x for x in ln_dirs if x != d)
            sets.append(support.DefinitionSet(f"ln29:{sub}", "ln29", dirs, tuple(support.definitions_below(d))))
    corpus_names = support.definitions_below(support.CORPUS_MD_DIR) + support.definitions_below(
        support.CORPUS_EXTRA_DIR
    )
    sets.append(support.DefinitionSet("corpus", "corpus", (support.CORPUS_MD_DIR,), tuple(corpus_names)))
    if support.ELEVATOR_MD_DIR.is_dir():
        sets.append(
            support.DefinitionSet(
                "elevator",
                "elevator",
                (support.ELEVATOR_MD_DIR,),
                tuple(support.definitions_below(support.ELEVATOR_MD_DIR)),
            )
        )
    return sets


_REF = support.find_reference()
SETS = definition_sets(_REF if isinstance(_REF, support.Reference) else None)
SETS_BY_LABEL = {s.label: s for s in SETS}
CASES = [pytest.param(s.label, n, id=f"{s.label}:{n}") for s in SETS for n in s.names]

# ------------------------------------------------------------- results


@pytest.fixture(scope="session")
def differential(reference, our_tools, tool_env, session_dir, c_compiler) -> support.Differential:
    return support.Differential(reference, our_tools, tool_env, session_dir / "differential", c_compiler, SETS)


def _outputs(differential, label, name):
    """(result, LN's header part, our header part) or a test failure that
    says which side could not process the definition."""
    r = differential.result(label)
    ln_part, our_part, problems = support.parts_or_problems(r, name)
    if problems:
        pytest.fail("\n\n".join(problems), pytrace=False)
    return r, ln_part, our_part


# ----------------------------------------------------------------- tests


def test_inventory(reference, differential):
    """Counts what is compared; LN's three share dirs must all have
    definitions."""
    counts = {}
    for s in SETS:
        r = differential.result(s.label)
        counts[s.label] = (len(s.names), len(r.ln.ok_names), len(r.ours.ok_names))
    ln_total = sum(len(s.names) for s in SETS if s.origin == "ln29")
    corpus = SETS_BY_LABEL["corpus"]
    REPORT["LN 2.9 shipped definitions compared"] = (
        f"{ln_total} ("
        + ", ".join(f"{s.label.split(':', 1)[1]}: {len(s.names)}" for s in SETS if s.origin == "ln29")
        + ")"
    )
    REPORT["corpus definitions compared"] = len(corpus.names)
    if "elevator" in SETS_BY_LABEL:
        REPORT["elevator definitions compared"] = len(SETS_BY_LABEL["elevator"].names)
    REPORT["per set: names / accepted by LN / accepted by ours"] = counts
    empty = [s.label for s in SETS if s.origin == "ln29" and not s.names]
    assert not empty, f"LN 2.9 share dirs without definitions: {empty}"
    assert ln_total >= 40, f"only {ln_total} LN 2.9 definitions found below {reference.share_dir}"
    assert len(corpus.names) >= 50, f"the corpus shrank to {len(corpus.names)} definitions"


@pytest.mark.parametrize("label", [s.label for s in SETS])
def test_header_preamble_and_order(differential, label):
    """Same include guard / HAVE_LN_MD_NAME, and definitions (with their
    sub-types first) in the same order."""
    r = differential.result(label)
    if not r.ln.ok_names or not r.ours.ok_names:
        pytest.skip("nothing generated (per-definition tests report why)")
    ln_pre = {n for n in support.generated_names(r.ln_sections[support.PREAMBLE])}
    our_pre = {n for n in support.generated_names(r.our_sections[support.PREAMBLE])}
    assert our_pre == ln_pre, f"{label}: header preamble names differ: LN {sorted(ln_pre)} ours {sorted(our_pre)}"
    our_order = support.section_order(r.ours.output)
    repeated = sorted({n for n in our_order if our_order.count(n) > 1})
    assert not repeated, f"{label}: our header emits these definitions more than once: {repeated}"
    if set(r.ln.ok_names) == set(r.ours.ok_names):
        ln_order = support.section_order(r.ln.output)
        assert our_order == ln_order, (
            f"{label}: definitions are emitted in a different order\nLN:   {ln_order}\nours: {our_order}"
        )


@pytest.mark.parametrize("label,name", CASES)
def test_md_name(differential, label, name):
    r, ln_part, our_part = _outputs(differential, label, name)
    problems = support.md_name_problems(r, name, ln_part, our_part)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("label,name", CASES)
def test_signatures(differential, label, name):
    r, ln_part, our_part = _outputs(differential, label, name)
    problems = support.signature_problems(r, name, ln_part, our_part)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("label,name", CASES)
def test_generated_names(differential, label, name):
    r, ln_part, our_part = _outputs(differential, label, name)
    problems = support.name_differences(ln_part, our_part, name, r.infos.get(name, {}).get("kind"))
    assert not problems, f"{name}: generated names differ\n" + "\n".join(problems)


@pytest.mark.parametrize("label,name", CASES)
def test_layout(differential, label, name):
    r, _, _ = _outputs(differential, label, name)
    problems = support.layout_problems(r, name)
    assert not problems, "\n".join(problems)


def test_our_builtin_definitions_are_ln29s(reference, our_tools, tool_env, work_dir):
    """Every built-in definition ln_core installs is LN 2.9's built-in of that
    name (same name|hash): programs import them by name (`define pyobject as
    "ln2/pyobject"`)."""
    ours = support.definitions_below(support.OUR_BUILTIN_MD_DIR)
    ln_dir = reference.share_dir / "links_and_nodes" / "message_definitions"
    theirs = support.definitions_below(ln_dir)
    assert ours and set(ours) <= set(theirs), f"not LN 2.9 built-ins: {sorted(set(ours) - set(theirs))}"
    REPORT["LN 2.9 built-ins ln_core does not install (yet)"] = sorted(set(theirs) - set(ours))
    out = work_dir / "ln.h"
    ln = support.run([reference.ln_generate, "--md-dir", ln_dir, "-o", out, *ours], tool_env, cwd=work_dir)
    assert ln.returncode == 0, ln.describe()
    info = support.run([our_tools.ln_md_info, "--md-dir", support.OUR_BUILTIN_MD_DIR, *ours], tool_env, cwd=work_dir)
    assert info.returncode == 0, info.describe()
    records = support.parse_json_lines(info.stdout)
    ln_macros = support.macros(out.read_text())
    wrong = [
        f"{n}: LN 2.9 {ln_macros.get(support.identifier(n).upper() + '_MD_NAME')}, ours \"{n}|{records[n]['hash']}\""
        for n in ours
        if ln_macros.get(support.identifier(n).upper() + "_MD_NAME") != f'"{n}|{records[n]["hash"]}"'
    ]
    assert not wrong, "built-ins differ from LN 2.9's:\n" + "\n".join(wrong)


# ------------------------------------------- what LN 2.9 itself cannot do

#: Definitions LN 2.9's ln_generate crashes on (Python tracebacks). Ours must
#: handle each sensibly: a clear one-line error, or -- where the definition
#: has an obvious meaning -- a header that compiles and whose layout agrees
#: with ln_md_info. `ours` says which of these ln_core currently does.
LN_CANNOT_PROCESS = {
    "mutual_recursion": dict(
        files={"c/a": 'define b_t as "b"\ndouble x\nb_t* bs\n', "c/b": 'define a_t as "a"\na_t* as_\n'},
        name="c/a",
        ours="error",
        reason="A holds B* and B holds A*: LN's hash recursion never ends (RecursionError); a signature "
        "cannot say which type '[]' means, so ln_core refuses it too",
    ),
    "self_recursion_via_search_path": dict(
        files={"c/selfsp": 'define self as "c/selfsp"\ndouble v\nself* next\n'},
        name="c/selfsp",
        ours="accept",
        reason="self-recursion is only detected when the define resolves next to the file (as "
        "identical path strings); found through a search-path entry that is not a canonical path "
        "(here the relative --md-dir md) LN recurses forever (RecursionError)",
    ),
    "event_pointer_before_marker": dict(
        files={"c/ev": "event\nchar* early\nconnect\ncall\ndouble v\n"},
        name="c/ev",
        ours="accept",
        reason="a dynamic field before 'connect'/'call' in an event: LN raises KeyError 'connect'",
    ),
    "two_dimensional_array": dict(
        files={"c/m": "double m[2][3]\n"},
        name="c/m",
        ours="error",
        reason="LN evaluates '2][3' with Python eval: SyntaxError traceback",
    ),
    "count_is_a_name": dict(
        files={"c/n": "double x[abc]\n"},
        name="c/n",
        ours="error",
        reason="LN evaluates 'abc' with Python eval: NameError traceback",
    ),
}

#: Definitions LN 2.9 accepts but ln_core deliberately refuses with a clear
#: error (ln_spec.md: grammar requires '"', C/C++-usable names, counts >= 1).
DELIBERATE_DIVERGENCES = {
    "define_in_single_quotes": dict(
        files={"c/q": "define p as 'pt'\np where\n", "c/pt": "float x\n"},
        name="c/q",
        reason="LN strips the first and last character of the quoted name, so 'pt' works there",
    ),
    "service_used_as_type": dict(
        files={"c/svc": "service\nrequest\ndouble a\nresponse\ndouble b\n", "c/uses": 'define s as "svc"\ns x\n'},
        name="c/uses",
        reason="LN embeds the service struct but counts it as 0 bytes in signatures",
    ),
    "cxx_keyword_field": dict(
        files={"c/k": "int class\n"}, name="c/k", reason="LN generates 'int32_t class;', which no C++ compiler accepts"
    ),
    "zero_count": dict(
        files={"c/z": "double x[0]\n"}, name="c/z", reason="LN emits a scalar member but signature 'double 8 0'"
    ),
    "define_redefined_to_another_definition": dict(
        files={
            "c/r": 'define t as "a"\nt x\ndefine t as "b"\nt y\n',
            "c/a": "double v\nint32_t n\n",
            "c/b": "float w\n",
        },
        name="c/r",
        reason="LN gives every field of type t the last target and emits a struct named after c/b holding c/a's fields",
    ),
}


@pytest.mark.parametrize("case", sorted(LN_CANNOT_PROCESS))
def test_ln_cannot_process(case, reference, our_tools, tool_env, work_dir, c_compiler):
    spec = LN_CANNOT_PROCESS[case]
    support.write_definitions(work_dir, spec["files"])
    md = "md"  # relative to work_dir: LN's self-recursion check compares path strings
    ln = support.run(
        [reference.ln_generate, "--md-dir", md, "-o", work_dir / "ln.h", spec["name"]], tool_env, cwd=work_dir
    )
    REPORT.setdefault("LN 2.9 cannot process (ours handles)", {})[case] = spec["reason"]
    assert ln.returncode != 0, (
        f"{case}: LN 2.9 now accepts this ({spec['reason']}); move it to the corpus\n{ln.describe()}"
    )
    out = work_dir / "ours.h"
    ours = support.run([our_tools.ln_generate, "--md-dir", md, "-o", out, spec["name"]], tool_env, cwd=work_dir)
    if spec["ours"] == "error":
        problems = support.single_error_problems(ours)
        assert not problems and not out.exists(), (
            f"{case} ({spec['reason']}): ours should refuse it with one clear error line: "
            f"{problems or ['but wrote ' + str(out)]}\n{ours.describe()}"
        )
        return
    assert ours.returncode == 0, f"{case}: ours no longer accepts this ({spec['reason']})\n{ours.describe()}"
    info = support.run([our_tools.ln_md_info, "--md-dir", md, spec["name"]], tool_env, cwd=work_dir)
    assert info.returncode == 0, f"{case}: ln_md_info fails\n{info.describe()}"
    infos = support.parse_json_lines(info.stdout)
    items = [i for rec in infos.values() for i in support.probe_items(rec)]
    stub = support.write_stub_includes(work_dir / "stub")
    values, error = support.compile_and_run_probe(
        c_compiler, work_dir / "probe", out.read_text(), items, [stub], tool_env, "ours"
    )
    assert error is None, f"{case}: our header does not compile as C: {error}"
    wrong = [f"{i.what} = {v}, ln_md_info says {i.expected}" for i, v in zip(items, values) if v != i.expected]
    assert not wrong, f"{case}: layout differs from ln_md_info:\n  " + "\n  ".join(wrong)


@pytest.mark.parametrize("case", sorted(DELIBERATE_DIVERGENCES))
def test_deliberate_divergence(case, reference, our_tools, tool_env, work_dir):
    spec = DELIBERATE_DIVERGENCES[case]
    md = support.write_definitions(work_dir, spec["files"])
    ln = support.run(
        [reference.ln_generate, "--md-dir", md, "-o", work_dir / "ln.h", spec["name"]], tool_env, cwd=work_dir
    )
    REPORT.setdefault("LN 2.9 accepts, ours refuses (deliberate)", {})[case] = spec["reason"]
    assert ln.returncode == 0, f"{case}: LN 2.9 no longer accepts this\n{ln.describe()}"
    out = work_dir / "ours.h"
    ours = support.run([our_tools.ln_generate, "--md-dir", md, "-o", out, spec["name"]], tool_env, cwd=work_dir)
    problems = support.single_error_problems(ours)
    path = str(md / spec["name"])
    if path not in ours.stderr:
        problems.append(f"the error does not name {path}")
    assert not problems and not out.exists(), (
        f"{case} ({spec['reason']}): ours must refuse it with one clear error line: {problems}\n{ours.describe()}"
    )
