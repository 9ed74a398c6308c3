"""Field values on the command line, and packets as plain data.

The value syntax is the flow style of YAML, which is what people type after
`ros2 topic pub`::

    time: 1.5, num_counts: 3          commas or plain spaces between fields
    {vec: [1, 2, 3], origin: {x: 1}}  nested sub-types and arrays
    corners[1].x: 7  name: "two words"   a path as key; quotes for text with spaces

Scalars are decided by the field they are assigned to, not by how they look:
`name: 123` sets a `char name[8]` to the text "123", `x: 0x10` sets a number
to 16. That is why the parser keeps unquoted words as `Bare` text and the
conversion happens in `assign_fields`, against the message definition.
Everything is validated before anything is sent.
"""

import re

import numpy as np

from .._packets import (
    FieldTypeError,
    FieldValueError,
    Part,
    _Array,
    _Char,
    _CharArray,
    _DynNumeric,
    _DynSub,
    _DynText,
    _Length,
    _Scalar,
    _Sub,
    _SubArray,
)


class ValueSyntaxError(ValueError):
    """The text is not 'field: value' syntax; the message says where."""


class Bare(str):
    """An unquoted word: text or a number, whichever its field needs."""


# ------------------------------------------------------------------ paths

_PATH = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*|\[\s*-?\d+\s*\])*")
_PATH_STEP = re.compile(r"([A-Za-z_]\w*)|\[\s*(-?\d+)\s*\]")


def parse_path(text):
    """'corners[1].x' -> ['corners', 1, 'x']; ValueError if malformed."""
    text = text.strip()
    if not _PATH.fullmatch(text):
        raise ValueError("'%s' is not a field path like a.b[2]" % text)
    return [name if name else int(index) for name, index in _PATH_STEP.findall(text)]


def format_path(steps):
    out = ""
    for step in steps:
        out += "[%d]" % step if isinstance(step, int) else ("." if out else "") + step
    return out


# ----------------------------------------------------------------- parser

_STOP = set(",:{}[]#\"'") | set(" \t\r\n")


class _Parser:
    def __init__(self, text):
        self.text = text
        self.pos = 0

    def fail(self, what):
        rest = self.text[self.pos : self.pos + 20]
        raise ValueSyntaxError("%s at %s" % (what, "'%s'" % rest if rest.strip() else "the end"))

    def skip(self):
        text = self.text
        while self.pos < len(text):
            c = text[self.pos]
            if c in " \t\r\n":
                self.pos += 1
            elif c == "#":
                end = text.find("\n", self.pos)
                self.pos = len(text) if end < 0 else end
            else:
                return
        return

    def peek(self):
        self.skip()
        return self.text[self.pos] if self.pos < len(self.text) else ""

    def top(self):
        if self.peek() == "{":
            mapping = self.mapping()
            if self.peek():
                self.fail("unexpected text after the closing '}'")
            return mapping
        return self.pairs(closer="")

    def pairs(self, closer):
        out = {}
        while True:
            c = self.peek()
            if c == closer:
                return out
            if c == "":
                self.fail("missing '%s'" % closer)
            key = self.key()
            if key in out:
                self.fail("field '%s' given twice" % key)
            if self.peek() != ":":
                self.fail("expected ':' after '%s'" % key)
            self.pos += 1
            c = self.peek()
            if c in ("", ",", "}") or (c == closer and closer):
                self.fail("missing value for '%s'" % key)
            out[key] = self.value()
            if self.peek() == ",":
                self.pos += 1

    def key(self):
        if self.peek() in "\"'":
            return self.quoted()
        start = self.pos
        while self.pos < len(self.text) and self.text[self.pos] not in ":,{} \t\r\n":
            self.pos += 1
        key = self.text[start : self.pos].strip()
        if not key:
            self.fail("expected a field name")
        try:
            parse_path(key)
        except ValueError:
            self.pos = start
            self.fail("'%s' is not a field name" % key)
        return key

    def mapping(self):
        self.pos += 1  # '{'
        out = self.pairs(closer="}")
        self.pos += 1
        return out

    def sequence(self):
        self.pos += 1  # '['
        out = []
        while True:
            c = self.peek()
            if c == "]":
                self.pos += 1
                return out
            if c == "":
                self.fail("missing ']'")
            if c == ",":
                self.fail("missing list item")
            out.append(self.value())
            if self.peek() == ",":
                self.pos += 1

    def value(self):
        c = self.peek()
        if c == "{":
            return self.mapping()
        if c == "[":
            return self.sequence()
        if c in "\"'":
            return self.quoted()
        start = self.pos
        while self.pos < len(self.text) and self.text[self.pos] not in _STOP:
            self.pos += 1
        if self.pos == start:
            self.fail("unexpected '%s' (quote text that contains it)" % c)
        return Bare(self.text[start : self.pos])

    def quoted(self):
        quote = self.text[self.pos]
        self.pos += 1
        out = []
        text = self.text
        while self.pos < len(text):
            c = text[self.pos]
            self.pos += 1
            if c == quote:
                if quote == "'" and text.startswith("'", self.pos):  # YAML: '' inside '...'
                    out.append("'")
                    self.pos += 1
                    continue
                return "".join(out)
            if c == "\\" and quote == '"' and self.pos < len(text):
                escape = text[self.pos]
                self.pos += 1
                out.append({"n": "\n", "t": "\t", "r": "\r", "0": "\0"}.get(escape, escape))
            else:
                out.append(c)
        self.fail("missing closing %s" % quote)


def parse_fields(texts):
    """{'field path': value} from the 'field: value' arguments (merged in
    order); leaves are str (quoted) or Bare (unquoted), lists and dicts.
    ValueSyntaxError names the argument and where it went wrong."""
    merged = {}
    for text in texts:
        try:
            pairs = _Parser(text).top()
        except ValueSyntaxError as error:
            raise ValueSyntaxError("'%s': %s" % (text, error)) from None
        for key, value in pairs.items():
            if key in merged:
                raise ValueSyntaxError("field '%s' given twice" % key)
            merged[key] = value
    return merged


# ------------------------------------------------------------- conversion


def _number(value, where):
    """An int, float or bool from a Bare word; text stays text (and fails in the packet)."""
    if not isinstance(value, Bare):
        return value
    word = value.strip()
    low = word.lower()
    if low in ("true", "false"):
        return low == "true"
    for convert in (lambda w: int(w, 0), lambda w: int(w, 10), float):
        try:
            return convert(word)
        except ValueError:
            pass
    raise FieldTypeError("%s: expects a number, got '%s'" % (where, word))


def _descriptor(part, name):
    descriptor = type(part).__dict__.get(name) if name in part._field_types else None
    if descriptor is None:
        raise AttributeError(
            "'%s' has no field '%s'; fields: %s" % (part._type_name, name, ", ".join(public_fields(part)))
        )
    return descriptor


def _where(part, name):
    return "field '%s' of '%s'" % (name, part._type_name)


def assign_fields(part, values):
    """Assigns parse_fields() output to a packet part, converting each value
    for its field; raises AttributeError / FieldTypeError / FieldValueError
    naming the field."""
    for key, value in values.items():
        _assign_path(part, parse_path(key), value)


def _assign_path(part, steps, value):
    name = steps[0]
    descriptor = _descriptor(part, name)
    rest = steps[1:]
    if not rest:
        _assign(part, name, descriptor, value)
        return
    index = rest[0] if isinstance(rest[0], int) else None
    if index is None:
        if not isinstance(descriptor, _Sub):
            raise AttributeError("%s has no sub-fields (it is not a sub-type)" % _where(part, name))
        _assign_path(getattr(part, name), rest, value)
        return
    current = getattr(part, name)
    if isinstance(descriptor, (_Scalar, _CharArray, _DynText, _Length, _Sub)) or not hasattr(current, "__len__"):
        raise FieldTypeError("%s is not an array" % _where(part, name))
    if not -len(current) <= index < len(current):
        raise FieldValueError("%s: index %d is out of range (%d items)" % (_where(part, name), index, len(current)))
    if isinstance(descriptor, (_SubArray, _DynSub)):
        item = current[index]
        if len(rest) == 1:
            _assign_part(item, value, "%s[%d]" % (name, index))
        elif isinstance(rest[1], str):
            _assign_path(item, rest[1:], value)
        else:
            _fail_nested_index(part, name)
        return
    if len(rest) > 1:
        _fail_nested_index(part, name)
    items = list(current)
    items[index] = _number(value, "%s[%d]" % (_where(part, name), index))
    setattr(part, name, items)


def _fail_nested_index(part, name):
    raise FieldTypeError("%s: arrays have one index" % _where(part, name))


def _assign_part(part, value, field_name):
    if not isinstance(value, dict):
        raise FieldTypeError(
            "field '%s' is a %s: give its fields as {%s}"
            % (field_name, part._type_name, ", ".join("%s: ..." % f for f in public_fields(part)))
        )
    assign_fields(part, value)


def _assign(part, name, descriptor, value):
    where = _where(part, name)
    if isinstance(descriptor, _Length):
        return  # follows its dynamic field
    if isinstance(descriptor, (_CharArray, _DynText)):
        if isinstance(value, (list, dict)):
            raise FieldTypeError("%s: expects text, got %s" % (where, "a list" if isinstance(value, list) else "{...}"))
        setattr(part, name, str(value))
    elif isinstance(descriptor, _Char):
        # a number is the character's code (as echo shows it), a single letter the character
        if isinstance(value, Bare):
            try:
                value = _number(value, where)
            except FieldTypeError:
                if len(value) != 1:
                    raise
                value = str(value)
        setattr(part, name, value)
    elif isinstance(descriptor, _Scalar):
        if isinstance(value, (list, dict)):
            raise FieldTypeError(
                "%s: expects one number, got %s" % (where, "a list" if isinstance(value, list) else "{...}")
            )
        number = _number(value, where)
        if isinstance(number, float) and number.is_integer() and descriptor.ctype not in ("float", "double"):
            number = int(number)  # 1e3 for an integer field
        setattr(part, name, number)
    elif isinstance(descriptor, (_Array, _DynNumeric)):
        if isinstance(value, str) and not isinstance(value, Bare) and descriptor.dtype == np.uint8:
            data = value.encode("utf-8")  # "text" into a byte array, NUL padded
            if isinstance(descriptor, _Array):
                if len(data) > descriptor.count:
                    raise FieldValueError("%s: holds at most %d bytes, got %d" % (where, descriptor.count, len(data)))
                data = data.ljust(descriptor.count, b"\0")
            setattr(part, name, data)
            return
        if not isinstance(value, list):
            raise FieldTypeError("%s: expects a list like [1, 2, 3]" % where)
        setattr(part, name, [_number(item, "%s[%d]" % (where, i)) for i, item in enumerate(value)])
    elif isinstance(descriptor, _Sub):
        _assign_part(getattr(part, name), value, name)
    elif isinstance(descriptor, _SubArray):
        if not isinstance(value, list):
            raise FieldTypeError("%s: expects a list of %d items like [{...}, ...]" % (where, descriptor.count))
        if len(value) != descriptor.count:
            raise FieldValueError("%s: expects %d items, got %d" % (where, descriptor.count, len(value)))
        for i, (item, item_value) in enumerate(zip(getattr(part, name), value)):
            _assign_part(item, item_value, "%s[%d]" % (name, i))
    elif isinstance(descriptor, _DynSub):
        if not isinstance(value, list):
            raise FieldTypeError("%s: expects a list like [{...}, ...]" % where)
        items = []
        for i, item_value in enumerate(value):
            item = descriptor.cls(name="%s[%d]" % (name, i))
            _assign_part(item, item_value, "%s[%d]" % (name, i))
            items.append(item)
        setattr(part, name, items)
    else:  # pragma: no cover - every descriptor type is handled above
        raise FieldTypeError("%s cannot be set from the command line" % where)


# ------------------------------------------------------------- plain data


def public_fields(part):
    """Field names without the automatic `_len` companions of dynamic fields."""
    types = part._field_types
    return [name for name in part._fields if not (name.endswith("_len") and types.get(name[:-4], "").endswith("*"))]


def _float32_list(array):
    # the shortest text that reads back as the same float32, so 0.1f shows as 0.1
    return [float(np.format_float_positional(v, unique=True, trim="-")) if np.isfinite(v) else float(v) for v in array]


def to_plain(value, descriptor=None):
    """A packet (or field value) as dicts, lists, str, int and float."""
    if isinstance(value, Part):
        return {name: to_plain(getattr(value, name), type(value).__dict__.get(name)) for name in public_fields(value)}
    if isinstance(value, np.ndarray):
        if value.dtype == np.float32:
            return _float32_list(value)
        return value.tolist()
    if isinstance(value, list):
        return [to_plain(item) for item in value]
    if isinstance(value, np.generic):
        return to_plain(np.asarray([value]))[0]
    if isinstance(value, float) and isinstance(descriptor, _Scalar) and descriptor.ctype == "float":
        return _float32_list(np.asarray([value], np.float32))[0]
    return value


def select(part, steps):
    """The field value at a parse_path() path, as plain data; KeyError/IndexError
    with a message naming the path if it does not exist."""
    value, descriptor = part, None
    for i, step in enumerate(steps):
        if isinstance(step, str):
            if not isinstance(value, Part) or step not in type(value).__dict__ or step not in value._field_types:
                shown = format_path(steps[: i + 1])
                if isinstance(value, Part):
                    raise KeyError("no field '%s'; fields here: %s" % (shown, ", ".join(public_fields(value))))
                raise KeyError("no field '%s' ('%s' has no sub-fields)" % (shown, format_path(steps[:i])))
            descriptor = type(value).__dict__[step]
            value = getattr(value, step)
        else:
            if isinstance(value, (str, Part)) or not hasattr(value, "__len__"):
                raise KeyError("'%s' is not an array" % format_path(steps[:i]))
            if not -len(value) <= step < len(value):
                raise IndexError(
                    "index %d of '%s' is out of range (%d items)" % (step, format_path(steps[:i]), len(value))
                )
            value = value[step]
            descriptor = None if isinstance(value, Part) else descriptor
    return to_plain(value, descriptor)


def flatten(plain, prefix=""):
    """[(column, scalar)] of plain data: a.b, a.c[0], ... (for CSV)."""
    if isinstance(plain, dict):
        out = []
        for key, item in plain.items():
            out.extend(flatten(item, "%s.%s" % (prefix, key) if prefix else key))
        return out
    if isinstance(plain, list):
        out = []
        for i, item in enumerate(plain):
            out.extend(flatten(item, "%s[%d]" % (prefix, i)))
        return out
    return [(prefix or "value", plain)]
