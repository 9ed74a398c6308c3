"""MAT files written with libmatio (through ctypes): an independent writer of the
files LN 2.9's loggers save as .mat (scipy's savemat, level 5: 1-D columns as
1 x N rows, 2-D columns as N x k, object columns as cell arrays of 1 x 1 arrays).
LN 2.9 needs scipy for them, which its venv here lacks, so the tests make them so."""

import ctypes
import ctypes.util

import numpy as np

MAT_FT_MAT5 = 0x0100
_CLASSES = {
    "f8": (6, 9),
    "f4": (7, 7),
    "i1": (8, 1),
    "u1": (9, 2),
    "i2": (10, 3),
    "u2": (11, 4),
    "i4": (12, 5),
    "u4": (13, 6),
    "i8": (14, 12),
    "u8": (15, 13),
}
MAT_C_CELL, MAT_T_CELL = 1, 21


def _library():
    lib = ctypes.CDLL(ctypes.util.find_library("matio") or "libmatio.so.11")
    lib.Mat_CreateVer.restype = ctypes.c_void_p
    lib.Mat_CreateVer.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int]
    lib.Mat_VarCreate.restype = ctypes.c_void_p
    lib.Mat_VarCreate.argtypes = [
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_int,
        ctypes.c_int,
        ctypes.POINTER(ctypes.c_size_t),
        ctypes.c_void_p,
        ctypes.c_int,
    ]
    lib.Mat_VarSetCell.restype = ctypes.c_void_p
    lib.Mat_VarSetCell.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
    lib.Mat_VarWrite.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
    lib.Mat_VarFree.argtypes = [ctypes.c_void_p]
    lib.Mat_Close.argtypes = [ctypes.c_void_p]
    return lib


def write_mat(path, variables, compressed=False):
    """variables: {name: numpy array}; object arrays become cell arrays."""
    lib = _library()
    keep = []

    def create(name, array):
        if array.dtype == object:
            dims = (ctypes.c_size_t * 2)(*array.shape)
            cell = lib.Mat_VarCreate(name, MAT_C_CELL, MAT_T_CELL, 2, dims, None, 0)
            for i, value in enumerate(array.reshape(-1, order="F")):
                lib.Mat_VarSetCell(cell, i, create(b"", np.array([[value]], dtype=np.int64)))
            return cell
        data = np.asfortranarray(array)
        keep.append(data)
        klass, kind = _CLASSES[data.dtype.str[1:]]
        dims = (ctypes.c_size_t * 2)(*(data.shape if data.ndim == 2 else (1, data.shape[0])))
        return lib.Mat_VarCreate(name, klass, kind, 2, dims, data.ctypes.data_as(ctypes.c_void_p), 0)

    mat = lib.Mat_CreateVer(str(path).encode(), None, MAT_FT_MAT5)
    assert mat, "libmatio cannot create %s" % path
    for name, array in variables.items():
        var = create(name.encode(), np.asarray(array))
        assert lib.Mat_VarWrite(mat, var, 1 if compressed else 0) == 0, "libmatio cannot write %s" % name
        lib.Mat_VarFree(var)
    lib.Mat_Close(mat)


def logger_variables(columns, topic=None):
    """LN 2.9's variable names for a logger's flattened columns: of one topic COLUMN (a leading
    '_' moves to the end), of several TOPIC_COLUMN (without the leading '_'); '.', '/', '['
    become '_', ']' goes."""
    out = {}
    for column, values in columns.items():
        if topic is None:
            name = column[1:] + "_" if column.startswith("_") else column
        else:
            name = "%s_%s" % (topic, column[1:] if column.startswith("_") else column)
        out[name.replace(".", "_").replace("/", "_").replace("[", "_").replace("]", "")] = values
    return out
