"""MATLAB level-5 MAT files (what LN 2.9's loggers write with manager_save(FILE.mat)),
read into numpy: numeric and logical arrays, char arrays, and cell arrays of those
(uncompressed or zlib-compressed elements). Structs, sparse and object arrays are
reported as unsupported; MAT v4 and v7.3 (HDF5) files as not level 5.

Format facts: a 128-byte header (text, subsystem offset, version 0x0100, endian
indicator "IM"); then data elements, each an 8-byte tag (type, byte count) or, when
the count fits, a 4-byte tag with its data; elements are padded to 8 bytes; arrays
are miMATRIX elements holding flags (class), dimensions, name and data in column order.
"""

import struct
import zlib

from ._native import BagError

_MI = {
    1: "i1",
    2: "u1",
    3: "i2",
    4: "u2",
    5: "i4",
    6: "u4",
    7: "f4",
    9: "f8",
    12: "i8",
    13: "u8",
    16: "u1",
    17: "u2",
    18: "u4",
}
MI_MATRIX, MI_COMPRESSED = 14, 15
_CLASS = {6: "f8", 7: "f4", 8: "i1", 9: "u1", 10: "i2", 11: "u2", 12: "i4", 13: "u4", 14: "i8", 15: "u8"}
CELL, STRUCT, OBJECT, CHAR, SPARSE = 1, 2, 3, 4, 5
LOGICAL = 0x0200


class _Reader:
    def __init__(self, data, order, path):
        self.data, self.order, self.path, self.at = data, order, path, 0

    def fail(self, what):
        raise BagError("%s: %s (at byte %d of an element)" % (self.path, what, self.at))

    def element(self):
        """(type, bytes) of the next data element."""
        if self.at + 8 > len(self.data):
            self.fail("the file ends inside an element tag (cut off?)")
        first, second = struct.unpack_from(self.order + "II", self.data, self.at)
        if first >> 16:  # small data element: 2-byte count, 2-byte type, 4 bytes of data
            kind, size = first & 0xFFFF, first >> 16
            if size > 4:
                self.fail("a small data element of %d bytes" % size)
            body = self.data[self.at + 4 : self.at + 4 + size]
            self.at += 8
            return kind, body
        kind, size = first, second
        start = self.at + 8
        if start + size > len(self.data):
            self.fail("an element of %d bytes, but the file ends before (cut off?)" % size)
        self.at = start + size
        if kind != MI_COMPRESSED:
            self.at += (-size) % 8
        return kind, self.data[start : start + size]


def _array(kind, body, order, path):
    import numpy as np

    if kind not in _MI:
        raise BagError("%s: data of element type %d, which a numeric array cannot hold" % (path, kind))
    return np.frombuffer(body, np.dtype(_MI[kind]).newbyteorder(order))


def _matrix(body, order, path):
    """(name, value) of a miMATRIX element's body."""
    import numpy as np

    r = _Reader(body, order, path)
    if not body:
        return "", np.empty((0, 0))
    kind, flags = r.element()
    if kind != 6 or len(flags) < 8:
        r.fail("an array without its flags")
    word = struct.unpack_from(order + "I", flags)[0]
    array_class = word & 0xFF
    kind, dims = r.element()
    dims = [int(d) for d in _array(kind, dims, order, path)]
    kind, name = r.element()
    name = bytes(name).decode("latin-1")
    count = int(np.prod(dims)) if dims else 0
    if array_class == CELL:
        cells = []
        for _ in range(count):
            kind, cell = r.element()
            if kind != MI_MATRIX:
                r.fail("a cell that is not an array")
            cells.append(_matrix(cell, order, path)[1])
        value = np.empty(count, dtype=object)
        value[:] = cells
        return name, value.reshape(dims, order="F")
    if array_class in (STRUCT, OBJECT, SPARSE):
        raise BagError(
            "%s: variable '%s' is a %s array, which LN logger files do not hold"
            % (path, name, {STRUCT: "struct", OBJECT: "object", SPARSE: "sparse"}[array_class])
        )
    if array_class == CHAR:
        kind, data = r.element()
        text = "".join(chr(c) for c in _array(kind, data, order, path))
        return name, np.array(text)
    if array_class not in _CLASS:
        raise BagError("%s: variable '%s' has the unknown array class %d" % (path, name, array_class))
    kind, data = r.element()
    values = _array(kind, data, order, path)
    if len(values) != count:
        raise BagError("%s: variable '%s' has %d values for dimensions %s" % (path, name, len(values), dims))
    dtype = "?" if word & LOGICAL else _CLASS[array_class]
    return name, values.astype(dtype).reshape(dims, order="F")


def read_mat5(path):
    """{variable name: numpy array} of a level-5 MAT file."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as error:
        raise BagError("cannot read %s: %s" % (path, error.strerror)) from None
    if len(data) < 128:
        raise BagError("%s: too short for a MAT file header" % path)
    indicator = data[126:128]
    if indicator not in (b"IM", b"MI"):
        raise BagError("%s: not a level-5 MAT file (MAT v4 and v7.3/HDF5 files are not supported)" % path)
    order = "<" if indicator == b"IM" else ">"
    variables = {}
    r = _Reader(data, order, path)
    r.at = 128
    while r.at < len(data):
        kind, body = r.element()
        if kind == MI_COMPRESSED:
            try:
                inner = zlib.decompress(body)
            except zlib.error as error:
                raise BagError("%s: a compressed element does not decompress: %s" % (path, error)) from None
            kind, body = _Reader(inner, order, path).element()
        if kind != MI_MATRIX:
            continue  # other top-level elements carry no variables
        name, value = _matrix(body, order, path)
        variables[name] = value
    return variables
