"""Packet classes built from ln_core's message-definition model.

A message definition (as the native module's model describes it) becomes a
Python class whose instances are *parts*: every field is an attribute backed
by a bytes buffer laid out like LN's packed struct without dynamic fields.

* scalars read and write the buffer (``p.counter = 3``);
* fixed numeric arrays are numpy arrays that *are* views into the buffer;
* ``char name[N]`` is a str (UTF-8, NUL padded), ``char c`` an int;
* sub-types are nested parts (views into the same buffer), arrays of them
  lists of parts;
* dynamic fields (services only) are held beside the buffer: ``T* x`` as a
  numpy array, ``char* s`` as str, ``sub_t* l`` as a list of parts; the
  companion ``x_len`` always reports the length and is never set by hand.

Every assignment is checked at once, so a bad value raises (a FieldError,
or AttributeError for an unknown field, naming the field) before anything
is sent.

The flat form (``encode``/``decode``) is LN's service wire format: fields in
order, little endian, a dynamic field as a u32 count followed by its
elements, ``x_len`` not travelling on its own.
"""

from __future__ import annotations

import ast
import math
import os
import pickle
import re
import struct
import sys
from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import builtins
    from typing import Self

    from typing_extensions import Buffer

if sys.byteorder != "little":  # pragma: no cover
    raise ImportError("links_and_nodes on ln_core supports little-endian hosts only")

# c_name -> (struct code, numpy dtype)
PRIMITIVES: dict[str, tuple[str, np.dtype[Any]]] = {
    "float": ("f", np.dtype("<f4")),
    "double": ("d", np.dtype("<f8")),
    "char": ("B", np.dtype("u1")),
    "int8_t": ("b", np.dtype("i1")),
    "uint8_t": ("B", np.dtype("u1")),
    "int16_t": ("h", np.dtype("<i2")),
    "uint16_t": ("H", np.dtype("<u2")),
    "int32_t": ("i", np.dtype("<i4")),
    "uint32_t": ("I", np.dtype("<u4")),
    "int64_t": ("q", np.dtype("<i8")),
    "uint64_t": ("Q", np.dtype("<u8")),
}
_U32 = struct.Struct("<I")


class FieldError(TypeError, ValueError, OverflowError):
    """A value a field cannot hold. LN 2.9 raises TypeError, ValueError or
    OverflowError for such values, depending on where its conversion fails;
    a FieldError is all three, so an `except` written for LN 2.9 catches it."""


class FieldTypeError(FieldError):
    """The value's kind does not fit the field (a str for a number, ...)."""


class FieldValueError(FieldError):
    """The value does not fit: out of range, too long, wrong count."""


def _where(obj, name):
    return "field '%s' of '%s'" % (name, obj._type_name)


def _check_integral_array(obj, name, src, dtype):
    """Raises unless every value of `src` fits the integer `dtype` exactly."""
    if src.size == 0:
        return
    if src.dtype.kind == "f":
        if not np.all(np.isfinite(src)) or not np.all(src == np.floor(src)):
            raise FieldTypeError("%s: %s expects integers, got non-integral floats" % (_where(obj, name), dtype))
    info = np.iinfo(dtype)
    lo, hi = int(src.min()), int(src.max())  # exact: float64 rounds int64's maximum up to 2**63
    if lo < info.min or hi > info.max:
        raise FieldValueError(
            "%s: values must lie in [%d, %d] for %s, got %s..%s"
            % (_where(obj, name), info.min, info.max, dtype, lo, hi)
        )


def _as_numeric_array(obj, name, value, dtype, count=None):
    """`value` as a flat array of `dtype`, or a FieldError.

    Takes what LN 2.9 converts with numpy (sequences, nested ones flattened,
    arrays of any numeric dtype, numeric strings, None as NaN for floating
    point) and raw bytes (reinterpreted, as LN 2.9's services do); refuses
    what numpy would silently truncate or wrap into an integer type."""
    if isinstance(value, np.ndarray):
        src = value
    elif isinstance(value, (bytes, bytearray, memoryview)):
        data = memoryview(value).cast("B")
        if data.nbytes % dtype.itemsize:
            raise FieldValueError(
                "%s: %d bytes are not a whole number of %s values" % (_where(obj, name), data.nbytes, dtype)
            )
        src = np.frombuffer(data, dtype=dtype)
    elif isinstance(value, str):
        raise FieldTypeError("%s: expects a sequence of numbers, got a str" % _where(obj, name))
    else:
        try:
            src = np.asarray(value)
        except Exception as error:
            raise FieldTypeError("%s: cannot use %r as an array: %s" % (_where(obj, name), value, error)) from None
    if src.dtype.kind not in "biuf":
        if src.dtype.kind == "c":
            raise FieldTypeError("%s: expects real numbers (%s), got complex ones" % (_where(obj, name), dtype))
        try:  # numpy's own conversion: numeric strings, None
            src = np.array(src, dtype=dtype)
        except (TypeError, ValueError, OverflowError) as error:
            raise FieldTypeError(
                "%s: expects numbers (%s), got %r: %s" % (_where(obj, name), dtype, value, error)
            ) from None
    src = src.reshape(-1)
    if count is not None and src.size != count:
        raise FieldValueError("%s: expects %d values, got %d" % (_where(obj, name), count, src.size))
    if dtype.kind in "iu" and not np.can_cast(src.dtype, dtype, casting="safe"):
        _check_integral_array(obj, name, src, dtype)
    return src


def _char_codes(obj, name, value, count):
    """The bytes of `count` character codes (ints -128..255) given as a
    sequence or an integer array, as LN 2.9 takes them for `char x[N]`."""
    src = np.asarray(value)
    if src.dtype.kind not in "biu":
        raise FieldTypeError(
            "%s: expects a str, bytes or %d integer character codes, got %r" % (_where(obj, name), count, value)
        )
    src = src.reshape(-1)
    if src.size != count:
        raise FieldValueError("%s: expects %d character codes, got %d" % (_where(obj, name), count, src.size))
    if src.size and (src.min() < -128 or src.max() > 255):
        raise FieldValueError("%s: character codes must lie in [-128, 255]" % _where(obj, name))
    return (src.astype(np.int64) & 0xFF).astype(np.uint8).tobytes()


# --------------------------------------------------------------- descriptors


class _Scalar:
    __slots__ = ("name", "offset", "get", "set", "ctype")

    def __init__(self, name, offset, ctype):
        self.name, self.offset, self.ctype = name, offset, ctype
        s = struct.Struct("<" + PRIMITIVES[ctype][0])
        self.get, self.set = s.unpack_from, s.pack_into

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        return self.get(obj._buf, obj._off + self.offset)[0]

    def __set__(self, obj, value):
        try:
            self.set(obj._buf, obj._off + self.offset, value)
        except (struct.error, TypeError, OverflowError) as error:
            if self.ctype == "float" and isinstance(error, OverflowError):
                # beyond float32's range: infinity, as numpy and LN 2.9 convert it
                self.set(obj._buf, obj._off + self.offset, math.copysign(math.inf, float(value)))
                return
            if self.ctype == "int8_t" and isinstance(value, str) and len(value) == 1 and ord(value) < 128:
                self.set(obj._buf, obj._off + self.offset, ord(value))  # LN 2.9 writes the character's byte
                return
            raise self.error(obj, value, error) from None

    def __delete__(self, obj):
        self.set(obj._buf, obj._off + self.offset, 0)

    def error(self, obj, value, error):
        code = PRIMITIVES[self.ctype][0]
        if code in "fd":
            if not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
                return FieldTypeError("%s: expects a number, got %r" % (_where(obj, self.name), value))
            return FieldValueError("%s: %r does not fit %s" % (_where(obj, self.name), value, self.ctype))
        if isinstance(value, float) or not hasattr(value, "__index__"):
            return FieldTypeError("%s: expects an integer (%s), got %r" % (_where(obj, self.name), self.ctype, value))
        info = np.iinfo(PRIMITIVES[self.ctype][1])
        return FieldValueError(
            "%s: %r is out of range [%d, %d] for %s" % (_where(obj, self.name), value, info.min, info.max, self.ctype)
        )


class _LenientFloat(_Scalar):
    """A floating-point scalar of a service: like LN 2.9's services it also
    takes None (0.0) and numeric text."""

    def __set__(self, obj, value):
        if value is None:
            value = 0.0
        elif isinstance(value, (str, bytes)):
            try:
                value = float(value)
            except ValueError:
                raise FieldTypeError("%s: expects a number, got %r" % (_where(obj, self.name), value)) from None
        _Scalar.__set__(self, obj, value)


class _Char(_Scalar):
    """`char c`: an int 0..255 (LN 2.9 reads it unsigned); accepts -128..255,
    a one-byte str or bytes, "" for 0."""

    def __set__(self, obj, value):
        if isinstance(value, str):
            value = value.encode("utf-8")
        if isinstance(value, (bytes, bytearray)):
            if len(value) > 1:
                raise FieldValueError("%s: expects one byte, got %r" % (_where(obj, self.name), value))
            value = value[0] if value else 0
        if not hasattr(value, "__index__"):
            raise FieldTypeError("%s: expects a character or an int, got %r" % (_where(obj, self.name), value))
        value = value.__index__()
        if not -128 <= value <= 255:
            raise FieldValueError("%s: %d is out of range [-128, 255] for char" % (_where(obj, self.name), value))
        self.set(obj._buf, obj._off + self.offset, value & 0xFF)


class _TextChar(_Char):
    """`char c` of a service: LN 2.9 reads it as a one-character str ("" for 0)."""

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        byte = self.get(obj._buf, obj._off + self.offset)[0]
        return bytes((byte,)).rstrip(b"\0").decode("utf-8", "surrogateescape")


class _Array:
    """Fixed numeric array: a numpy view into the buffer."""

    __slots__ = ("name", "offset", "count", "dtype", "shape")

    def __init__(self, name, offset, count, dtype):
        self.name, self.offset, self.count, self.dtype = name, offset, count, dtype
        self.shape = (count,)

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        view = obj._cache.get(self.name)
        if view is None:
            view = obj._cache[self.name] = np.frombuffer(obj._buf, self.dtype, self.count, obj._off + self.offset)
        return view

    def __set__(self, obj, value):
        view = obj._cache.get(self.name)
        if view is None:
            view = self.__get__(obj)
        if value is view:
            return
        if (
            type(value) is np.ndarray
            and (value.dtype is self.dtype or value.dtype == self.dtype)
            and value.shape == self.shape
        ):
            # e.g. the same field of a received packet: nothing to convert or check
            view[...] = value
            return
        src = _as_numeric_array(obj, self.name, value, self.dtype, self.count)
        with np.errstate(over="ignore"):  # float32 overflow: infinity, as LN 2.9 sends it
            view[...] = src

    def __delete__(self, obj):
        self.__get__(obj)[...] = 0


class _CharArray:
    """`char s[N]`: a str, UTF-8 encoded, NUL padded; also takes bytes and N
    character codes (a list, tuple or integer array)."""

    __slots__ = ("name", "offset", "count")

    def __init__(self, name, offset, count):
        self.name, self.offset, self.count = name, offset, count

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        start = obj._off + self.offset
        raw = bytes(memoryview(obj._buf)[start : start + self.count]).rstrip(b"\0")
        return raw.decode("utf-8", "surrogateescape")

    def __set__(self, obj, value):
        if isinstance(value, (list, tuple, np.ndarray)):
            data = _char_codes(obj, self.name, value, self.count)
        else:
            data = _encode_text(obj, self.name, value)
        if len(data) > self.count:
            raise FieldValueError(
                "%s: holds at most %d bytes, got %d" % (_where(obj, self.name), self.count, len(data))
            )
        start = obj._off + self.offset
        memoryview(obj._buf)[start : start + self.count] = data.ljust(self.count, b"\0")

    def __delete__(self, obj):
        self.__set__(obj, b"")


def _encode_text(obj, name, value):
    if isinstance(value, str):
        try:
            return value.encode("utf-8", "surrogateescape")
        except UnicodeEncodeError as error:
            raise FieldValueError("%s: cannot encode %r as UTF-8: %s" % (_where(obj, name), value, error)) from None
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    raise FieldTypeError("%s: expects a str or bytes, got %r" % (_where(obj, name), value))


class _Sub:
    """A sub-type by value: a nested part viewing the same buffer."""

    __slots__ = ("name", "offset", "cls")

    def __init__(self, name, offset, cls):
        self.name, self.offset, self.cls = name, offset, cls

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        part = obj._cache.get(self.name)
        if part is None:
            part = obj._cache[self.name] = self.cls(obj._buf, obj._off + self.offset, name=self.name)
        return part

    def __set__(self, obj, value):
        self.__get__(obj)._assign(value, self.name)

    def __delete__(self, obj):
        self.__get__(obj)._clear()


class _SubArray:
    """A fixed array of sub-types: a list of nested parts."""

    __slots__ = ("name", "offset", "count", "cls")

    def __init__(self, name, offset, count, cls):
        self.name, self.offset, self.count, self.cls = name, offset, count, cls

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        parts = obj._cache.get(self.name)
        if parts is None:
            size = self.cls._size
            parts = obj._cache[self.name] = [
                self.cls(obj._buf, obj._off + self.offset + i * size, name="%s[%d]" % (self.name, i))
                for i in range(self.count)
            ]
        return parts

    def __set__(self, obj, value):
        parts = self.__get__(obj)
        try:
            n = len(value)
        except TypeError:
            raise FieldTypeError("%s: expects a sequence of %d items" % (_where(obj, self.name), self.count)) from None
        if n != self.count:
            raise FieldValueError("%s: expects %d items, got %d" % (_where(obj, self.name), self.count, n))
        if value is parts:
            return
        for part, item in zip(parts, value):
            part._assign(item, self.name)

    def __delete__(self, obj):
        for part in self.__get__(obj):
            part._clear()


class _DynNumeric:
    """`T* x`: a numpy array held beside the buffer."""

    __slots__ = ("name", "dtype")

    def __init__(self, name, dtype):
        self.name, self.dtype = name, dtype

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        value = obj._dyn.get(self.name)
        if value is None:
            value = obj._dyn[self.name] = np.zeros(0, self.dtype)
        return value

    def __set__(self, obj, value):
        if isinstance(value, np.ndarray) and value.dtype == self.dtype and value.ndim == 1:
            obj._dyn[self.name] = value
            return
        src = _as_numeric_array(obj, self.name, value, self.dtype)
        with np.errstate(over="ignore"):
            obj._dyn[self.name] = np.array(src, dtype=self.dtype)

    def __delete__(self, obj):
        obj._dyn.pop(self.name, None)

    def encode(self, obj, out):
        value = np.ascontiguousarray(self.__get__(obj), dtype=self.dtype)
        out.append(_U32.pack(value.size))
        out.append(value.tobytes())

    def decode(self, obj, data, pos):
        (n,) = _U32.unpack_from(data, pos)
        pos += 4
        end = pos + n * self.dtype.itemsize
        if end > len(data):
            raise ValueError("truncated data for field '%s'" % self.name)
        obj._dyn[self.name] = np.frombuffer(data, self.dtype, n, pos).copy()
        return end

    def length(self, obj):
        return len(self.__get__(obj))


class _DynText:
    """`char* s`: a str (kept UTF-8 encoded, so bad text fails on assignment).
    As in LN 2.9, None is "" and any other object its str()."""

    __slots__ = ("name",)

    def __init__(self, name):
        self.name = name

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        return obj._dyn.get(self.name, b"").decode("utf-8", "surrogateescape")

    def __set__(self, obj, value):
        if value is None:
            value = ""
        elif not isinstance(value, (str, bytes, bytearray, memoryview)):
            value = str(value)
        obj._dyn[self.name] = _encode_text(obj, self.name, value)

    def __delete__(self, obj):
        obj._dyn.pop(self.name, None)

    def encode(self, obj, out):
        data = obj._dyn.get(self.name, b"")
        out.append(_U32.pack(len(data)))
        out.append(data)

    def decode(self, obj, data, pos):
        (n,) = _U32.unpack_from(data, pos)
        pos += 4
        if pos + n > len(data):
            raise ValueError("truncated data for field '%s'" % self.name)
        obj._dyn[self.name] = bytes(data[pos : pos + n])
        return pos + n

    def length(self, obj):
        return len(obj._dyn.get(self.name, b""))


class _DynSub:
    """`sub_t* l`: a list of parts of the sub-type."""

    __slots__ = ("name", "cls")

    def __init__(self, name, cls):
        self.name, self.cls = name, cls

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        value = obj._dyn.get(self.name)
        if value is None:
            value = obj._dyn[self.name] = []
        return value

    def __set__(self, obj, value):
        if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
            raise FieldTypeError(
                "%s: expects a list of %s items or dicts" % (_where(obj, self.name), self.cls._type_name)
            )
        items = []
        for i, item in enumerate(value):
            if type(item) is self.cls:
                items.append(item)
            else:
                part = self.cls(name="%s[%d]" % (self.name, i))
                part._assign(item, self.name)
                items.append(part)
        obj._dyn[self.name] = items

    def __delete__(self, obj):
        obj._dyn.pop(self.name, None)

    def encode(self, obj, out):
        items = self.__get__(obj)
        out.append(_U32.pack(len(items)))
        for item in items:
            if type(item) is not self.cls:
                raise FieldTypeError(
                    "%s: items must be %s parts (use %s()), got %r"
                    % (_where(obj, self.name), self.cls._type_name, ctor_name(self.cls._type_name), item)
                )
            item._encode_into(out)

    def decode(self, obj, data, pos):
        (n,) = _U32.unpack_from(data, pos)
        pos += 4
        if n > len(data) - pos and self.cls._min_flat > 0:
            raise ValueError("truncated data for field '%s'" % self.name)
        items = []
        for i in range(n):
            part = self.cls(name="%s[%d]" % (self.name, i))
            pos = part._decode_from(data, pos)
            items.append(part)
        obj._dyn[self.name] = items
        return pos

    def length(self, obj):
        return len(self.__get__(obj))


class _PyObject:
    """`pyobject x` of a service (LN's local type name for ln2/pyobject): any
    Python object, pickled into the ln2/pyobject part `x_packet` when sent.
    A `pyobject x[N]` is a list of N objects, a `pyobject* x` a list."""

    __slots__ = ("name", "inner", "count")

    def __init__(self, name, inner, count):
        self.name, self.inner, self.count = name, inner, count  # count None: dynamic

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        value = obj._dyn.get(self.name, _MISSING)
        if value is _MISSING:
            value = obj._dyn[self.name] = None if self.count == 1 else [None] * (self.count or 0)
        return value

    def __set__(self, obj, value):
        if self.count != 1:
            if isinstance(value, dict) or not hasattr(value, "__len__"):
                raise FieldTypeError("%s: expects a list of Python objects" % _where(obj, self.name))
            if self.count is not None and len(value) != self.count:
                raise FieldValueError(
                    "%s: expects %d objects, got %d" % (_where(obj, self.name), self.count, len(value))
                )
            value = list(value)
        obj._dyn[self.name] = value

    def __delete__(self, obj):
        obj._dyn.pop(self.name, None)

    def _parts(self, obj):
        value = self.__get__(obj)
        if self.count == 1:
            return [self.inner.__get__(obj)], [value]
        if self.count is None:
            obj._dyn[self.inner.name] = [self.inner.cls(name="%s[%d]" % (self.name, i)) for i in range(len(value))]
        return self.inner.__get__(obj), value

    def encode(self, obj, out):
        parts, values = self._parts(obj)
        for part, value in zip(parts, values):
            try:
                part.data = pickle.dumps(value, _pickle_protocol())
            except Exception as error:
                raise FieldValueError("%s: cannot pickle %r: %s" % (_where(obj, self.name), value, error)) from None
            part.is_pickle = 1
        if self.count is None:
            self.inner.encode(obj, out)
        else:
            for part in parts:
                part._encode_into(out)

    def decode(self, obj, data, pos):
        if self.count is None:
            pos = self.inner.decode(obj, data, pos)
            parts = self.inner.__get__(obj)
        else:
            parts = [self.inner.__get__(obj)] if self.count == 1 else self.inner.__get__(obj)
            for part in parts:
                pos = part._decode_from(data, pos)
        values = [_unpickle(part) for part in parts]
        obj._dyn[self.name] = values[0] if self.count == 1 else values
        return pos

    def length(self, obj):
        return len(self.__get__(obj))


_MISSING = object()


def _pickle_protocol():
    """LN 2.9 reads the protocol from LN_PYOBJECT_PICKLE_PROTOCOL."""
    protocol = os.environ.get("LN_PYOBJECT_PICKLE_PROTOCOL")
    return int(protocol) if protocol else None


def _unpickle(part):
    """The object of a received ln2/pyobject part: its pickle, or a literal
    given as text (LN 2.9 evaluates that text with eval(); ln_core accepts
    literals only)."""
    raw = part.data.tobytes()
    if part.is_pickle:
        return pickle.loads(raw)
    return ast.literal_eval(raw.decode("ascii")) if raw else None


class _Length:
    """`x_len` of a dynamic field: always the current length of `x`."""

    __slots__ = ("name", "target")

    def __init__(self, name, target):
        self.name, self.target = name, target

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        return self.target.length(obj)

    def __set__(self, obj, value):
        if isinstance(value, float) or not hasattr(value, "__index__"):
            raise FieldTypeError("%s: expects an integer, got %r" % (_where(obj, self.name), value))
        # Like LN 2.9, the length always follows the data; nothing to store.

    def __delete__(self, obj):
        pass


# ------------------------------------------------------------------- parts

if TYPE_CHECKING:
    # what the Compiler puts in a part class for a field
    _Field = _Scalar | _Array | _CharArray | _Sub | _SubArray | _DynNumeric | _DynText | _DynSub | _PyObject | _Length
    # a field kept beside the buffer (it travels as a count and its items)
    _DynField = _DynNumeric | _DynText | _DynSub | _PyObject
    # a step of the flat form: a run of buffer bytes [start, end) or a field
    _PlanStep = tuple[int, int] | _Sub | _SubArray | _DynField


class Part:
    """One message (or sub-type) instance; fields are attributes."""

    __slots__ = ("_buf", "_off", "_cache", "_dyn", "_name")
    _fields: tuple[str, ...] = ()
    _field_types: dict[str, str] = {}
    _field_ctor_names: dict[str, str] = {}
    _type_name = ""
    _size = 0
    _fixed = True
    _plan: tuple[_PlanStep, ...] = ()
    _min_flat = 0

    def __init__(self, buf: Buffer | None = None, off: int = 0, name: str | None = None) -> None:
        self._buf = bytearray(self._size) if buf is None else buf
        self._off = off
        self._cache: builtins.dict[str, Any] = {}  # field -> its numpy view, part or list of parts
        self._dyn: builtins.dict[str, Any] = {}  # dynamic field -> its value
        self._name = self._type_name if name is None else name

    # LN 2.9 compatible helpers ------------------------------------------
    if TYPE_CHECKING:
        # The fields are attributes each part class gets from its message
        # definition (see Compiler): checkers cannot know them.
        def __getattr__(self, name: str) -> Any: ...
        def __setattr__(self, name: str, value: Any) -> None: ...

    def keys(self) -> list[str]:
        return list(self._fields)

    def items(self) -> list[tuple[str, Any]]:
        return [(k, getattr(self, k)) for k in self._fields]

    iteritems = items

    def __iter__(self) -> Iterator[tuple[str, Any]]:
        return iter(self.items())

    def get_field_types(self) -> builtins.dict[str, str]:
        return dict(self._field_types)

    def get_field_ctors(self) -> builtins.dict[str, Callable[..., Part]]:
        """{dynamic sub-type field: its item constructor (new_<type>_packet)}."""
        return {field: getattr(self, ctor) for field, ctor in self._field_ctor_names.items()}

    def dict(self, detect_ln_string: bool = False) -> builtins.dict[str, Any]:
        out: builtins.dict[str, Any] = {}
        for key in self._fields:
            out[key] = _plain(getattr(self, key), detect_ln_string)
        return out

    get_dict = dict

    def utf8_decode_char_fields(self, do_decode: bool) -> None:
        """Accepted for LN 2.9 compatibility; text is always decoded."""

    def __str__(self) -> str:
        if self._type_name != self._name:
            head = "%s %s" % (self._type_name, self._name)
        else:
            head = self._name
        return "<%s:\n\t%s\n>" % (head, ",\n\t".join("%s: %r" % kv for kv in self.items()))

    __repr__ = __str__

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Part)
            and other._type_name == self._type_name
            and bytes(self._flat()) == bytes(other._flat())
        )

    __hash__ = None  # type: ignore[assignment]  # mutable: equal by value, so not hashable

    def __copy__(self) -> Self:
        new = type(self)(name=self._name)
        new._assign(self, self._name)
        return new

    def __deepcopy__(self, memo: builtins.dict[int, Any]) -> Self:
        return self.__copy__()

    def copy(self) -> Self:
        return self.__copy__()

    # assignment of a whole part ------------------------------------------
    def _assign(self, value, field_name):
        if type(value) is type(self):
            self._decode_from(value._flat(), 0)
            return
        if isinstance(value, dict):
            for key, item in value.items():
                if key not in self._field_types:
                    raise AttributeError(
                        "'%s' (field '%s') has no field '%s'; fields: %s"
                        % (self._type_name, field_name, key, ", ".join(self._fields))
                    )
                setattr(self, key, item)
            return
        # Like LN 2.9: any object with these fields (a part of another packet,
        # a plain object); the length companions follow their data.
        cls = type(self)
        wanted = [k for k in self._fields if not isinstance(getattr(cls, k), _Length)]
        if (
            value is None
            or isinstance(value, (str, bytes, int, float, list, tuple))
            or not all(hasattr(value, k) for k in wanted)
        ):
            raise FieldTypeError(
                "field '%s': expects a %s part, a dict or an object with the fields %s, got %r"
                % (field_name, self._type_name, ", ".join(wanted), value)
            )
        for key in wanted:
            setattr(self, key, getattr(value, key))

    def _clear(self):
        memoryview(self._buf)[self._off : self._off + self._size] = bytes(self._size)
        self._dyn.clear()
        for value in self._cache.values():
            if isinstance(value, Part):
                value._clear()
            elif isinstance(value, list):
                for part in value:
                    part._clear()

    # flat form ------------------------------------------------------------
    def _flat(self):
        """The flat (wire) form as a bytes-like object."""
        if self._fixed:
            if isinstance(self._buf, bytearray):
                if self._off == 0 and len(self._buf) == self._size:
                    return self._buf
                return bytes(memoryview(self._buf)[self._off : self._off + self._size])
            # A borrowed packet's Loan: a byte view of it (a Loan has no len() and no slicing).
            return memoryview(self._buf).cast("B")[self._off : self._off + self._size]
        out: list[bytes] = []
        self._encode_into(out)
        return b"".join(out)

    def _encode_into(self, out):
        mv = memoryview(self._buf)
        off = self._off
        for step in self._plan:
            if type(step) is tuple:
                out.append(bytes(mv[off + step[0] : off + step[1]]))
            elif isinstance(step, (_Sub,)):
                step.__get__(self)._encode_into(out)
            elif isinstance(step, _SubArray):
                for part in step.__get__(self):
                    part._encode_into(out)
            else:  # a dynamic field (`type(step) is tuple` does not narrow the union)
                step.encode(self, out)  # type: ignore[union-attr]

    def _decode(self, data):
        """Fills this part from its flat form (the whole of `data`)."""
        if self._fixed:
            if len(data) != self._size:
                raise ValueError("'%s': expected %d bytes, got %d" % (self._type_name, self._size, len(data)))
            memoryview(self._buf)[self._off : self._off + self._size] = data
            return
        end = self._decode_from(data, 0)
        if end != len(data):
            raise ValueError("'%s': %d bytes left over" % (self._type_name, len(data) - end))

    def _decode_from(self, data, pos):
        mv = memoryview(self._buf)
        off = self._off
        for step in self._plan:
            if type(step) is tuple:
                n = step[1] - step[0]
                if pos + n > len(data):
                    raise ValueError("'%s': data too short" % self._type_name)
                mv[off + step[0] : off + step[1]] = data[pos : pos + n]
                pos += n
            elif isinstance(step, _Sub):
                pos = step.__get__(self)._decode_from(data, pos)
            elif isinstance(step, _SubArray):
                for part in step.__get__(self):
                    pos = part._decode_from(data, pos)
            else:  # a dynamic field (`type(step) is tuple` does not narrow the union)
                pos = step.decode(self, data, pos)  # type: ignore[union-attr]
        return pos


def _plain(value, detect_ln_string):
    if isinstance(value, Part):
        if detect_ln_string and _is_ln_string(value):
            return value.string
        return value.dict(detect_ln_string)
    if isinstance(value, list) and value and isinstance(value[0], Part):
        return [_plain(item, detect_ln_string) for item in value]
    return value


def _is_ln_string(part):
    return sorted(part._field_types.items()) == [("string", "char*"), ("string_len", "uint32_t")]


def _identifier(name):
    out = "".join(c if c.isalnum() else "_" for c in name).strip("_")
    return out if out and not out[0].isdigit() else "_" + out


class Compiler:
    """Builds (and caches) part classes from model dicts.

    Parts of services (service=True) differ from those of topics where LN
    2.9's service code does: a `char c` reads as a one-character str, and a
    floating-point scalar also takes None and numeric text."""

    def __init__(self) -> None:
        self._classes: dict[tuple[str, str, str, bool], type[Part]] = {}

    def part_class(
        self, model: Mapping[str, Any], section: str = "fields", suffix: str = "", service: bool = False
    ) -> type[Part]:
        """The class for `model`'s `section` ("fields" or "response_fields")."""
        key = (model["name"], model["hash"], section, service)
        cls = self._classes.get(key)
        if cls is None:
            cls = self._build(model, model[section], model["name"] + suffix, model.get("defs", {}), service)
            self._classes[key] = cls
        return cls

    def _sub_class(self, name, defs, service):
        sub = defs[name]
        key = (sub["name"], sub["hash"], "fields", service)
        cls = self._classes.get(key)
        if cls is None:
            cls = self._build(sub, sub["fields"], sub["name"], defs, service)
            self._classes[key] = cls
        return cls

    def _build(self, model, fields, type_name, defs, service):
        namespace = {"__slots__": (), "_type_name": type_name, "_ident": _identifier(type_name)}
        names, types = [], {}
        length_names = {f[0] + "_len" for f in fields if f[4]}
        plan: list[_PlanStep]
        plan, run_start, offset, fixed, min_flat = [], None, 0, True, 0
        pending_lengths: dict[str, _DynField] = {}
        field_ctors = {}  # dynamic sub-type field -> name of its item constructor

        def close_run():
            nonlocal run_start
            if run_start is not None and run_start < offset:
                plan.append((run_start, offset))
            run_start = None

        desc: _Field
        for name, spelling, prim, sub, dynamic, count, element in fields:
            names.append(name)
            types[name] = (spelling + "*") if dynamic else spelling
            if dynamic:
                close_run()
                fixed = False
                if prim:
                    desc = _DynText(name) if prim == "char" else _DynNumeric(name, PRIMITIVES[prim][1])
                else:
                    cls = self._sub_class(sub, defs, service)
                    desc = _DynSub(name, cls)
                    namespace[ctor_name(spelling)] = _make_ctor(cls, name)
                    field_ctors[name] = ctor_name(spelling)
                    if service and spelling == "pyobject":
                        desc = _PyObject(name, _DynSub(name + "_packet", cls), None)
                        namespace[name + "_packet"] = desc.inner
                namespace[name] = desc
                plan.append(desc)
                min_flat += 4
                length_name = name + "_len"
                if length_name in namespace or length_name in pending_lengths:
                    namespace[length_name] = _Length(length_name, desc)
                    pending_lengths.pop(length_name, None)
                else:
                    pending_lengths[length_name] = desc
                continue
            size = element * count
            is_length = name in length_names
            if prim:
                if count > 1 and prim == "char":
                    desc = _CharArray(name, offset, count)
                elif count > 1:
                    desc = _Array(name, offset, count, PRIMITIVES[prim][1])
                elif prim == "char":
                    desc = (_TextChar if service else _Char)(name, offset, prim)
                elif service and prim in ("float", "double"):
                    desc = _LenientFloat(name, offset, prim)
                else:
                    desc = _Scalar(name, offset, prim)
                if is_length:
                    close_run()  # the companion does not travel on its own
                elif run_start is None:
                    run_start = offset
                namespace[name] = desc
                if is_length and name in pending_lengths:
                    namespace[name] = _Length(name, pending_lengths.pop(name))
            else:
                cls = self._sub_class(sub, defs, service)
                desc = _Sub(name, offset, cls) if count == 1 else _SubArray(name, offset, count, cls)
                if service and spelling == "pyobject" and not cls._fixed:
                    desc.name = name + "_packet"
                    namespace[desc.name] = desc
                    desc = _PyObject(name, desc, count)
                namespace[name] = desc
                if cls._fixed:
                    if run_start is None:
                        run_start = offset
                else:
                    close_run()
                    fixed = False
                    plan.append(desc)
                min_flat += cls._min_flat * count
            if prim and not is_length:
                min_flat += size
            offset += size
        close_run()
        # dynamic fields without a companion field still answer x_len
        for length_name, desc in pending_lengths.items():
            namespace[length_name] = _Length(length_name, desc)
        namespace.update(
            _fields=tuple(names),
            _field_types=types,
            _field_ctor_names=field_ctors,
            _size=offset,
            _fixed=fixed,
            _plan=tuple(plan),
            _min_flat=min_flat if not fixed else offset,
        )
        return type(_identifier(type_name), (Part,), namespace)


def ctor_name(field_type: str) -> str:
    """LN's name of the constructor method for items of a dynamic sub-type field."""
    return "new_%s_packet" % re.sub(r"(^[0-9])|(\W+)", "_", field_type)


def _make_ctor(cls, field_name):
    def ctor(self, name=None, **fields):
        part = cls(name=field_name if name is None else name)
        if fields:
            part._assign(fields, field_name)
        return part

    return ctor


def ln29_definition(model: Mapping[str, Any]) -> dict[str, Any]:
    """The definition dict LN 2.9's manager hands to Python clients:
    fields as [type, name, count], resp_fields, defines by local type name."""
    defs = model.get("defs", {})

    def convert(fields, defines):
        out = []
        for name, spelling, _prim, sub, dynamic, count, _ in fields:
            out.append([spelling + ("*" if dynamic else ""), name, count])
            if sub and spelling not in defines:
                defines[spelling] = None
                defines[spelling] = convert(defs[sub]["fields"], defines)
        return out

    defines: dict[str, list[list[Any]] | None] = {}
    result = {"fields": convert(model["fields"], defines), "resp_fields": convert(model["response_fields"], defines)}
    result["defines"] = defines
    return result
