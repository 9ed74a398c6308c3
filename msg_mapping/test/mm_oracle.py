"""Independent pure-Python reference encoders for the tests (no msg_mapping code involved).

cdr_encode(msg)            XCDR1 little-endian CDR of a ROS message object, with the positions of
                           alignment padding (rclpy leaves those bytes uninitialized).
ln_encode(msg, ...)        LN flat bytes of the same message, from the machine-readable pairing
                           that ln_mapping.json / ros_mapping.json record (codec.hpp documents the format).
random_message(cls, ...)   a ROS message filled with random values.
"""

import random
import struct

from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractSequence,
    AbstractString,
    Array,
    BasicType,
    BoundedSequence,
    BoundedString,
    NamespacedType,
)

BASIC = {  # rosidl typename -> struct format (little-endian), size
    "boolean": ("?", 1),
    "octet": ("B", 1),
    "char": ("B", 1),
    "uint8": ("B", 1),
    "int8": ("b", 1),
    "uint16": ("H", 2),
    "int16": ("h", 2),
    "uint32": ("I", 4),
    "int32": ("i", 4),
    "uint64": ("Q", 8),
    "int64": ("q", 8),
    "float": ("f", 4),
    "double": ("d", 8),
}
ROS_FMT = {
    "bool": "?",
    "byte": "B",
    "char": "B",
    "uint8": "B",
    "int8": "b",
    "uint16": "H",
    "int16": "h",
    "uint32": "I",
    "int32": "i",
    "uint64": "Q",
    "int64": "q",
    "float32": "f",
    "float64": "d",
}


def message_class(ros_type):
    """'pkg/msg/T' or 'pkg/srv/T_Request' -> the generated Python class."""
    import importlib

    package, kind, name = ros_type.split("/")
    module = importlib.import_module(f"{package}.{kind}")
    if kind == "srv":
        service, part = name.rsplit("_", 1)
        return getattr(getattr(module, service), part)
    return getattr(module, name)


def fields_of(cls):
    return [(slot[1:], slot_type) for slot, slot_type in zip(cls.__slots__, cls.SLOT_TYPES) if slot != "_check_fields"]


def nested_class(t):
    return message_class("/".join(t.namespaces + [t.name]))


# ------------------------------------------------------------------ CDR


class _CdrWriter:
    def __init__(self):
        self.body = bytearray()
        self.padding = set()  # positions in the full message (header included)

    def align(self, n):
        pad = (-len(self.body)) % n
        for i in range(pad):
            self.padding.add(4 + len(self.body) + i)
        self.body += bytes(pad)

    def put(self, fmt, value):
        self.align(struct.calcsize(fmt))
        self.body += struct.pack("<" + fmt, value)


def _cdr_value(w, t, v):
    if isinstance(t, BasicType):
        w.put(BASIC[t.typename][0], v[0] if isinstance(v, (bytes, bytearray)) else v)
    elif isinstance(t, AbstractString):
        data = v.encode("utf-8")
        w.put("I", len(data) + 1)
        w.body += data + b"\0"
    elif isinstance(t, NamespacedType):
        _cdr_struct(w, v)
    elif isinstance(t, Array):
        for x in v:
            _cdr_value(w, t.value_type, x)
    elif isinstance(t, AbstractSequence):
        w.put("I", len(v))
        for x in v:
            _cdr_value(w, t.value_type, x)
    else:
        raise TypeError(f"unsupported type {t}")


def _cdr_struct(w, msg):
    fields = fields_of(type(msg))
    if not fields:  # rosidl's structure_needs_at_least_one_member (not visible from Python)
        w.body += b"\0"
    for name, slot_type in fields:
        _cdr_value(w, slot_type, getattr(msg, name))


def cdr_encode(msg):
    """(bytes, padding positions) of the CDR serialization of `msg`."""
    w = _CdrWriter()
    _cdr_struct(w, msg)
    return b"\x00\x01\x00\x00" + bytes(w.body), w.padding


def equal_except_padding(a, b, padding):
    if len(a) != len(b):
        return False
    return all(x == y or i in padding for i, (x, y) in enumerate(zip(a, b)))


# ------------------------------------------------------------------ LN flat


class Pairing:
    """The paired types of mapping files, by LN name (and by ROS name for LN -> ROS types)."""

    def __init__(self, mapping_documents):
        self.types = {}  # LN name -> type
        self.by_ros = {}  # ROS name -> type (unique for LN -> ROS mappings)
        for doc in mapping_documents:
            for type_json in doc.get("types", []):
                self._add(type_json)
            for interface in doc["interfaces"]:
                for part in ("message", "request", "response", "connect", "call"):
                    if part in interface:
                        self._add(interface[part])

    def _add(self, type_json):
        self.types[type_json["ln_name"]] = type_json
        self.by_ros[type_json["ros_type"]] = type_json

    def ln_encode(self, msg, ln_name):
        out = bytearray()
        self._struct(out, msg, self.types[ln_name])
        return bytes(out)

    def _struct(self, out, msg, type_json):
        for f in type_json["fields"]:
            # rosidl's dummy member of an empty message is not visible from Python (it is 0)
            self._field(out, f, getattr(msg, f["ros"], 0))

    def _element(self, out, f, x):
        if f["element"] == "primitive":
            out += struct.pack("<" + ROS_FMT[f["ros_primitive"]], x[0] if isinstance(x, (bytes, bytearray)) else x)
        elif f["element"] == "string":
            data = x.encode("utf-8")
            out += struct.pack("<I", len(data)) + data
            if "string_capacity" in f:
                out += bytes(f["string_capacity"] - len(data))
        else:
            self._struct(out, x, self.types[f["ln_struct"]])

    def _element_size(self, f):
        if f["element"] == "primitive":
            return struct.calcsize(ROS_FMT[f["ros_primitive"]])
        if f["element"] == "string":
            return 4 + f["string_capacity"]
        out = bytearray()
        self._struct(out, message_class(f["ros_struct"])(), self.types[f["ln_struct"]])
        return len(out)

    def _field(self, out, f, v):
        shape = f["shape"]
        if shape == "opaque":
            out += bytes(v) if len(v) else struct.pack("<I", 0)
        elif shape == "single":
            self._element(out, f, v)
        elif shape == "fixed_array":
            for x in v:
                self._element(out, f, x)
        else:
            out += struct.pack("<I", len(v))
            for x in v:
                self._element(out, f, x)
            if shape == "inline_sequence":
                out += bytes((f["count"] - len(v)) * self._element_size(f))


# ------------------------------------------------------------------ random values


def _random_basic(rng, typename):
    if typename == "boolean":
        return rng.random() < 0.5
    if typename == "octet":
        return bytes([rng.randint(0, 255)])
    if typename in ("float", "double"):
        x = rng.uniform(-1e6, 1e6) if rng.random() < 0.9 else rng.choice([0.0, -0.0, 1e-30, float("inf")])
        return float(struct.unpack("<f", struct.pack("<f", x))[0]) if typename == "float" else x
    fmt = BASIC[typename][0]
    bits = 8 * struct.calcsize(fmt)
    if fmt.islower():
        return rng.randint(-(1 << (bits - 1)), (1 << (bits - 1)) - 1)
    return rng.randint(0, (1 << bits) - 1)


def _random_text(rng, limit):
    alphabet = "abcXYZ 019_/-äß€"
    return "".join(rng.choice(alphabet) for _ in range(rng.randint(0, limit)))


def _fits(text, bound):
    return bound is None or len(text.encode("utf-8")) <= bound


def random_value(rng, t, depth, opaque=None):
    if isinstance(t, BasicType):
        return _random_basic(rng, t.typename)
    if isinstance(t, AbstractString):
        bound = t.maximum_size if isinstance(t, BoundedString) else None
        while True:
            text = _random_text(rng, 12 if bound is None else min(bound, 12))
            if _fits(text, bound):
                return text
    if isinstance(t, NamespacedType):
        return random_message(rng, nested_class(t), depth + 1, opaque)
    if isinstance(t, AbstractNestedType):
        if isinstance(t, Array):
            n = t.size
        else:
            limit = t.maximum_size if isinstance(t, BoundedSequence) else 5
            n = rng.randint(0, min(limit, 5 if depth < 3 else 1))
        return [random_value(rng, t.value_type, depth, opaque) for _ in range(n)]
    raise TypeError(f"unsupported type {t}")


def random_message(rng, cls, depth=0, opaque=None):
    """A random `cls`; `opaque(cls, field_name, depth)` supplies values of opaque (recursive) fields."""
    msg = cls()
    for name, t in fields_of(cls):
        if opaque is not None:
            special = opaque(cls, name, depth)
            if special is not None:
                setattr(msg, name, special)
                continue
        setattr(msg, name, random_value(rng, t, depth, opaque))
    return msg


def opaque_filler(pairing, rng, max_depth=2):
    """Random valid LN flat bytes for the opaque fields of recursive types (empty when the count is 0)."""
    by_class = {}
    for ros_type, type_json in pairing.by_ros.items():
        for f in type_json["fields"]:
            if f["shape"] == "opaque":
                by_class.setdefault(ros_type, {})[f["ros"]] = f

    def fill(cls, name, depth):
        ros_type = f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"
        f = by_class.get(ros_type, {}).get(name)
        if f is None:
            return None
        n = rng.randint(0, 2) if depth < max_depth else 0
        if n == 0:
            return []
        element_cls = message_class(f["ros_struct"])
        data = struct.pack("<I", n)
        for _ in range(n):
            element = random_message(rng, element_cls, depth + 1, fill)
            data += pairing.ln_encode(element, f["ln_struct"])
        return list(data)

    return fill


def rng_for(name, trial):
    return random.Random(f"{name}:{trial}")
