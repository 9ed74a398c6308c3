"""The value syntax, its validation against message definitions, field
selection, and the output formats (no manager needed)."""

import io

import links_and_nodes as ln
import pytest
from conftest import MSGDEFS
from links_and_nodes import _ln
from links_and_nodes._packets import Compiler
from links_and_nodes.cli import values as V
from links_and_nodes.cli.output import Output, format_number, human_bytes, yaml_lines


def packet(md_name, section="fields"):
    model = _ln.model_from_dirs(md_name, [MSGDEFS])
    return Compiler().part_class(model, section)(name=md_name)


def filled(md_name, *texts, section="fields"):
    part = packet(md_name, section)
    V.assign_fields(part, V.parse_fields(texts))
    return part


# ------------------------------------------------------------------ syntax


@pytest.mark.parametrize(
    "text, expected",
    [
        ("a: 1", {"a": "1"}),
        ("a: 1, b: x", {"a": "1", "b": "x"}),
        ("a: 1 b: -2.5e3", {"a": "1", "b": "-2.5e3"}),  # spaces separate pairs too
        ("{a: 1, b: [1, 2, 3]}", {"a": "1", "b": ["1", "2", "3"]}),
        ("a: {x: 1, y: [1 2]}", {"a": {"x": "1", "y": ["1", "2"]}}),
        ('s: "two words, a: colon"', {"s": "two words, a: colon"}),
        ("s: 'it''s'", {"s": "it's"}),
        ('s: "tab\\there"', {"s": "tab\there"}),
        ('"quoted key": 1', {"quoted key": "1"}),
        ("corners[1].x: 7", {"corners[1].x": "7"}),
        ("a: 1,\nb: 2  # comment", {"a": "1", "b": "2"}),
        ("l: []", {"l": []}),
        ("", {}),
    ],
)
def test_parse(text, expected):
    assert V.parse_fields([text]) == expected


def test_bare_words_are_marked_and_quoted_ones_are_not():
    parsed = V.parse_fields(['a: 12, b: "12"'])
    assert isinstance(parsed["a"], V.Bare) and not isinstance(parsed["b"], V.Bare)


@pytest.mark.parametrize(
    "text, message",
    [
        ("a 1", "expected ':' after 'a'"),
        ("a:", "missing value for 'a'"),
        ("a: [1, 2", "missing ']'"),
        ("a: {x: 1", "missing '}'"),
        ("a: 'open", "missing closing '"),
        ("a: 1:2", "expected a field name"),
        ("a: [1,,2]", "missing list item"),
        ("{a: 1} b", "after the closing '}'"),
        ("a..b: 1", "not a field name"),
        ("a: 1, a: 2", "given twice"),
    ],
)
def test_parse_errors(text, message):
    with pytest.raises(V.ValueSyntaxError) as info:
        V.parse_fields([text])
    assert message in str(info.value) and text in str(info.value)


def test_arguments_merge_and_must_not_repeat_fields():
    assert V.parse_fields(["a: 1", "b: 2"]) == {"a": "1", "b": "2"}
    with pytest.raises(V.ValueSyntaxError, match="given twice"):
        V.parse_fields(["a: 1", "a: 2"])


# -------------------------------------------------------------- validation


def test_values_are_converted_for_their_fields():
    p = filled(
        "pytest/all_types",
        "f: 0.5, d: -1e-3, i8: -128, u8: 0xff, u16: 0b101, i64: -9_000, u64: 1e3",
        'name: 123, c: A, vec: [1, 2.5, nan], small: [1, -2, 3, 4], bytes: "hi", origin: {y: 2}',
        "corners[1].x: 7, corners[0]: {x: 1, y: 1}",
    )
    assert (p.f, p.d, p.i8, p.u8, p.u16, p.i64, p.u64) == (0.5, -1e-3, -128, 255, 5, -9000, 1000)
    assert p.name == "123" and p.c == ord("A")
    assert list(p.vec[:2]) == [1.0, 2.5] and p.vec[2] != p.vec[2]
    assert list(p.small) == [1, -2, 3, 4] and list(p.bytes) == [104, 105, 0, 0, 0]
    assert (p.origin.x, p.origin.y) == (0.0, 2.0)
    assert (p.corners[0].x, p.corners[0].y, p.corners[1].x) == (1.0, 1.0, 7.0)
    assert filled("pytest/all_types", "c: 65").c == 65 and filled("pytest/all_types", 'c: "7"').c == ord("7")
    assert filled("pytest/all_types", "u8: true").u8 == 1


def test_dynamic_fields_of_a_service_request():
    req = filled("pytest/echo", 'values: [1, 2], text: hello, points: [{x: 1}, {y: 2}], vec[2]: 9', section="fields")
    assert list(req.values) == [1.0, 2.0] and req.values_len == 2 and req.text == "hello"
    assert [(pt.x, pt.y) for pt in req.points] == [(1.0, 0.0), (0.0, 2.0)] and list(req.vec) == [0, 0, 9]


@pytest.mark.parametrize(
    "text, error, words",
    [
        ("u8: 256", ln.FieldValueError, ["u8", "out of range"]),
        ("i8: x", ln.FieldTypeError, ["field 'i8'", "expects a number, got 'x'"]),
        ("u32: 1.5", ln.FieldTypeError, ["u32", "integer"]),
        ("vec: [1, 2]", ln.FieldValueError, ["vec", "expects 3 values, got 2"]),
        ("vec: 1", ln.FieldTypeError, ["vec", "a list"]),
        ("vec[3]: 1", ln.FieldValueError, ["index 3 is out of range"]),
        ("name: toolongname", ln.FieldValueError, ["name", "at most 8 bytes"]),
        ("name: [1]", ln.FieldTypeError, ["name", "expects text"]),
        ("origin: 3", ln.FieldTypeError, ["origin", "{x: ..., y: ...}"]),
        ("origin: {z: 1}", AttributeError, ["no field 'z'", "x, y"]),
        ("corners: [{x: 1}]", ln.FieldValueError, ["corners", "expects 2 items, got 1"]),
        ("nope: 1", AttributeError, ["no field 'nope'", "f, d, c"]),
        ("d.x: 1", AttributeError, ["no sub-fields"]),
        ("d[0]: 1", ln.FieldTypeError, ["not an array"]),
        ("_fields: 1", AttributeError, ["no field '_fields'"]),
    ],
)
def test_invalid_values_name_the_field(text, error, words):
    with pytest.raises(error) as info:
        filled("pytest/all_types", text)
    for word in words:
        assert word in str(info.value)


# --------------------------------------------------------- plain and select


def test_to_plain_select_and_flatten():
    p = filled("pytest/all_types", "f: 0.1, vec: [1, 2, 3], name: ab, corners[1].y: -4")
    plain = V.to_plain(p)
    assert plain["f"] == 0.1  # the float32 read back as typed
    assert plain["vec"] == [1.0, 2.0, 3.0] and plain["name"] == "ab" and plain["corners"][1] == {"x": 0.0, "y": -4.0}
    assert V.select(p, V.parse_path("corners[1].y")) == -4.0
    assert V.select(p, V.parse_path("vec[-1]")) == 3.0
    assert V.select(p, V.parse_path("corners[1]")) == {"x": 0.0, "y": -4.0}
    for path, message in (
        ("zz", "no field 'zz'"),
        ("vec[3]", "out of range"),
        ("f.x", "no sub-fields"),
        ("f[0]", "not an array"),
        ("corners[0].z", "no field 'corners[0].z'"),
    ):
        with pytest.raises((KeyError, IndexError)) as info:
            V.select(p, V.parse_path(path))
        assert message in str(info.value)
    columns = dict(V.flatten(plain))
    assert columns["vec[2]"] == 3.0 and columns["corners[1].y"] == -4.0 and columns["origin.x"] == 0.0
    assert V.flatten(5, "") == [("value", 5)]
    req = filled("pytest/echo", "text: hi", section="fields")
    assert "text_len" not in V.to_plain(req) and V.to_plain(req)["text"] == "hi"


# ------------------------------------------------------------------ output


def test_yaml_lines():
    data = {"a": 1.5, "s": "x\"y", "l": [1, 2, 3], "d": {"b": True}, "items": [{"x": 1, "y": 2}], "e": {}}
    assert yaml_lines(data) == [
        "a: 1.5",
        's: "x\\"y"',
        "l: [1, 2, 3]",
        "d:",
        "  b: true",
        "items:",
        "  - x: 1",
        "    y: 2",
        "e: {}",
    ]
    assert yaml_lines({"long": list(range(10))}, max_array=3) == ["long: [0, 1, 2, ... (10 values)]"]


def test_table_alignment_and_colour():
    stream = io.StringIO()
    Output(stream=stream).table(("NAME", "N"), [("a", 1), ("bbb", 22)], numeric=(1,))
    assert stream.getvalue() == "NAME   N\na      1\nbbb   22\n"
    stream = io.StringIO()
    Output(stream=stream, colour="always").table(("NAME",), [("a",)])
    assert stream.getvalue() == "\033[1mNAME\033[0m\na\n"
    stream = io.StringIO()
    Output(stream=stream).table(("NAME",), [], empty="nothing")
    assert stream.getvalue() == "nothing\n"


def test_numbers_for_people():
    assert [format_number(v) for v in (0.1 * 29, 3.0, -0.5, 1e20, 2**0.5, float("nan"), 7)] == [
        "2.9",
        "3.0",
        "-0.5",
        "1e+20",
        "1.4142135623731",
        "nan",
        "7",
    ]


def test_human_units():
    assert human_bytes(512) == "512 B" and human_bytes(2048, per_second=True) == "2.05 KB/s"
    assert human_bytes(3.5e6) == "3.50 MB"
