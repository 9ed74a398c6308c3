"""Random message definitions (md_generator.py) through LN 2.9's ln_generate
and ours.

Valid trees: defines in every section (also repeated), aliases, comments,
blank and tab variants, count expressions, nested sub-types, arrays of them,
dynamic fields with implicit or declared `_len`, self-recursion, services
and events. Every generated definition must be accepted by both, with the
same <ID>_MD_NAME (hash), signature macros, generated names, the same C
declarations (macros and structs, blanks normalised) and the same layout (sizeof/offsetof from
both headers compiled as C, equal to ln_md_info's).

Invalid definitions: one mutation of a valid one each. What LN 2.9 refuses,
ours must refuse; what ours refuses beyond that must be a documented
deliberate difference (md_generator.MUTATIONS).

Seeded and bounded for CI (about 30 s on 2 cores). A longer run:
    LN_RANDOM_MD_SEEDS=100 LN_RANDOM_MD_SIZE=60 python -m pytest tests/differential/test_random_definitions.py
(seeds 1..N; LN_RANDOM_MD_FIRST_SEED moves the start).
"""

from __future__ import annotations

import concurrent.futures
import os
import random
import re

import ln_diff_support as support
import md_generator
import pytest
from ln_diff_support import REPORT

FIRST_SEED = int(os.environ.get("LN_RANDOM_MD_FIRST_SEED", "1"))
SEEDS = range(FIRST_SEED, FIRST_SEED + int(os.environ.get("LN_RANDOM_MD_SEEDS", "3")))
#: top-level definitions per seed (plus half as many sub-types)
SIZE = int(os.environ.get("LN_RANDOM_MD_SIZE", "24"))
#: invalid definitions per seed
INVALID = int(os.environ.get("LN_RANDOM_MD_INVALID", str(len(md_generator.MUTATIONS))))


def _reproduce(seed: int) -> str:
    return (
        f"reproduce: LN_RANDOM_MD_FIRST_SEED={seed} LN_RANDOM_MD_SEEDS=1 LN_RANDOM_MD_SIZE={SIZE} "
        f"python -m pytest tests/differential/test_random_definitions.py"
    )


_BLANKS = re.compile(r"[ \t]+")


def c_declarations(part: str) -> list[str]:
    """The C part of a header part: macros and struct declarations, without
    comments, includes, guards and `#ifdef __cplusplus` blocks, blanks
    normalised. (The C++ classes are compared by name only: ln_core writes
    its own.)"""
    text = re.sub(r"/\*.*?\*/", "", part, flags=re.S)
    out, skipping = [], 0
    for line in text.splitlines():
        code = re.sub(r" ([\[;])", r"\1", _BLANKS.sub(" ", line).strip())  # LN keeps "x [3]", "x ;"
        if skipping:
            if code.startswith("#if"):
                skipping += 1
            elif code.startswith("#endif"):
                skipping -= 1
            continue
        if code == "#ifdef __cplusplus":
            skipping = 1
        elif code and (not code.startswith("#") or code.startswith("#define")):
            out.append(code)
    return out


@pytest.mark.parametrize("seed", SEEDS)
def test_random_valid_definitions(seed, reference, our_tools, tool_env, work_dir, c_compiler):
    tree = md_generator.RandomDefinitions(seed)
    tops = tree.build(sub_types=max(2, SIZE // 2), top_level=SIZE)
    md = support.write_definitions(work_dir, tree.files())
    names = tuple(tree.definitions)  # sub-types too: each is a definition of its own
    dset = support.DefinitionSet(f"random{seed}", "random", (md,), names)
    r = support.Differential(reference, our_tools, tool_env, work_dir / "out", c_compiler).compute(dset)
    problems = []
    for name in names:
        ln_part, our_part, found = support.parts_or_problems(r, name)
        if not found:
            found = (
                support.md_name_problems(r, name, ln_part, our_part)
                + support.signature_problems(r, name, ln_part, our_part)
                + [
                    f"{name}: {p}"
                    for p in support.name_differences(ln_part, our_part, name, r.infos.get(name, {}).get("kind"))
                ]
                + support.layout_problems(r, name)
            )
            if not found and c_declarations(ln_part) != c_declarations(our_part):
                found = [f"{name}: the C declarations differ\n--- LN 2.9 ---\n{ln_part}\n--- ours ---\n{our_part}"]
        if found:
            text = tree.definitions[name].text
            problems.append("\n".join(found) + f"\n--- definition {name} ---\n{text}")
    REPORT.setdefault("random valid definitions compared", {})[seed] = f"{len(names)} ({len(tops)} top-level)"
    assert not problems, (
        f"seed {seed}: {len(problems)} of {len(names)} definitions differ ({_reproduce(seed)})\n\n"
        + "\n\n".join(problems[:5])
    )


@pytest.mark.parametrize("seed", SEEDS)
def test_random_invalid_definitions(seed, reference, our_tools, tool_env, work_dir):
    tree = md_generator.RandomDefinitions(seed)
    tree.build(sub_types=4, top_level=8)
    rng = random.Random(seed * 7919)
    cases = []
    for i in range(INVALID):
        mutation = md_generator.MUTATIONS[i % len(md_generator.MUTATIONS)]
        candidates = [d for d in tree.definitions.values() if d.name not in tree.sub_types]
        rng.shuffle(candidates)
        for definition in candidates:
            text = md_generator.mutate(rng, definition, mutation, tree.sub_types)
            if text is not None:
                cases.append((i, mutation, definition.name, text))
                break

    def run_case(case):
        i, mutation, name, text = case
        files = dict(tree.files())
        files[name] = text
        md = support.write_definitions(work_dir / f"case{i}", files)
        out = work_dir / f"case{i}"
        ln = support.run([reference.ln_generate, "--md-dir", md, "-o", out / "ln.h", name], tool_env, cwd=out)
        ours = support.run([our_tools.ln_generate, "--md-dir", md, "-o", out / "ours.h", name], tool_env, cwd=out)
        return case, ln, ours

    problems, counts = [], {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        for (_i, mutation, name, text), ln, ours in pool.map(run_case, cases):
            ln_ok, ours_ok = ln.returncode == 0, ours.returncode == 0
            outcome = f"LN {'accepts' if ln_ok else 'refuses'}, ours {'accepts' if ours_ok else 'refuses'}"
            counts.setdefault(outcome, []).append(mutation.kind)
            where = f"mutation {mutation.kind} of {name}:\n{text}"
            if not ln_ok and ours_ok:
                problems.append(f"LN 2.9 refuses, ours accepts -- {where}\nLN 2.9: {ln.stderr.strip()[-600:]}")
            elif ln_ok and not ours_ok and mutation.ours_stricter is None:
                problems.append(
                    f"LN 2.9 accepts, ours refuses without a documented reason -- {where}\nours: {ours.stderr.strip()}"
                )
            elif ln_ok and mutation.ours_stricter is not None and ours_ok:
                problems.append(f"ours accepts what it documents to refuse ({mutation.ours_stricter}) -- {where}")
            elif not ours_ok and ("Traceback" in ours.stderr or len(ours.stderr.strip().splitlines()) != 1):
                problems.append(f"ours refuses without one clear error line -- {where}\n{ours.stderr}")
    REPORT.setdefault("random invalid definitions", {})[seed] = {k: len(v) for k, v in counts.items()}
    assert len(cases) >= min(INVALID, len(md_generator.MUTATIONS)) // 2, f"only {len(cases)} mutations applied"
    assert not problems, f"seed {seed} ({_reproduce(seed)}):\n\n" + "\n\n".join(problems[:6])
