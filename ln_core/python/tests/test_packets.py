"""Packet classes from the md model, without a manager."""

import copy

import links_and_nodes as ln
import numpy as np
import pytest
from conftest import MSGDEFS
from links_and_nodes import _ln
from links_and_nodes._packets import Compiler


def part(name, section="fields", service=False):
    model = _ln.model_from_dirs(name, [MSGDEFS])
    return Compiler().part_class(model, section, service=service)(name=name)


def test_model_comes_from_the_md_library():
    model = _ln.model_from_dirs("pytest/all_types", [MSGDEFS])
    assert model["kind"] == "plain"
    assert model["size"] == 4 + 8 + 1 + 1 + 1 + 2 + 2 + 4 + 4 + 8 + 8 + 24 + 8 + 5 + 8 + 16 + 32
    assert "pytest/point" in model["defs"]
    assert len(model["hash"]) == 64


def test_model_from_sources_resolves_imports_like_the_parser():
    sources = {"a/top": 'define p as "pt"\np here\n', "a/pt": "double x\n"}
    model = _ln.model_from_sources("a/top", sources)
    assert model["fields"][0][3] == "a/pt"


def test_scalars_round_trip_through_the_buffer():
    p = part("pytest/all_types")
    p.f, p.d, p.i8, p.u8, p.i16, p.u16 = 1.5, 2.25, -5, 250, -300, 60000
    p.i32, p.u32, p.i64, p.u64 = -70000, 4000000000, -(2**40), 2**63
    p.c = "A"
    assert (p.f, p.d, p.i8, p.u8, p.i16, p.u16) == (1.5, 2.25, -5, 250, -300, 60000)
    assert (p.i32, p.u32, p.i64, p.u64, p.c) == (-70000, 4000000000, -(2**40), 2**63, 65)
    assert len(p._buf) == type(p)._size


def test_arrays_are_writable_numpy_views_into_the_buffer():
    p = part("pytest/all_types")
    assert isinstance(p.vec, np.ndarray) and p.vec.dtype == np.float64
    p.vec[1] = 3.0
    assert np.frombuffer(p._buf, np.float64, 3, 4 + 8 + 1 + 1 + 1 + 2 + 2 + 4 + 4 + 8 + 8)[1] == 3.0
    view = p.vec
    p.vec = [1, 2, 3]
    assert view is p.vec and list(view) == [1, 2, 3]
    p.small = np.array([1, -2, 3, -4], dtype=np.int64)
    assert p.small.dtype == np.int16 and list(p.small) == [1, -2, 3, -4]
    # another packet's field (same dtype and shape) is copied, never shared
    q = part("pytest/all_types")
    q.vec = p.vec
    p.vec[0] = 9.0
    assert list(q.vec) == [1, 2, 3] and q.vec is not p.vec
    with pytest.raises(ln.FieldValueError):
        q.vec = np.zeros(4)
    q.vec = np.zeros((3, 1))  # any shape with the right count, as before
    assert list(q.vec) == [0, 0, 0]


def test_char_arrays_are_text_and_subtypes_nested_parts():
    p = part("pytest/all_types")
    p.name = "héllo"
    assert p.name == "héllo"
    p.name = "ab"
    assert p.name == "ab"
    p.origin.x = 1.0
    p.corners[1].y = 2.0
    p.origin = {"y": 5.0}
    assert (p.origin.x, p.origin.y, p.corners[1].y) == (1.0, 5.0, 2.0)
    assert p.dict()["origin"] == {"x": 1.0, "y": 5.0}
    assert "origin" in str(p)


@pytest.mark.parametrize(
    "field,value,error",
    [
        ("u8", 256, ln.FieldValueError),
        ("i8", -129, ln.FieldValueError),
        ("u32", -1, ln.FieldValueError),
        ("u32", 1.5, ln.FieldTypeError),
        ("d", "x", ln.FieldTypeError),
        ("vec", [1, 2], ln.FieldValueError),
        ("vec", ["a", "b", "c"], ln.FieldTypeError),
        ("small", [1, 2, 3, 70000], ln.FieldValueError),
        ("small", [1.5, 2, 3, 4], ln.FieldTypeError),
        ("name", "far too long", ln.FieldValueError),
        ("name", "\udc80\ud800", ln.FieldValueError),
        ("name", 5, ln.FieldTypeError),
        ("c", 300, ln.FieldValueError),
        ("origin", 3, ln.FieldTypeError),
        ("corners", [{}, {}, {}], ln.FieldValueError),
    ],
)
def test_bad_values_raise_naming_the_field_and_leave_the_packet_alone(field, value, error):
    p = part("pytest/all_types")
    before = bytes(p._buf)
    with pytest.raises(error, match="'%s'" % field):
        setattr(p, field, value)
    assert bytes(p._buf) == before


def test_unknown_field_names_raise():
    p = part("pytest/all_types")
    with pytest.raises(AttributeError, match="u33"):
        p.u33 = 1
    with pytest.raises(AttributeError, match="nope"):
        p.origin = {"nope": 1}


def test_dynamic_fields_and_flat_form():
    req = part("pytest/echo")
    req.counter = 7
    req.values = [1.0, 2.0]
    req.text = "hi"
    req.points = [{"x": 1.0, "y": 2.0}]
    assert req.values_len == 2 and req.text_len == 2 and req.points_len == 1
    p = req.new_point_t_packet(x=3.0)
    req.points.append(p)
    flat = req._flat()
    # counter, vec[3], (n, values), (n, text), origin, (n, points)
    assert len(flat) == 4 + 24 + 4 + 16 + 4 + 2 + 16 + 4 + 32
    copy_ = part("pytest/echo")
    copy_._decode(flat)
    assert copy_ == req
    assert list(copy_.values) == [1.0, 2.0] and copy_.text == "hi" and copy_.points[1].x == 3.0
    with pytest.raises(ValueError):
        copy_._decode(flat[:-1])


def test_fixed_service_parts_are_their_buffer():
    req = part("pytest/small_srv")
    assert req._flat() is req._buf
    resp = part("pytest/small_srv", "response_fields")
    assert resp._fields == ("seq", "y")


def test_copy_is_independent():
    p = part("pytest/all_types")
    p.vec = [1, 2, 3]
    q = copy.deepcopy(p)
    q.vec[0] = 9
    assert p.vec[0] == 1 and q.vec[0] == 9


# LN 2.9's forms (tests/ln29_behaviour/test_ln29b_python_fields.py compares
# all of them with LN 2.9 itself)


def test_char_arrays_also_take_character_codes_and_bytes():
    p = part("pytest/all_types")
    p.name = list(b"pkt-1".ljust(8, b"\0"))  # a program written for LN 2.9 does this
    assert p.name == "pkt-1"
    p.name = tuple(b"ab".ljust(8, b"\0"))
    assert p.name == "ab"
    p.name = np.frombuffer(b"xyz".ljust(8, b"\0"), dtype=np.int8)
    assert p.name == "xyz"
    p.name = bytearray(b"raw")
    assert p.name == "raw"
    with pytest.raises(ln.FieldValueError, match="8 character codes"):
        p.name = list(b"short")  # LN 2.9 too wants one code per character
    with pytest.raises(ln.FieldTypeError, match="'name'"):
        p.name = [1.0] * 8


def test_scalars_take_what_ln29_takes():
    p = part("pytest/all_types")
    p.c = True
    assert p.c == 1
    p.c = ""
    assert p.c == 0
    p.i8 = "7"  # LN 2.9 writes the character's byte
    assert p.i8 == 55
    p.f = 1e39  # beyond float32: infinity
    assert p.f == float("inf")
    p.u64 = np.uint64(2**64 - 1)
    assert p.u64 == 2**64 - 1


def test_numeric_arrays_convert_like_numpy_but_refuse_truncation_and_wrapping():
    p = part("pytest/all_types")
    p.vec = ["1", "2.5", "3"]
    assert list(p.vec) == [1.0, 2.5, 3.0]
    p.vec = [None, 1, 2]
    assert np.isnan(p.vec[0])
    p.vec = np.arange(3, dtype=np.float64).tobytes()  # raw bytes, as LN 2.9's services take them
    assert list(p.vec) == [0.0, 1.0, 2.0]
    p.small = [[1, 2], [3, 4]]
    assert list(p.small) == [1, 2, 3, 4]
    with pytest.raises(ln.FieldTypeError, match="'small'"):
        p.small = np.array([1.5, 2, 3, 4])  # LN 2.9 truncates silently
    with pytest.raises(ln.FieldValueError, match="'small'"):
        p.small = np.array([70000, 2, 3, 4])  # LN 2.9 wraps silently


def test_field_errors_are_caught_by_what_ln29_raises():
    p = part("pytest/all_types")
    for exception in (TypeError, ValueError, OverflowError):
        with pytest.raises(exception):
            p.u8 = 300
        with pytest.raises(exception):
            p.name = None


def test_subtypes_take_any_object_with_their_fields():
    p = part("pytest/all_types")
    other = part("pytest/all_types", service=True)  # another class of the same type
    other.origin.x, other.origin.y = 1.5, 2.5
    p.origin = other.origin
    assert (p.origin.x, p.origin.y) == (1.5, 2.5)
    p.origin = type("Plain", (), {"x": 3.0, "y": 4.0})()
    assert (p.origin.x, p.origin.y) == (3.0, 4.0)
    with pytest.raises(ln.FieldTypeError, match="'origin'"):
        p.origin = type("Partial", (), {"x": 3.0})()


def test_service_parts_read_char_as_text_and_take_none_and_text_for_floats():
    req = part("pytest/echo", service=True)
    req.text = 12345  # LN 2.9: str() of anything else
    assert req.text == "12345"
    req.text = None
    assert req.text == "" and req.text_len == 0
    req.values = 5
    assert list(req.values) == [5.0]
    resp = part("pytest/small_srv", "response_fields", service=True)
    resp.y = "2.5"
    assert resp.y == 2.5
    resp.y = None
    assert resp.y == 0.0
    topic = part("pytest/all_types")
    with pytest.raises(ln.FieldTypeError):
        topic.d = None  # only services take None (as LN 2.9's services do)


def test_a_define_repeated_in_the_response_section():
    sources = {
        "s/svc": 'service\nrequest\ndefine item_t as "item"\nitem_t a\nresponse\ndefine item_t as "item"\nitem_t b\n',
        "s/item": "double x\n",
    }
    model = _ln.model_from_sources("s/svc", sources)
    assert model["fields"][0][3] == model["response_fields"][0][3] == "s/item"


def test_pyobject_fields_pickle_any_python_object():
    pyobject = "uint8_t* data\nint data_len\nint is_pickle\n"
    sources = {
        "p/svc": 'service\nrequest\ndefine pyobject as "ln2/pyobject"\npyobject args\n'
        'pyobject pair[2]\npyobject* many\nresponse\n',
        "ln2/pyobject": pyobject,
    }
    model = _ln.model_from_sources("p/svc", sources)
    cls = Compiler().part_class(model, "fields", service=True)
    req = cls(name="req")
    assert (req.args, req.pair, req.many, req.many_len) == (None, [None, None], [], 0)
    req.args = {"k": [1, 2.5]}
    req.pair = ("a", None)
    req.many = [1, {2}, "three"]
    assert req.many_len == 3 and req.args_packet._type_name == "ln2/pyobject"
    received = cls(name="received")
    received._decode(bytes(req._flat()))
    assert (received.args, received.pair, received.many) == ({"k": [1, 2.5]}, ["a", None], [1, {2}, "three"])
    assert received.args_packet.is_pickle == 1
    with pytest.raises(ln.FieldValueError, match="'pair'"):
        req.pair = [1]
    # text instead of a pickle: a literal (LN 2.9 evaluates any expression)
    received.args_packet.data, received.args_packet.is_pickle = b"[1, 'x']", 0
    from links_and_nodes._packets import _unpickle

    assert _unpickle(received.args_packet) == [1, "x"]


def test_get_field_ctors_names_the_item_constructors():
    req = part("pytest/echo", service=True)
    ctors = req.get_field_ctors()
    assert set(ctors) == {"points"}
    assert ctors["points"](x=1.0).x == 1.0
