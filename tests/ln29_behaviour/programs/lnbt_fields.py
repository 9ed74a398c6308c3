"""Every field kind of a topic and a service, assigned in every form a Python
program may use, sent, received and printed -- one line per case.

Run with LN 2.9's Python and with ln_core's against a manager of the same
system (LN_MANAGER); test_ln29b_python_fields.py compares the transcripts.
Each line is

    <where> <field> <form>: ok <what the receiving side reads>
    <where> <field> <form>: rejected <builtin exception classes, most specific first>

where <where> is `topic`, `request` (the caller assigns, the provider reads)
or `response` (the provider assigns, the caller reads). A rejection may come
from the assignment or from the write/call (LN 2.9 checks topic fields only
when writing); both count as the same result.

Only the standard library, numpy and links_and_nodes; bounded in time.
"""

import sys
import threading
import time

import links_and_nodes as ln
import numpy as np

TOPIC_MD = "lnbt/fields/topic"
SERVICE_MD = "lnbt/fields/service"
READ_TIMEOUT = 2.0

# ------------------------------------------------------------------ printing


def builtin_classes(error):
    """The builtin exception classes an `except` clause could name to catch
    `error`, most specific first (user classes left out)."""
    import builtins

    return [
        c.__name__
        for c in type(error).__mro__
        if getattr(builtins, c.__name__, None) is c and c not in (BaseException, object)
    ]


def show(value):
    """A canonical text of a received value, naming its Python type."""
    if hasattr(value, "_fields") and not isinstance(value, tuple):
        return "{" + ", ".join("%s=%s" % (k, show(getattr(value, k))) for k in value._fields) + "}"
    if isinstance(value, np.ndarray):
        return "ndarray<%s>%r" % (value.dtype, value.tolist())
    if isinstance(value, np.generic):
        return "np.%s(%r)" % (type(value).__name__, value.item())
    if isinstance(value, (list, tuple)):
        return "%s[%s]" % (type(value).__name__, ", ".join(show(v) for v in value))
    return "%s(%r)" % (type(value).__name__, value)


def emit(where, field, form, result):
    print("%s %s %s: %s" % (where, field, form, result), flush=True)


# ------------------------------------------------------------------- values

INT_RANGES = {
    "c": (-128, 127),
    "i8": (-128, 127),
    "u8": (0, 255),
    "i16": (-(2**15), 2**15 - 1),
    "u16": (0, 2**16 - 1),
    "i32": (-(2**31), 2**31 - 1),
    "u32": (0, 2**32 - 1),
    "i64": (-(2**63), 2**63 - 1),
    "u64": (0, 2**64 - 1),
}


def integer_forms(lo, hi):
    return [
        ("int_7", lambda: 7),
        ("int_min", lambda: lo),
        ("int_max", lambda: hi),
        ("int_below_min", lambda: lo - 1),
        ("int_above_max", lambda: hi + 1),
        ("float_7.0", lambda: 7.0),
        ("float_7.5", lambda: 7.5),
        ("bool_True", lambda: True),
        ("np.int32_7", lambda: np.int32(7)),
        ("np.uint8_7", lambda: np.uint8(7)),
        ("np.int64_-1", lambda: np.int64(-1)),
        ("np.float64_7.0", lambda: np.float64(7.0)),
        ("np.bool_True", lambda: np.bool_(True)),
        ("str_7", lambda: "7"),
        ("bytes_7", lambda: b"7"),
        ("None", lambda: None),
        ("list_[7]", lambda: [7]),
        ("ndarray0d_7", lambda: np.array(7)),
        ("ndarray1_[7]", lambda: np.array([7])),
    ]


def float_forms(is_float32):
    return [
        ("int_7", lambda: 7),
        ("float_2.5", lambda: 2.5),
        ("float_1e-3", lambda: 1e-3),
        ("float_inf", lambda: float("inf")),
        ("float_1e39", lambda: 1e39),
        ("int_2**70", lambda: 2**70),
        ("bool_True", lambda: True),
        ("np.float32_2.5", lambda: np.float32(2.5)),
        ("np.float64_2.5", lambda: np.float64(2.5)),
        ("np.int32_7", lambda: np.int32(7)),
        ("str_2.5", lambda: "2.5"),
        ("bytes_2.5", lambda: b"2.5"),
        ("None", lambda: None),
        ("list_[2.5]", lambda: [2.5]),
        ("ndarray0d_2.5", lambda: np.array(2.5)),
        ("ndarray1_[2.5]", lambda: np.array([2.5])),
    ]


CHAR_FORMS = [
    ("str_A", lambda: "A"),
    ("bytes_A", lambda: b"A"),
    ("str_AB", lambda: "AB"),
    ("str_empty", lambda: ""),
    ("int_200", lambda: 200),
    ("int_-5", lambda: -5),
]


def char_array_forms(n):
    text = b"pkt-1"[: n - 1]
    return [
        ("str", lambda: text.decode()),
        ("str_empty", lambda: ""),
        ("str_full", lambda: "x" * n),
        ("str_too_long", lambda: "x" * (n + 1)),
        ("str_utf8", lambda: "\u00e9t\u00e9"),
        ("bytes", lambda: text),
        ("bytes_full", lambda: b"y" * n),
        ("bytes_too_long", lambda: b"y" * (n + 1)),
        ("bytes_high", lambda: b"\xff\xfe".ljust(n, b"\0")),
        ("bytearray_full", lambda: bytearray(b"z" * n)),
        ("list_of_ints_full", lambda: list(text.ljust(n, b"\0"))),
        ("tuple_of_ints_full", lambda: tuple(text.ljust(n, b"\0"))),
        ("list_of_ints_short", lambda: list(text)),
        ("list_of_ints_too_long", lambda: list(text.ljust(n + 1, b"\0"))),
        ("list_of_ints_high", lambda: [200] + [0] * (n - 1)),
        ("list_of_ints_negative", lambda: [-3] + [0] * (n - 1)),
        ("list_of_floats_full", lambda: [float(b) for b in text.ljust(n, b"\0")]),
        ("ndarray_uint8_full", lambda: np.frombuffer(text.ljust(n, b"\0"), dtype=np.uint8).copy()),
        ("ndarray_int8_full", lambda: np.frombuffer(text.ljust(n, b"\0"), dtype=np.int8).copy()),
        ("ndarray_int64_full", lambda: np.array(list(text.ljust(n, b"\0")), dtype=np.int64)),
        ("ndarray_uint8_short", lambda: np.frombuffer(text, dtype=np.uint8).copy()),
        ("np.bytes_", lambda: np.bytes_(text)),
        ("np.str_", lambda: np.str_(text.decode())),
        ("int_5", lambda: 5),
        ("None", lambda: None),
        ("list_of_str", lambda: list(text.decode().ljust(n, "\0"))),
    ]


def array_forms(n, dtype):
    dtype = np.dtype(dtype)
    integral = dtype.kind in "iu"
    ints = list(range(1, n + 1))
    forms = [
        ("list_of_ints", lambda: list(ints)),
        ("tuple_of_ints", lambda: tuple(ints)),
        ("list_of_floats_integral", lambda: [float(v) for v in ints]),
        ("list_of_floats", lambda: [v + 0.25 for v in ints]),
        ("range", lambda: range(1, n + 1)),
        ("list_short", lambda: ints[:-1]),
        ("list_too_long", lambda: ints + [9]),
        ("ndarray_same_dtype", lambda: np.array(ints, dtype=dtype)),
        ("ndarray_float64", lambda: np.array(ints, dtype=np.float64) + 0.5),
        ("ndarray_float64_integral", lambda: np.array(ints, dtype=np.float64)),
        ("ndarray_int64", lambda: np.array(ints, dtype=np.int64)),
        ("ndarray_float32", lambda: np.array(ints, dtype=np.float32)),
        ("ndarray_bool", lambda: np.array([True] * n)),
        ("ndarray_2d", lambda: np.array([ints], dtype=dtype)),
        ("nested_list", lambda: [ints]),
        ("ndarray_strided", lambda: np.array(ints + ints, dtype=dtype)[::2]),
        ("list_of_np_scalars", lambda: [dtype.type(v) for v in ints]),
        ("scalar_5", lambda: 5),
        ("str_abc", lambda: "abc"),
        ("bytes_n", lambda: bytes(ints)),
        ("None", lambda: None),
        ("list_with_None", lambda: [None] * n),
        ("list_of_str_digits", lambda: [str(v) for v in ints]),
    ]
    if integral:
        info = np.iinfo(dtype)
        forms += [
            ("list_above_max", lambda: [int(info.max) + 1] + ints[1:]),
            ("list_below_min", lambda: [int(info.min) - 1] + ints[1:]),
            (
                "ndarray_int64_above_max",
                lambda: (
                    np.array([int(info.max) + 1] + ints[1:], dtype=np.int64)
                    if info.max < 2**63 - 1
                    else np.array([2**64 - 1] + ints[1:], dtype=np.uint64)
                ),
            ),
            ("list_with_nan", lambda: [float("nan")] + ints[1:]),
        ]
    else:
        forms += [
            ("list_with_nan_inf", lambda: [float("nan"), float("inf")] + ints[2:]),
            ("list_1e39", lambda: [1e39] + ints[1:]),
        ]
    return forms


def sub_forms(fresh_part):
    return [
        ("dict", lambda: {"x": 1.5, "n": 2, "tag": "ab"}),
        ("dict_partial", lambda: {"x": 3.25}),
        ("dict_unknown_key", lambda: {"x": 1.0, "nope": 1}),
        ("part_same_type", fresh_part),
        ("tuple", lambda: (1.5, 2, "ab")),
        ("None", lambda: None),
        ("int_5", lambda: 5),
        ("object_with_attributes", lambda: type("Obj", (), {"x": 4.5, "n": 6, "tag": "cd"})()),
    ]


def sub_array_forms(fresh_part):
    return [
        ("list_of_dicts", lambda: [{"x": 1.5, "n": 1, "tag": "a"}, {"x": 2.5, "n": 2, "tag": "b"}]),
        ("list_of_parts", lambda: [fresh_part(), fresh_part()]),
        ("tuple_of_parts", lambda: (fresh_part(), fresh_part())),
        ("list_short", lambda: [fresh_part()]),
        ("None", lambda: None),
    ]


# ------------------------------------------------------------------- topics

TOPIC_SCALARS = ["c", "i8", "u8", "i16", "u16", "i32", "u32", "i64", "u64"]
TOPIC_ARRAYS = {
    "fa": (3, np.float32),
    "da": (3, np.float64),
    "i8a": (3, np.int8),
    "u8a": (4, np.uint8),
    "i16a": (2, np.int16),
    "u16a": (2, np.uint16),
    "i32a": (2, np.int32),
    "u32a": (2, np.uint32),
    "i64a": (2, np.int64),
    "u64a": (2, np.uint64),
}


def get_path(obj, path):
    for part in path.replace("[", ".[").split("."):
        obj = obj[int(part[1:-1])] if part.startswith("[") else getattr(obj, part)
    return obj


def set_path(obj, path, value):
    head, _, last = path.rpartition(".")
    if head:
        obj = get_path(obj, head)
    setattr(obj, last, value)


def topic_cases(sample_part):
    cases = []
    for name in TOPIC_SCALARS:
        cases += [(name, f) for f in integer_forms(*INT_RANGES[name])]
    cases += [("c", f) for f in CHAR_FORMS]
    cases += [("f", f) for f in float_forms(True)] + [("d", f) for f in float_forms(False)]
    cases += [("label", f) for f in char_array_forms(16)]
    for name, (n, dtype) in TOPIC_ARRAYS.items():
        cases += [(name, f) for f in array_forms(n, dtype)]
    cases += [("s", f) for f in sub_forms(sample_part)] + [("sa", f) for f in sub_array_forms(sample_part)]
    cases += [("s.x", f) for f in float_forms(False)[:4]] + [("s.tag", f) for f in char_array_forms(4)]
    cases += [("sa[1].n", f) for f in integer_forms(*INT_RANGES["i32"])[:6]]
    return cases


def baseline(field):
    """A value every system accepts, assigned (and written) before each case
    so that no case sees another's leftovers."""
    if field in ("label",):
        return "\0" * 16
    if field == "s.tag":
        return "\0" * 4
    if field in TOPIC_ARRAYS:
        return np.zeros(TOPIC_ARRAYS[field][0], dtype=TOPIC_ARRAYS[field][1])
    if field in ("s", "sa", "s.x", "sa[1].n"):
        return None  # restored from the object itself
    return 0


def run_topics(clnt):
    pub = clnt.publish("lnbt.fields.topic", TOPIC_MD)
    sub = clnt.subscribe("lnbt.fields.topic", TOPIC_MD, buffers=4)
    other = clnt.publish("lnbt.fields.other", TOPIC_MD)  # source of parts of the same type
    deadline = time.monotonic() + 10
    while sub.read(0.05) is None:
        pub.write()
        if time.monotonic() > deadline:
            raise SystemExit("the subscriber never received a packet")
    while sub.read(0.2) is not None:  # drain the handshake packets
        pass
    sample_values = iter(range(1, 1000))

    def sample_part():
        v = next(sample_values)
        other.packet.s.x, other.packet.s.n, other.packet.s.tag = v + 0.5, v, "p%d" % v
        return other.packet.s

    packet = pub.packet
    originals = {"s": packet.s, "sa": packet.sa, "s.x": 0.0, "sa[1].n": 0}
    emit("topic", "*", "initial", show(packet))
    for field, (form, make) in topic_cases(sample_part):
        base = baseline(field)
        set_path(packet, field, originals[field] if base is None else base)
        pub.write()
        sub.read(READ_TIMEOUT)
        try:
            set_path(packet, field, make())
            pub.write()
        except Exception as error:
            emit("topic", field, form, "rejected %s" % ",".join(builtin_classes(error)))
            set_path(packet, field, originals[field] if base is None else base)
            continue
        try:
            received = sub.read(READ_TIMEOUT)
        except Exception as error:
            emit("topic", field, form, "ok, but reading fails: %s" % ",".join(builtin_classes(error)))
            continue
        emit("topic", field, form, "ok %s" % (show(get_path(received, field)) if received is not None else "<nothing>"))
    # LN 2.9 writes a char array's new text over the old one without clearing the rest
    set_path(packet, "label", "hello world")
    pub.write()
    sub.read(READ_TIMEOUT)
    set_path(packet, "label", "hi")
    pub.write()
    received = sub.read(READ_TIMEOUT)
    emit("topic", "label", "str_after_longer_str", "ok %s" % show(received.label))
    emit("topic", "*", "received", show(received))


# ----------------------------------------------------------------- services

REQUEST_FIELDS = {
    "d": float_forms(False),
    "i32": integer_forms(*INT_RANGES["i32"]),
    "u8": integer_forms(*INT_RANGES["u8"]),
    "c": CHAR_FORMS + integer_forms(*INT_RANGES["c"])[:5],
    "label": char_array_forms(8),
    "da": array_forms(3, np.float64),
    "i16a": array_forms(2, np.int16),
}
RESPONSE_FIELDS = {
    "d": float_forms(False),
    "i32": integer_forms(*INT_RANGES["i32"]),
    "u8": integer_forms(*INT_RANGES["u8"])[:8],
    "label": char_array_forms(8),
    "da": array_forms(3, np.float64),
}


def dynamic_forms(kind):
    if kind == "double":
        return [
            ("list_of_floats", lambda: [1.5, 2.5]),
            ("list_of_ints", lambda: [1, 2, 3]),
            ("tuple", lambda: (1.5,)),
            ("empty_list", lambda: []),
            ("ndarray_float64", lambda: np.array([0.5, 1.5])),
            ("ndarray_int64", lambda: np.array([4, 5])),
            ("ndarray_float32", lambda: np.array([1.5], np.float32)),
            ("ndarray_2d", lambda: np.array([[1.0, 2.0], [3.0, 4.0]])),
            ("range", lambda: range(3)),
            ("scalar_5", lambda: 5),
            ("str_1.5", lambda: "1.5"),
            ("bytes_8", lambda: b"\0" * 8),
            ("None", lambda: None),
            ("list_with_str", lambda: [1.0, "x"]),
        ]
    if kind == "uint8":
        return [
            ("bytes", lambda: b"\x00\x01\xff"),
            ("bytearray", lambda: bytearray(b"ab")),
            ("list_of_ints", lambda: [1, 2, 255]),
            ("list_above_max", lambda: [1, 300]),
            ("list_negative", lambda: [-1]),
            ("str_abc", lambda: "abc"),
            ("ndarray_uint8", lambda: np.array([7, 8], np.uint8)),
            ("ndarray_int64", lambda: np.array([7, 8])),
            ("ndarray_float64", lambda: np.array([7.5])),
            ("empty_bytes", lambda: b""),
            ("None", lambda: None),
        ]
    if kind == "int32":
        return [
            ("list_of_ints", lambda: [1, -2]),
            ("list_of_floats", lambda: [1.5]),
            ("list_of_floats_integral", lambda: [1.0, 2.0]),
            ("ndarray_uint64", lambda: np.array([3], np.uint64)),
            ("list_above_max", lambda: [2**31]),
            ("ndarray_int64_above_max", lambda: np.array([2**31])),
        ]
    if kind == "text":
        return [
            ("str", lambda: "hello"),
            ("str_empty", lambda: ""),
            ("str_utf8", lambda: "gr\u00fc\u00df"),
            ("bytes", lambda: b"raw"),
            ("bytes_utf8", lambda: "\u00e9".encode()),
            ("int_12345", lambda: 12345),
            ("float_1.5", lambda: 1.5),
            ("None", lambda: None),
            ("list_of_str", lambda: ["a", "b"]),
            ("bytearray", lambda: bytearray(b"ba")),
            ("np.str_", lambda: np.str_("npstr")),
            ("str_with_nul", lambda: "a\0b"),
        ]
    raise ValueError(kind)


def pyobject_forms(count):
    """`pyobject x` (count 1), `pyobject x[count]` or `pyobject* x` (count None)."""
    single = [
        ("int", lambda: 5),
        ("str", lambda: "text"),
        ("dict", lambda: {"a": [1, 2.5], "b": None}),
        ("None", lambda: None),
        ("tuple", lambda: (1, "x", 2.5)),
        ("set", lambda: {3}),
        ("bytes", lambda: b"\x00raw"),
        ("nested_list", lambda: [[1], [2, [3]]]),
    ]
    if count == 1:
        return single
    n = count or 3
    forms = [
        ("list", lambda: [{"k": i} for i in range(n)]),
        ("tuple", lambda: tuple(range(n))),
        ("list_too_short", lambda: [1] * (n - 1)),
        ("str", lambda: "abc"),
    ]
    if count is None:
        forms += [("empty_list", lambda: [])]
    return forms


def sub_list_forms(new_part):
    return [
        ("list_of_new_parts", lambda: [new_part(x=1.5, n=1, tag="a"), new_part(x=2.5, n=2, tag="b")]),
        ("list_of_dicts", lambda: [{"x": 1.5, "n": 1, "tag": "a"}]),
        ("empty_list", lambda: []),
        ("tuple_of_new_parts", lambda: (new_part(x=3.5),)),
        ("None", lambda: None),
        ("list_of_ints", lambda: [1, 2]),
    ]


def request_cases(new_part, sample_part):
    cases = []
    for field, forms in REQUEST_FIELDS.items():
        cases += [(field, f) for f in forms]
    cases += [("s", f) for f in sub_forms(sample_part)] + [("sa", f) for f in sub_array_forms(sample_part)]
    cases += [("dv", f) for f in dynamic_forms("double")] + [("bv", f) for f in dynamic_forms("uint8")]
    cases += [("iv", f) for f in dynamic_forms("int32")] + [("text", f) for f in dynamic_forms("text")]
    cases += [("sl", f) for f in sub_list_forms(new_part)]
    cases += [("po", f) for f in pyobject_forms(1)] + [("poa", f) for f in pyobject_forms(2)]
    cases += [("pol", f) for f in pyobject_forms(None)]
    return cases


def response_cases(new_part, sample_part):
    cases = []
    for field, forms in RESPONSE_FIELDS.items():
        cases += [(field, f) for f in forms]
    cases += [("s", f) for f in sub_forms(sample_part)[:4]] + [("sa", f) for f in sub_array_forms(sample_part)[:3]]
    cases += [("dv", f) for f in dynamic_forms("double")] + [("bv", f) for f in dynamic_forms("uint8")]
    cases += [("text", f) for f in dynamic_forms("text")] + [("sl", f) for f in sub_list_forms(new_part)]
    cases += [("po", f) for f in pyobject_forms(1)]
    return cases


#: Forms that crash LN 2.9's process (an assertion in its native module, or a
#: char array sent as the raw bytes of a numpy array of another size, which
#: breaks the request so that unpacking it segfaults): no LN 2.9 program uses
#: them, so neither system runs them here.
ABORTS_LN29 = {
    (where, field, form)
    for where in ("request", "response")
    for field, form in (
        ("sa", "tuple_of_parts"),
        ("sl", "tuple_of_new_parts"),
        ("label", "ndarray_int64_full"),
        ("label", "ndarray_uint8_short"),
    )
}

REQUEST_SHOWN = (
    "d",
    "i32",
    "u8",
    "c",
    "label",
    "da",
    "i16a",
    "s",
    "sa",
    "dv",
    "dv_len",
    "bv",
    "iv",
    "text",
    "sl",
    "po",
    "poa",
    "pol",
)


class Provider:
    """Provides SERVICE_MD in a thread of its own client: for a request case
    it describes the received field in resp.received; for a response case it
    assigns the case's value to the response field."""

    def __init__(self, name):
        self.clnt = ln.client("lnbt_fields_provider")
        self.svc = self.clnt.get_service_provider(name, SERVICE_MD)
        self.svc.set_handler(self.handle)
        self.svc.do_register("lnbt_fields")
        self.cases = {}  # case id -> (field, make) of response cases
        self.errors = {}  # case id -> exception raised while answering
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop:
            self.clnt.wait_and_handle_service_group_requests("lnbt_fields", 0.05)

    def handle(self, request, req, resp):
        case = self.cases.get(req.case_id)
        resp.received = "|".join("%s=%s" % (k, show(getattr(req, k))) for k in REQUEST_SHOWN) if case is None else ""
        if case is not None:
            field, make = case
            reset_response(resp)
            try:
                setattr(resp, field, make())
                request.respond()
            except Exception as error:
                self.errors[req.case_id] = error
                raise
            return 0
        request.respond()
        return 0


def reset_request(req, sample_part):
    req.d, req.i32, req.u8, req.c, req.label = 0.0, 0, 0, "\0", "\0" * 8
    req.da, req.i16a = np.zeros(3), np.zeros(2, np.int16)
    req.dv, req.bv, req.iv, req.text, req.sl = np.zeros(0), np.zeros(0, np.uint8), np.zeros(0, np.int32), "", []
    req.po, req.poa, req.pol = None, [None, None], []


def reset_response(resp):
    resp.d, resp.i32, resp.u8, resp.label, resp.da = 0.0, 0, 0, "\0" * 8, np.zeros(3)
    resp.dv, resp.bv, resp.text, resp.sl, resp.po = np.zeros(0), np.zeros(0, np.uint8), "", [], None


def run_services(clnt):
    name = "lnbt.fields.service"
    provider = Provider(name)
    svc = clnt.get_service(name, SERVICE_MD)
    new_part = svc.req.new_sub_t_packet
    other = clnt.publish("lnbt.fields.parts", TOPIC_MD)
    counter = iter(range(1, 100000))

    def sample_part():
        v = next(counter)
        other.packet.s.x, other.packet.s.n, other.packet.s.tag = v + 0.5, v, "q%d" % (v % 100)
        return other.packet.s

    originals = {"s": svc.req.s, "sa": svc.req.sa}
    try:
        emit(
            "request",
            "*",
            "initial",
            "|".join("%s=%s" % (k, show(getattr(svc.req, k))) for k in REQUEST_SHOWN if hasattr(svc.req, k)),
        )
        case_id = 0
        for field, (form, make) in request_cases(new_part, sample_part):
            case_id += 1
            if ("request", field, form) in ABORTS_LN29:
                continue
            reset_request(svc.req, sample_part)
            if field in originals:
                setattr(svc.req, field, originals[field])
            svc.req.case_id = case_id
            try:
                setattr(svc.req, field, make())
                svc.call()
            except Exception as error:
                emit("request", field, form, "rejected %s" % ",".join(builtin_classes(error)))
                if field in originals:
                    setattr(svc.req, field, originals[field])
                continue
            seen = dict(item.split("=", 1) for item in svc.resp.received.split("|"))
            emit("request", field, form, "ok %s" % seen.get(field, "<missing>"))
            if field in ("dv",):
                emit("request", "dv_len", form, "ok %s" % seen.get("dv_len"))
        reset_request(svc.req, sample_part)
        for field, (form, make) in response_cases(new_part, sample_part):
            case_id += 1
            if ("response", field, form) in ABORTS_LN29:
                continue
            svc.req.case_id = case_id
            provider.cases[case_id] = (field, make)
            try:
                svc.call()
            except Exception as error:
                provider_error = provider.errors.get(case_id)
                emit("response", field, form, "rejected %s" % ",".join(builtin_classes(provider_error or error)))
                continue
            emit("response", field, form, "ok %s" % show(getattr(svc.resp, field)))
        emit(
            "response",
            "*",
            "received",
            "|".join("%s=%s" % (k, show(getattr(svc.resp, k))) for k in svc.resp._fields if k != "received"),
        )
    finally:
        provider.stop = True
        provider.thread.join(5)


def main():
    clnt = ln.client("lnbt_fields")
    what = sys.argv[1:] or ["topics", "services"]
    if "topics" in what:
        run_topics(clnt)
    if "services" in what:
        run_services(clnt)
    print("done", flush=True)


if __name__ == "__main__":
    main()
