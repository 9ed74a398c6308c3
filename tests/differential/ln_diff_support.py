"""Helpers of the differential tests: locating the tools, running them,
picking generated headers apart and building the layout probes.

Nothing here asserts; the tests do. Everything is stdlib only.
"""

from __future__ import annotations

import concurrent.futures
import glob
import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
import ln_testing

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
CORPUS_DIR = HERE / "corpus"
#: The corpus is looked up through this directory only; its md.conf adds
#: CORPUS_EXTRA_DIR to the search path.
CORPUS_MD_DIR = CORPUS_DIR / "md"
CORPUS_EXTRA_DIR = CORPUS_DIR / "md_extra"
ELEVATOR_MD_DIR = REPO_ROOT / "ln_core" / "examples" / "elevator" / "msgdefs"
OUR_INCLUDE_DIR = REPO_ROOT / "ln_core" / "include"
#: the built-in definitions ln_core installs (LN's share/links_and_nodes/message_definitions)
OUR_BUILTIN_MD_DIR = REPO_ROOT / "ln_core" / "share" / "message_definitions"

#: Every subprocess is bounded; LN's Python ln_generate needs < 1 s per run.
TOOL_TIMEOUT = 60
COMPILE_TIMEOUT = 120

#: LN 2.9 ships its definitions in these directories below
#: <venv>/lib/python3.X/site-packages/liblinks_and_nodes/share.
LN29_MD_SUBDIRS = (
    "message_definitions",
    "links_and_nodes/message_definitions",
    "ln_runtime/message_definitions",
)

#: Filled by the tests, printed by conftest at the end of the run.
REPORT: dict[str, object] = {}

MissingPrerequisite = ln_testing.Unavailable
require = ln_testing.require


# --------------------------------------------------------------- locating


@dataclass(frozen=True)
class Reference:
    """An installed LN 2.9 (a Python venv with the liblinks_and_nodes wheel)."""

    venv: Path
    ln_generate: Path
    package_dir: Path  # .../site-packages/liblinks_and_nodes

    @property
    def include_dir(self) -> Path:
        return self.package_dir / "include"

    @property
    def share_dir(self) -> Path:
        return self.package_dir / "share"

    def md_dirs(self) -> list[Path]:
        return [self.share_dir / sub for sub in LN29_MD_SUBDIRS]


def find_reference() -> Reference | MissingPrerequisite:
    venv_env = os.environ.get("LN_CORE_LN29_VENV")
    if venv_env:
        venv = Path(venv_env)
        origin = f"LN_CORE_LN29_VENV={venv_env}"
    elif Path("/tmp/ref/ln29").is_dir():
        venv = Path("/tmp/ref/ln29")
        origin = "the default /tmp/ref/ln29 (LN_CORE_LN29_VENV is unset)"
    else:
        return MissingPrerequisite(
            "no LN 2.9 reference: set LN_CORE_LN29_VENV to the LN 2.9 venv "
            "(launchless_scripts/env.sh does) or install it at /tmp/ref/ln29"
        )
    ln_generate = venv / "bin" / "ln_generate"
    packages = sorted(glob.glob(str(venv / "lib" / "python3*" / "site-packages" / "liblinks_and_nodes")))
    if not ln_generate.is_file() or not packages:
        return MissingPrerequisite(
            f"{origin} is not an LN 2.9 venv: expected {ln_generate} and "
            f"{venv}/lib/python3*/site-packages/liblinks_and_nodes"
        )
    ref = Reference(venv, ln_generate, Path(packages[-1]))
    missing = [str(d) for d in ref.md_dirs() if not d.is_dir()]
    if missing or not (ref.include_dir / "ln" / "ln.h").is_file():
        return MissingPrerequisite(f"LN 2.9 at {venv} lacks {missing or ref.include_dir / 'ln/ln.h'}")
    return ref


@dataclass(frozen=True)
class OurTools:
    ln_generate: Path
    ln_md_info: Path


def find_our_tools() -> OurTools | MissingPrerequisite:
    """LN_CORE_BIN_DIR, then LN_CORE_BUILD_DIR (build tree), then PATH."""
    for var in ("LN_CORE_BIN_DIR", "LN_CORE_BUILD_DIR"):
        value = os.environ.get(var)
        if value:
            base = Path(value)
            for candidate in (base, base / "bin", base / "tools"):
                gen, info = candidate / "ln_generate", candidate / "ln_md_info"
                if gen.is_file() and info.is_file():
                    return OurTools(gen, info)
            return MissingPrerequisite(f"{var}={value} has no ln_generate and ln_md_info")
    gen, info = shutil.which("ln_generate"), shutil.which("ln_md_info")
    if gen and info:
        # LN's own ln_generate (a Python script of the reference venv) may
        # shadow ours on PATH; ours is the binary that ships ln_md_info.
        info_dir = Path(info).parent
        if (info_dir / "ln_generate").is_file():
            return OurTools(info_dir / "ln_generate", Path(info))
        return OurTools(Path(gen), Path(info))
    return MissingPrerequisite(
        "ln_core's ln_generate/ln_md_info not found: set LN_CORE_BIN_DIR (directory of both), "
        "LN_CORE_BUILD_DIR (cmake build dir) or put them on PATH (. launchless_scripts/env.sh)"
    )


def find_compiler(name: str) -> str | None:
    return shutil.which(name)


# ---------------------------------------------------------------- running


def tool_environment(home: Path) -> dict[str, str]:
    """The same controlled environment for LN's and our tools: no user
    definition dirs, no ~/.ln_config, no foreign Python path."""
    env = dict(os.environ)
    for var in ("LN_MESSAGE_DEFINITION_DIRS", "PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP"):
        env.pop(var, None)
    env["HOME"] = str(home)
    env["LC_ALL"] = "C.UTF-8"
    return env


@dataclass
class Run:
    argv: list[str]
    returncode: int
    stdout: str
    stderr: str

    def describe(self) -> str:
        return (
            f"$ {' '.join(self.argv)}\nexit status {self.returncode}\n"
            f"--- stderr ---\n{self.stderr.strip()}\n--- stdout (first 2000 chars) ---\n{self.stdout[:2000]}"
        )


def run(argv, env, cwd=None, timeout=TOOL_TIMEOUT, stdin=None) -> Run:
    argv = [str(a) for a in argv]
    try:
        p = subprocess.run(
            argv,
            env=env,
            cwd=cwd,
            stdin=stdin if stdin is not None else subprocess.DEVNULL,
            capture_output=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired as e:
        return Run(
            argv,
            -9,
            (e.stdout or b"").decode("utf-8", "replace"),
            f"TIMEOUT after {timeout} s\n" + (e.stderr or b"").decode("utf-8", "replace"),
        )
    return Run(argv, p.returncode, p.stdout.decode("utf-8", "replace"), p.stderr.decode("utf-8", "replace"))


def write_definitions(root: Path, files: dict[str, str]) -> Path:
    """Writes {definition name: text} as a definitions directory root/md (UTF-8); returns it."""
    md = root / "md"
    for name, text in files.items():
        path = md / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(text.encode("utf-8"))
    return md


def single_error_problems(run: Run) -> list[str]:
    """What keeps a run from being a clean refusal: a failure status (> 0, no signal), exactly one
    non-empty stderr line, no crash output."""
    problems = []
    lines = [l for l in run.stderr.splitlines() if l.strip()]
    if run.returncode <= 0:
        problems.append(f"exit status {run.returncode}, expected a failure status (> 0, no signal)")
    if len(lines) != 1:
        problems.append(f"{len(lines)} non-empty stderr lines, expected exactly one")
    if "Traceback" in run.stderr or "terminate called" in run.stderr:
        problems.append("crash output instead of an error message")
    return problems


def md_dir_args(md_dirs) -> list[str]:
    args = []
    for d in md_dirs:
        args += ["--md-dir", str(d)]
    return args


def definitions_below(md_dir: Path) -> list[str]:
    """Names of all definition files below md_dir (md.conf excluded)."""
    names = []
    for root, dirs, files in os.walk(md_dir):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            if f.startswith(".") or f == "md.conf":
                continue
            names.append(os.path.relpath(os.path.join(root, f), md_dir).replace(os.sep, "/"))
    return names


@dataclass
class BatchResult:
    """One tool run over many names; names it could not process (each tried
    alone) are in `failures` with the failing run."""

    ok_names: list[str]
    output: str  # header text or ln_md_info JSON lines for ok_names
    failures: dict[str, Run] = field(default_factory=dict)
    runs: list[Run] = field(default_factory=list)


def run_batch(make_argv, names, env, cwd, read_output) -> BatchResult:
    """Runs make_argv(names) once; if that fails, finds the culprits by
    running each name alone (in parallel) and reruns with the others."""
    first = run(make_argv(names, "all"), env, cwd)
    if first.returncode == 0:
        return BatchResult(list(names), read_output(first, "all"), runs=[first])
    failures = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(16, os.cpu_count() or 4)) as pool:
        singles = dict(
            zip(names, pool.map(lambda i_n: run(make_argv([i_n[1]], f"single{i_n[0]}"), env, cwd), enumerate(names)))
        )
    for name, r in singles.items():
        if r.returncode != 0:
            failures[name] = r
    ok = [n for n in names if n not in failures]
    if not ok:
        return BatchResult([], "", failures, [first])
    again = run(make_argv(ok, "ok"), env, cwd)
    if again.returncode != 0:
        # A combination fails that no single name does: report it on all.
        return BatchResult([], "", {n: again for n in ok} | failures, [first, again])
    return BatchResult(ok, read_output(again, "ok"), failures, [first, again])


# ------------------------------------------------------- header analysis

SECTION_MARKER = re.compile(r"^/\* ([^\s*]+) \*/\s*$")
MACRO = re.compile(r"^\s*#\s*define\s+(\w+)(?:\s+(.*?))?\s*$")
PREAMBLE = "<preamble>"


def split_sections(header: str) -> dict[str, str]:
    """Header text per definition (LN and ln_core both start each
    definition's part with a `/* md/name */` line); the part before the
    first marker is PREAMBLE."""
    sections = {PREAMBLE: []}
    current = PREAMBLE
    in_comment = False
    for line in header.splitlines():
        stripped = line.strip()
        if not in_comment:
            m = SECTION_MARKER.match(line)
            if m:
                current = m.group(1)
                sections.setdefault(current, [])
                continue
            if stripped.startswith("/*") and "*/" not in stripped:
                in_comment = True
        elif "*/" in stripped:
            in_comment = False
        sections[current].append(line)
    return {k: "\n".join(v) + "\n" for k, v in sections.items()}


def section_order(header: str) -> list[str]:
    """The `/* md/name */` markers in header order, repeats included (a
    sub-type emitted twice would show here)."""
    return [m.group(1) for m in map(SECTION_MARKER.match, header.splitlines()) if m]


def macros(text: str) -> dict[str, str]:
    """#define NAME VALUE -> {NAME: VALUE}, whitespace-normalised."""
    out = {}
    for line in text.splitlines():
        m = MACRO.match(line)
        if m:
            out[m.group(1)] = re.sub(r"\s+", " ", m.group(2) or "")
    return out


def string_macro(text: str, name: str) -> str | None:
    """The C string literal a macro expands to, unquoted."""
    for line in text.splitlines():
        m = MACRO.match(line)
        if m and m.group(1) == name:
            v = (m.group(2) or "").strip()
            if len(v) >= 2 and v[0] == '"' and v[-1] == '"':
                return v[1:-1]
            return v
    return None


_SCOPE_OPENERS = [
    ("namespace", re.compile(r"^\s*namespace\s+(\w+)\s*\{")),
    ("class", re.compile(r"^\s*(?:class|struct)\s+(?!LN_PACKED\b)(\w+)\s*(?::[^{]*)?\{")),
    ("struct", re.compile(r"^\s*(?:typedef\s+)?struct\s+LN_PACKED(?:\s+(\w+))?\s*\{")),
    ("struct", re.compile(r"^\s*typedef\s+struct(?:\s+(\w+))?\s*\{")),
]
_METHOD = re.compile(r"^\s*(?:virtual\s+)?(?:void|int|bool)\s+(\w+)\s*\(")
_TYPEDEF = re.compile(r"^\s*typedef\s+(.+?)\s+(\w+)\s*;")
_STRUCT_TAG = re.compile(r"\bstruct\s+(?:LN_PACKED\s+)?(\w+)")
_CLOSE_NAME = re.compile(r"^\s*\}\s*(\w+)\s*;")


def generated_names(text: str) -> set[tuple[str, str]]:
    """The names a header part declares, as (kind, qualified name):

    macro     #define NAME
    struct    C struct tags
    ctype     C typedef names at file scope
    member-typedef  typedefs inside a struct (the C++ request_t/response_t)
    cxx-typedef     typedefs inside namespaces, qualified ("ln::x::y_t")
    class     C++ classes, qualified
    method    methods of those classes declared as void/int/bool NAME(...),
              static helpers excluded, qualified ("ns::cls::name")
    """
    names: set[tuple[str, str]] = set()
    scopes: list[tuple[str, str | None]] = []
    in_comment = False
    for raw in text.splitlines():
        line = raw
        if in_comment:
            if "*/" not in line:
                continue
            line = line.split("*/", 1)[1]
            in_comment = False
        line = re.sub(r"/\*.*?\*/", "", line)
        if "/*" in line:
            line, in_comment = line.split("/*", 1)[0], True
        line = line.split("//", 1)[0]
        if not line.strip():
            continue
        m = MACRO.match(line)
        if m:
            names.add(("macro", m.group(1)))
            continue
        if line.lstrip().startswith("#"):
            continue
        qual = "::".join(n for kind, n in scopes if kind in ("namespace", "class") and n)
        in_struct = any(kind == "struct" for kind, _ in scopes)
        in_class = bool(scopes) and scopes[-1][0] == "class"
        in_namespace = any(kind in ("namespace", "class") for kind, _ in scopes)

        for tag in _STRUCT_TAG.findall(line):
            if tag != "LN_PACKED":
                names.add(("struct", tag))
        t = _TYPEDEF.match(line)
        if t and "{" not in line:
            if in_struct:
                names.add(("member-typedef", t.group(2)))
            elif in_namespace:
                names.add(("cxx-typedef", f"{qual}::{t.group(2)}"))
            else:
                names.add(("ctype", t.group(2)))
        if in_class:
            mm = _METHOD.match(line)
            if mm and "static" not in line.split("(")[0]:
                names.add(("method", f"{qual}::{mm.group(1)}"))

        # scope bookkeeping, brace by brace
        opener = None
        for kind, rx in _SCOPE_OPENERS:
            om = rx.match(line)
            if om:
                opener = (kind, om.group(1))
                break
        first_open = True
        for ch in line:
            if ch == "{":
                if first_open and opener:
                    scopes.append(opener)
                    if opener[0] == "class":
                        names.add(("class", f"{qual}::{opener[1]}" if qual else opener[1]))
                else:
                    scopes.append(("block", None))
                first_open = False
            elif ch == "}":
                closed = scopes.pop() if scopes else ("block", None)
                if closed[0] == "struct":
                    cm = _CLOSE_NAME.match(line)
                    still_in_struct = any(kind == "struct" for kind, _ in scopes)
                    if cm and line.lstrip().startswith("}") and not still_in_struct:
                        names.add(("ctype", cm.group(1)))
    return names


def is_cxx_name(kind: str) -> bool:
    return kind in ("cxx-typedef", "class", "method", "member-typedef")


def kind_of_part(ln_part: str) -> str:
    """plain/service/event, judged from the macros of LN's header part."""
    names = macros(ln_part)
    if any(k.endswith("_CONNECT_SIGNATURE") for k in names):
        return "event"
    if any(k.endswith("_SIGNATURE") for k in names):
        return "service"
    return "plain"


def name_differences(
    ln_part: str,
    our_part: str,
    md_name: str,
    md_kind: str | None = None,
    service_base_map: dict[str, str] | None = None,
) -> list[str]:
    """What differs between the names two header parts declare: C names
    and macros must be equal; C++ names of LN must all be in ours, and ours
    may only add the C++ alias ns::<base>_t of a plain definition (ln_spec.md
    8.2; <base> is the last name component or its --map-service-base
    replacement, which LN ignores for plain definitions). Also compares the
    values of macros both define."""
    md_kind = md_kind or kind_of_part(ln_part)
    ln_names, our_names = generated_names(ln_part), generated_names(our_part)
    base = (service_base_map or {}).get(md_name, md_name.rsplit("/", 1)[-1])

    def allowed_extra(kind_name):
        kind, qualified = kind_name
        return md_kind == "plain" and kind == "cxx-typedef" and qualified.endswith("::" + base + "_t")

    missing = sorted(ln_names - our_names)
    c_extra = sorted(n for n in our_names - ln_names if not is_cxx_name(n[0]))
    cxx_extra = sorted(n for n in our_names - ln_names if is_cxx_name(n[0]) and not allowed_extra(n))
    ln_macros, our_macros = macros(ln_part), macros(our_part)
    macro_diffs = [
        f"  {k}: LN {ln_macros[k]!r} ours {our_macros[k]!r}"
        for k in sorted(set(ln_macros) & set(our_macros))
        if ln_macros[k] != our_macros[k] and k != "HAVE_LN_MD_NAME"
    ]
    problems = []
    if missing:
        problems.append("missing in ours: " + ", ".join(f"{k} {n}" for k, n in missing))
    if c_extra:
        problems.append("C names only in ours: " + ", ".join(f"{k} {n}" for k, n in c_extra))
    if cxx_extra:
        problems.append(
            "C++ names only in ours (not the documented plain-type alias): "
            + ", ".join(f"{k} {n}" for k, n in cxx_extra)
        )
    if macro_diffs:
        problems.append("macro values differ:\n" + "\n".join(macro_diffs))
    return problems


def header_differences(ln_header: str, our_header: str, service_base_map: dict[str, str] | None = None) -> list[str]:
    """name_differences for every definition part of two whole headers,
    plus differing sets of parts."""
    ln_parts, our_parts = split_sections(ln_header), split_sections(our_header)
    problems = []
    if set(ln_parts) != set(our_parts):
        problems.append(
            f"different definitions: only LN {sorted(set(ln_parts) - set(our_parts))}, "
            f"only ours {sorted(set(our_parts) - set(ln_parts))}"
        )
    for name in sorted(set(ln_parts) & set(our_parts)):
        for p in name_differences(ln_parts[name], our_parts[name], name, service_base_map=service_base_map):
            problems.append(f"{name}: {p}")
    return problems


# ----------------------------------------------------------- layout probe


@dataclass
class ProbeItem:
    definition: str
    what: str  # human-readable: "sizeof(T.req)", "offsetof(T, req.x)"
    expression: str  # C expression of type size_t
    expected: int


def probe_items(info: dict) -> list[ProbeItem]:
    """What to measure for one ln_md_info JSON record."""
    items = []
    name = info["name"]
    section_total = {}
    for s in info["structs"]:
        t = s["c_type"]
        prefix = s["member_prefix"]
        sub = prefix.rstrip(".")
        size_expr = f"sizeof(((({t}*)0)->{sub}))" if sub else f"sizeof({t})"
        size_what = f"sizeof({t}.{sub})" if sub else size_expr
        items.append(ProbeItem(name, f"{s['section']}: {size_what}", size_expr, s["size"]))
        section_total[t] = section_total.get(t, 0) + s["size"]
        for f in s["fields"]:
            member = prefix + f["name"]
            off_what = f"offsetof({t}, {member})" + (f" - offsetof({t}, {sub})" if sub else "")
            off = f"({off_what})" if sub else off_what
            items.append(ProbeItem(name, f"{s['section']}: {off_what}", off, f["offset"]))
            items.append(
                ProbeItem(name, f"{s['section']}: sizeof({t}.{member})", f"sizeof(((({t}*)0)->{member}))", f["size"])
            )
    if info["kind"] == "service":
        # the service struct is exactly req + resp (packed; no member for an
        # empty section)
        t = identifier(name) + "_t"
        items.append(ProbeItem(name, f"sizeof({t}) (req + resp)", f"sizeof({t})", section_total.get(t, 0)))
    return items


def identifier(md_name: str) -> str:
    return re.sub(r"[ /.]+", "_", md_name).strip("_")


def probe_source(header_name: str, items: list[ProbeItem]) -> str:
    lines = [
        "/* generated by tests/differential: prints one number per line */",
        "#include <stddef.h>",
        "#include <stdio.h>",
        f'#include "{header_name}"',
        "int main(void) {",
    ]
    for i, item in enumerate(items):
        lines.append(f'  printf("%zu\\n", (size_t)({item.expression})); /* {i}: {item.definition} */')
    lines += ["  return 0;", "}", ""]
    return "\n".join(lines)


def compile_and_run_probe(cc: str, workdir: Path, header_text: str, items, include_dirs, env, label: str):
    """Compiles the probe as C11 against header_text; returns (values, None)
    or (None, diagnostic)."""
    workdir.mkdir(parents=True, exist_ok=True)
    header = workdir / f"{label}_messages.h"
    header.write_text(header_text, encoding="utf-8")
    source = workdir / f"{label}_probe.c"
    source.write_text(probe_source(header.name, items), encoding="utf-8")
    exe = workdir / f"{label}_probe"
    argv = [cc, "-std=c11", "-O0", "-w", "-I", str(workdir)]
    for d in include_dirs:
        argv += ["-I", str(d)]
    argv += [str(source), "-o", str(exe)]
    c = run(argv, env, timeout=COMPILE_TIMEOUT)
    if c.returncode != 0:
        return None, f"compiling the probe as C against {label}'s header failed:\n{c.describe()}"
    r = run([exe], env)
    if r.returncode != 0:
        return None, f"the {label} probe failed:\n{r.describe()}"
    values = [int(v) for v in r.stdout.split()]
    if len(values) != len(items):
        return None, f"the {label} probe printed {len(values)} numbers, expected {len(items)}"
    return values, None


def write_stub_includes(root: Path) -> Path:
    """A minimal ln/ include dir for compiling generated headers as C
    without ln_core's real ln.h."""
    ln = root / "ln"
    ln.mkdir(parents=True, exist_ok=True)
    (ln / "ln.h").write_text("/* stub for the layout probe */\n")
    (ln / "packed.h").write_text("#define LN_PACKED __attribute__((__packed__))\n")
    (ln / "endpacked.h").write_text("")
    return root


def parse_json_lines(text: str) -> dict[str, dict]:
    out = {}
    for line in text.splitlines():
        if line.strip():
            rec = json.loads(line)
            out[rec["name"]] = rec
    return out


# ------------------------------------------------- comparing definition sets


@dataclass(frozen=True)
class DefinitionSet:
    label: str
    origin: str  # "ln29", "corpus", "elevator" or "random"
    md_dirs: tuple[Path, ...]
    names: tuple[str, ...]


@dataclass
class SetResult:
    dset: DefinitionSet
    ln: BatchResult
    ours: BatchResult
    info: BatchResult
    ln_sections: dict[str, str]
    our_sections: dict[str, str]
    infos: dict[str, dict]
    # per definition: list of (ProbeItem, value) or an error text
    ln_probe: dict[str, object] = field(default_factory=dict)
    our_probe: dict[str, object] = field(default_factory=dict)


def _slug(label: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", label)


def probe_layouts(cc, workdir, header, infos, names, include_dirs, env, label):
    """Layout numbers per definition; on a compile failure of the whole
    batch each definition is probed alone to attribute the error."""
    out = {}
    items = {n: probe_items(infos[n]) for n in names}
    flat = [i for n in names for i in items[n]]
    values, error = compile_and_run_probe(cc, workdir, header, flat, include_dirs, env, label)
    if error is None:
        it = iter(values)
        for n in names:
            out[n] = [(item, next(it)) for item in items[n]]
        return out

    def one(i_n):
        i, n = i_n
        return n, compile_and_run_probe(cc, workdir / f"{label}_{i}", header, items[n], include_dirs, env, label)

    with concurrent.futures.ThreadPoolExecutor(max_workers=8) as pool:
        for n, (vals, err) in pool.map(one, enumerate(names)):
            out[n] = err if err else list(zip(items[n], vals))
    return out


class Differential:
    """Runs both generators (and ln_md_info, and the layout probes) over
    definition sets, once per set."""

    def __init__(self, ref, tools, env, root, cc, sets=()):
        self.ref, self.tools, self.env, self.root, self.cc = ref, tools, env, root, cc
        self.stub = write_stub_includes(root / "stub_include")
        self.sets = {s.label: s for s in sets}
        self._results: dict[str, SetResult] = {}

    def result(self, label: str) -> SetResult:
        if label not in self._results:
            self._results[label] = self.compute(self.sets[label])
        return self._results[label]

    def compute(self, dset: DefinitionSet) -> SetResult:
        d = self.root / _slug(dset.label)
        d.mkdir(parents=True, exist_ok=True)
        dirs = md_dir_args(dset.md_dirs)
        names = list(dset.names)

        # Both write "ln_messages.h" (the guard macro derives from it), in
        # their own directories.
        def out(prefix, tag):
            (d / prefix / tag).mkdir(parents=True, exist_ok=True)
            return d / prefix / tag / "ln_messages.h"

        def generator(exe, prefix):
            return lambda ns, tag: [exe, *dirs, "-f", "-o", out(prefix, tag), *ns]

        def header_reader(prefix):
            return lambda run, tag: out(prefix, tag).read_text(encoding="utf-8")

        ln = run_batch(generator(self.ref.ln_generate, "ln"), names, self.env, d, header_reader("ln"))
        ours = run_batch(generator(self.tools.ln_generate, "ours"), names, self.env, d, header_reader("ours"))
        info = run_batch(
            lambda ns, tag: [self.tools.ln_md_info, *dirs, *ns], names, self.env, d, lambda run, tag: run.stdout
        )
        r = SetResult(
            dset,
            ln,
            ours,
            info,
            split_sections(ln.output) if ln.ok_names else {},
            split_sections(ours.output) if ours.ok_names else {},
            parse_json_lines(info.output),
        )
        info_ok = set(info.ok_names)
        ln_names = [n for n in ln.ok_names if n in info_ok]
        our_names = [n for n in ours.ok_names if n in info_ok]
        if ln_names:
            # LN copies a no-break space before '[' into the C declaration
            # ("uint16_t d\xa0[3];", corpus syntax/unicode_whitespace), which
            # no C compiler reads; as a blank it means what LN meant.
            ln_c_text = ln.output.replace("\u00a0", " ")
            r.ln_probe = probe_layouts(
                self.cc, d / "probe_ln", ln_c_text, r.infos, ln_names, [self.ref.include_dir], self.env, "ln"
            )
        if our_names:
            r.our_probe = probe_layouts(
                self.cc, d / "probe_ours", ours.output, r.infos, our_names, [self.stub], self.env, "ours"
            )
        return r


def parts_or_problems(r: SetResult, name: str) -> tuple[str | None, str | None, list[str]]:
    """(LN's header part, our header part, problems): the problems say which
    side could not process the definition."""
    problems = []
    if name in r.ln.failures:
        origin = r.dset.origin
        why = {
            "ln29": "LN 2.9 fails on its own definition",
            "random": "the generator made a definition LN 2.9 refuses -- fix md_generator.py",
        }.get(origin, "every corpus/example definition must be accepted by LN 2.9 -- fix the definition")
        problems.append(f"LN 2.9's ln_generate rejected {name!r} ({why}):\n{r.ln.failures[name].describe()}")
    if name in r.ours.failures:
        problems.append(f"our ln_generate rejected {name!r}, which LN 2.9 accepts:\n{r.ours.failures[name].describe()}")
    if problems:
        return None, None, problems
    ln_part, our_part = r.ln_sections.get(name), r.our_sections.get(name)
    if ln_part is None or our_part is None:
        problems.append(
            f"{name!r}: no '/* {name} */' part in {'LN 2.9' if ln_part is None else 'our'} header "
            f"(LN has parts {sorted(r.ln_sections)[:8]}..., ours {sorted(r.our_sections)[:8]}...)"
        )
    return ln_part, our_part, problems


def split_top_level(signature: str) -> list[str]:
    """Splits "req|resp" at '|' outside [...] (sub-type signatures)."""
    parts, depth, current = [], 0, ""
    for ch in signature:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == "|" and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += ch
    return parts + [current]


def md_name_problems(r: SetResult, name: str, ln_part: str, our_part: str) -> list[str]:
    """<ID>_MD_NAME ("name|hash") equal, and ln_md_info's name|hash too."""
    macro = identifier(name).upper() + "_MD_NAME"
    ln_value, our_value = string_macro(ln_part, macro), string_macro(our_part, macro)
    if ln_value is None:
        return [f"{name}: LN's header has no {macro}"]
    if our_value != ln_value:
        return [f"{name}: {macro} differs\n  LN 2.9: {ln_value}\n  ours:   {our_value}"]
    info = r.infos.get(name)
    if info is None:
        failure = r.info.failures.get(name)
        return [f"{name}: ln_md_info failed: {failure and failure.describe()}"]
    if f"{info['name']}|{info['hash']}" != ln_value:
        return [
            f"{name}: ln_md_info's name|hash differs from LN's {macro}\n  LN 2.9:      {ln_value}\n"
            f"  ln_md_info: {info['name']}|{info['hash']}"
        ]
    return []


def signature_problems(r: SetResult, name: str, ln_part: str, our_part: str) -> list[str]:
    """The signature macros equal, and ln_md_info's signature agrees."""

    def signature_macros(text):
        return {k: v for k, v in macros(text).items() if k.lower().endswith("signature")}

    ln_sigs, our_sigs = signature_macros(ln_part), signature_macros(our_part)
    diffs = [
        f"  {k}:\n    LN 2.9: {ln_sigs.get(k)}\n    ours:   {our_sigs.get(k)}"
        for k in sorted(set(ln_sigs) | set(our_sigs))
        if ln_sigs.get(k) != our_sigs.get(k)
    ]
    if diffs:
        return [f"{name}: signature macros differ\n" + "\n".join(diffs)]
    info = r.infos.get(name)
    if info is None:
        return [f"{name}: ln_md_info failed"]
    upper = identifier(name).upper()
    if info["kind"] == "service":
        expect = string_macro(ln_part, upper + "_SIGNATURE")
        if info["signature"] != expect:
            return [
                f"{name}: ln_md_info signature differs from LN's {upper}_SIGNATURE\n"
                f"  LN 2.9:     {expect}\n  ln_md_info: {info['signature']}"
            ]
    elif info["kind"] == "event":
        parts = split_top_level(info["signature"])
        if len(parts) != 2:
            return [f"{name}: ln_md_info's event signature is not 'connect|call': {info['signature']}"]
        for part, macro in zip(parts, ("_CONNECT_SIGNATURE", "_CALL_SIGNATURE")):
            expect = string_macro(ln_part, upper + macro)
            if f"{name}: {part}" != expect:
                return [
                    f"{name}: ln_md_info signature differs from LN's {upper}{macro}\n"
                    f"  LN 2.9:     {expect}\n  ln_md_info: {name}: {part}"
                ]
    elif ln_sigs:
        return [f"{name}: LN emits signature macros for a plain definition: {ln_sigs}"]
    return []


def layout_problems(r: SetResult, name: str) -> list[str]:
    """sizeof/offsetof from both compiled headers equal ln_md_info's layout."""
    if name not in r.infos:
        return [f"{name}: ln_md_info failed:\n{r.info.failures[name].describe()}"]
    problems = []
    for who, probe in (
        ("LN 2.9's header (compiled as C11)", r.ln_probe),
        ("our header (compiled as C11)", r.our_probe),
    ):
        got = probe.get(name)
        if got is None:
            problems.append(f"{who}: not probed")
        elif isinstance(got, str):
            problems.append(f"{who}: {got}")
        else:
            problems += [
                f"{who}: {item.what} = {value}, ln_md_info says {item.expected}"
                for item, value in got
                if value != item.expected
            ]
    return [f"{name}: layout differs from ln_md_info's JSON\n  " + "\n  ".join(problems)] if problems else []
