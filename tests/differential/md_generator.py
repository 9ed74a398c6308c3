"""Random message definitions for the differential tests: valid ones in
every shape LN 2.9's ln_generate accepts, and invalid ones made from them by
one mutation each.

A RandomDefinitions(seed) writes a consistent tree of definitions: plain
sub-types (each may use earlier ones), then plain, service and event
definitions using them. Everything is drawn from one random.Random, so a seed
reproduces a tree exactly. Standard library only; nothing here asserts.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

PRIMITIVES = (
    "float",
    "double",
    "char",
    "int8_t",
    "uint8_t",
    "int16_t",
    "uint16_t",
    "int32_t",
    "uint32_t",
    "int64_t",
    "uint64_t",
)
ALIASES = {"float": "float32_t", "double": "float64_t", "int16_t": "short", "int32_t": "int"}
INTEGER_TYPES = ("uint32_t", "int32_t", "uint16_t", "uint64_t", "int64_t", "uint8_t")

#: Count expressions (Python integer expressions, as LN evaluates them).
COUNT_EXPRESSIONS = (
    "{n}",
    " {n} ",
    "{n}.0",
    "1*{n}",
    "({n}+0)*1",
    "{n}//1",
    "{n}**1",
    "{d}+{r}",
    "(1+{m})",
    "{n}<<0",
    "~-{n}+1",
    "-(-{n})",
    "2*{n}//2",
    "{n}|0",
    "{n}%{big}",
    "{n}*2/2",
)

#: Field name pieces: never C/C++ keywords, never LN's markers alone.
NAME_HEADS = (
    "pos",
    "vel",
    "gain",
    "flag",
    "count",
    "stamp",
    "label",
    "data",
    "value",
    "item",
    "joint",
    "mode",
    "offset",
    "scale",
    "state",
    "tag",
    "rate",
    "size",
    "limit",
    "error",
)
NAME_TAILS = ("", "_a", "_b", "_x", "_y", "2", "_mean", "_raw", "_ref", "_cmd")

#: Between a type and its name; LN splits at the first space, so each starts with one.
BLANKS = (" ", " ", " ", "  ", " \t", " \t ")


@dataclass
class Definition:
    """One generated definition file."""

    name: str  # below the md dir, e.g. "rnd/s3/point"
    kind: str  # plain, service or event
    lines: list[str] = field(default_factory=list)
    #: local type name -> definition name, for every define written
    defines: dict[str, str] = field(default_factory=dict)
    crlf: bool = False

    @property
    def text(self) -> str:
        eol = "\r\n" if self.crlf else "\n"
        return eol.join(self.lines) + eol


class RandomDefinitions:
    """A tree of random, valid definitions below the directory `package`."""

    def __init__(self, seed: int, package: str = "rnd"):
        self.seed = seed
        self.rng = random.Random(seed)
        self.package = package
        self.definitions: dict[str, Definition] = {}
        self.sub_types: list[str] = []  # plain, usable as types (in creation order)

    # ------------------------------------------------------------ building

    def build(self, sub_types: int, top_level: int) -> list[str]:
        """Creates `sub_types` plain sub-types and `top_level` definitions
        (plain, service or event); returns the top-level names."""
        for i in range(sub_types):
            self._plain(f"{self.package}/{self.rng.choice(('geo', 'sub', 'x/y'))}/t{i}", as_sub_type=True)
        tops = []
        for i in range(top_level):
            kind = self.rng.choice(("plain", "service", "service", "event"))
            name = f"{self.package}/top/{kind[0]}{i}"
            if kind == "plain":
                self._plain(name, as_sub_type=False)
            else:
                self._sectioned(name, kind)
            tops.append(name)
        return tops

    def files(self) -> dict[str, str]:
        return {d.name: d.text for d in self.definitions.values()}

    # ------------------------------------------------------------- pieces

    def _plain(self, name: str, as_sub_type: bool) -> None:
        d = Definition(name, "plain", crlf=self.rng.random() < 0.05)
        self.definitions[name] = d
        self._comment(d, always=self.rng.random() < 0.5)
        used: set[str] = set()
        if as_sub_type and self.rng.random() < 0.15:
            # self-recursion through a pointer (resolved next to the file)
            local = self._type_name(d)
            d.lines.append(f'define{self._blank()}{local} as "{name.rsplit("/", 1)[1]}"')
            d.defines[local] = name
            d.lines.append(f"{local}* {self._field_name(used)}")
        for _ in range(self.rng.randint(1 if as_sub_type else 2, 6)):
            self._field(d, used, allow_dynamic=not as_sub_type or self.rng.random() < 0.2)
        if as_sub_type:
            self.sub_types.append(name)

    def _sectioned(self, name: str, kind: str) -> None:
        d = Definition(name, kind, crlf=self.rng.random() < 0.05)
        self.definitions[name] = d
        first, second = ("request", "response") if kind == "service" else ("connect", "call")
        if self.rng.random() < 0.3:
            d.lines.append("# " + self._words())
        d.lines.append(kind + (self._comment_tail() if self.rng.random() < 0.2 else ""))
        order = [first, second] if self.rng.random() < 0.85 else [second, first]
        used_per_section: dict[str, set[str]] = {first: set(), second: set()}
        for section in order:
            # fields before any marker belong to the first section
            if section != first or section != order[0] or self.rng.random() < 0.9:
                d.lines.append(self._maybe_indent(section))
            for _ in range(self.rng.randint(0, 5)):
                self._field(d, used_per_section[section], allow_dynamic=True)
            if self.rng.random() < 0.1:
                self._blank_lines(d)
        if self.rng.random() < 0.2:
            # a section reopened: fields continue after the earlier ones
            section = self.rng.choice(order)
            d.lines.append(section)
            self._field(d, used_per_section[section], allow_dynamic=True)

    def _field(self, d: Definition, used: set[str], allow_dynamic: bool) -> None:
        self._blank_lines(d)
        if self.rng.random() < 0.15:
            d.lines.append(self._maybe_indent("# " + self._words()))
        roll = self.rng.random()
        name = self._field_name(used)
        if roll < 0.3 and self.sub_types and d.name not in self.sub_types:
            type_name = self._use_sub_type(d)
        else:
            base = self.rng.choice(PRIMITIVES)
            type_name = ALIASES[base] if base in ALIASES and self.rng.random() < 0.25 else base
        dynamic = allow_dynamic and self.rng.random() < 0.25
        if dynamic:
            # the length companion: implicit, declared right before, or after
            where = self.rng.choice(("implicit", "implicit", "before", "after"))
            len_line = f"{self.rng.choice(INTEGER_TYPES)} {name}_len"
            if where != "implicit":
                used.add(name + "_len")
            if where == "before":
                d.lines.append(len_line)
            d.lines.append(self._maybe_indent(f"{type_name}*{self._blank()}{name}") + self._maybe_comment())
            if where == "after":
                d.lines.append(len_line)
            return
        line = f"{type_name}{self._blank()}{name}"
        if self.rng.random() < 0.35:
            line += (" " if self.rng.random() < 0.15 else "") + f"[{self._count()}]"
        d.lines.append(self._maybe_indent(line) + self._maybe_comment())

    def _use_sub_type(self, d: Definition) -> str:
        """A local type name for a sub-type, defining it (again) when needed."""
        target = self.rng.choice(self.sub_types)
        existing = [local for local, t in d.defines.items() if t == target]
        if existing and self.rng.random() < 0.7:
            local = self.rng.choice(existing)
            if self.rng.random() < 0.25:
                # the same define once more (e.g. in another section): allowed
                d.lines.append(f'define {local} as "{self._reference(d.name, target)}"')
            return local
        local = self._type_name(d)
        d.lines.append(
            self._maybe_indent(f'define{self._blank()}{local} as "{self._reference(d.name, target)}"')
            + self._maybe_comment()
        )
        d.defines[local] = target
        return local

    def _reference(self, importer: str, target: str) -> str:
        """How `importer` names `target`: relative to its directory when it
        lies there (sometimes), else the full name."""
        importer_dir = importer.rsplit("/", 1)[0] + "/"
        if target.startswith(importer_dir) and self.rng.random() < 0.6:
            return target[len(importer_dir) :]
        return target

    def _type_name(self, d: Definition) -> str:
        while True:
            local = self.rng.choice(("pt", "sub", "elem", "node", "rec", "entry", "block")) + self.rng.choice(
                ("", "_t", "2", "_type")
            )
            if local not in d.defines:
                return local

    def _field_name(self, used: set[str]) -> str:
        for _ in range(1000):
            name = self.rng.choice(NAME_HEADS) + self.rng.choice(NAME_TAILS)
            if name not in used and name + "_len" not in used and not name.endswith("_len"):
                used.add(name)
                return name
        raise RuntimeError("out of field names")

    def _count(self) -> str:
        n = self.rng.randint(1, 6)
        d = self.rng.randint(0, n)
        expression = self.rng.choice(COUNT_EXPRESSIONS).format(n=n, d=d, r=n - d, m=n - 1, big=n + 7)
        assert int(eval(expression)) == n, expression
        return expression

    def _blank(self) -> str:
        return self.rng.choice(BLANKS)

    def _maybe_indent(self, line: str) -> str:
        return (self.rng.choice(("  ", "\t", " ")) + line) if self.rng.random() < 0.1 else line

    def _maybe_comment(self) -> str:
        return self._comment_tail() if self.rng.random() < 0.15 else ("  " if self.rng.random() < 0.05 else "")

    def _comment_tail(self) -> str:
        return self.rng.choice((" # ", "\t# ", "  #")) + self._words()

    def _comment(self, d: Definition, always: bool) -> None:
        if always:
            d.lines.append("# " + self._words())

    def _blank_lines(self, d: Definition) -> None:
        if self.rng.random() < 0.1:
            d.lines.append(self.rng.choice(("", "   ", "\t")))

    def _words(self) -> str:
        words = ("pose", "of the arm", "in m/s", "[rad]", "see below", "LN 2.9", "é ü", "x[3] y", "#hash", "define")
        return " ".join(self.rng.choice(words) for _ in range(self.rng.randint(1, 4)))


# ------------------------------------------------------ invalid definitions


@dataclass(frozen=True)
class Mutation:
    """One way to break a valid definition."""

    kind: str
    #: None: both generators must refuse it. A text: LN 2.9 accepts it, ln_core
    #: refuses it on purpose for this reason (README "Where ln_core differs").
    ours_stricter: str | None = None


MUTATIONS = (
    Mutation("unknown_type"),
    Mutation("duplicate_field"),
    Mutation("define_to_missing_file"),
    Mutation("one_word_line"),
    Mutation("name_with_dash"),
    Mutation("pointer_array"),
    Mutation("double_pointer"),
    Mutation("define_name_in_quotes"),
    Mutation("type_used_before_define"),
    Mutation("count_not_an_expression"),
    Mutation("count_two_dimensional"),
    Mutation("count_zero", ours_stricter="LN emits a scalar member but a signature with count 0"),
    Mutation("count_negative", ours_stricter="LN emits an array of negative size, which no compiler accepts"),
    Mutation("cxx_keyword_field", ours_stricter="LN emits a member no C++ compiler accepts"),
    Mutation(
        "redefine_to_other_target",
        ours_stricter="LN applies the last target to every field of that type and mislabels the struct",
    ),
)


# Mutations that append one invalid line.
_APPENDED_LINE = {
    "name_with_dash": "double has-dash",
    "pointer_array": "double* values[3]",
    "double_pointer": "uint8_t** raw",
    "count_not_an_expression": "double bad[abc]",
    "count_two_dimensional": "double matrix[2][3]",
    "count_zero": "double nothing[0]",
    "count_negative": "double negative[1-3]",
}


def mutate(rng: random.Random, definition: Definition, mutation: Mutation, sub_types: list[str]) -> str | None:
    """The text of `definition` broken by `mutation`, or None when this
    definition has nothing the mutation needs."""
    lines = list(definition.lines)
    fields = [i for i, line in enumerate(lines) if _is_field(line)]
    kind = mutation.kind
    if kind in _APPENDED_LINE:
        lines.append(_APPENDED_LINE[kind])
    elif kind == "unknown_type":
        lines.insert(rng.randint(_first_body_line(lines), len(lines)), "vector3d_t position")
    elif kind == "duplicate_field":
        plain_fields = [i for i in fields if "*" not in lines[i].split("#")[0]]
        if not plain_fields or definition.kind != "plain":
            return None
        lines.append(lines[rng.choice(plain_fields)].split("#")[0])
    elif kind == "define_to_missing_file":
        lines.insert(_first_body_line(lines), 'define gone_t as "no/such/definition"')
    elif kind == "one_word_line":
        lines.insert(rng.randint(_first_body_line(lines), len(lines)), "double")
    elif kind == "define_name_in_quotes":
        if not sub_types:
            return None
        lines.insert(_first_body_line(lines), f'define "quoted_t" as "{sub_types[0]}"')
    elif kind == "type_used_before_define":
        if not sub_types:
            return None
        lines.insert(_first_body_line(lines), "late_t early")
        lines.append(f'define late_t as "{sub_types[0]}"')
    elif kind == "cxx_keyword_field":
        lines.append("int32_t " + rng.choice(("class", "template", "namespace", "virtual")))
    elif kind == "redefine_to_other_target":
        if len(sub_types) < 2:
            return None
        first, second = rng.sample(sub_types, 2)
        lines += [f'define clash_t as "{first}"', "clash_t one", f'define clash_t as "{second}"', "clash_t two"]
    else:
        raise ValueError(kind)
    eol = "\r\n" if definition.crlf else "\n"
    return eol.join(lines) + eol


def _is_field(line: str) -> bool:
    body = line.split("#", 1)[0].strip()
    return bool(body) and " " in body.replace("\t", " ") and not body.startswith("define")


def _first_body_line(lines: list[str]) -> int:
    """Index after a leading `service`/`event` and its first section marker."""
    index = 0
    for i, line in enumerate(lines):
        body = line.split("#", 1)[0].strip()
        if body in ("service", "event"):
            index = i + 1
        elif body in ("request", "response", "connect", "call") and index == i:
            return i + 1
        elif body:
            break
    return index
