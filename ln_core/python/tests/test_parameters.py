"""Parameters in Python: client.parameter_block() provides, client.get_parameters()
reads and overrides, between clients of one ln_core manager (LN 2.9's
semantics), and with C++ programs (cpp/param_*.cpp, LN 2.9's C++ API) on
either side. The C++ API itself is tested in src/parameters."""

import os
import subprocess
import threading
import time

import links_and_nodes as ln
import numpy as np
import pytest
from conftest import LN_CORE, build_cpp_programs, which_compiler

CPP = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cpp")


@pytest.fixture(scope="module")
def manager(builtins_manager):
    return builtins_manager  # ln/parameters/* from the source tree


class Loop:
    """Calls block.update() every millisecond in a thread, as a control loop."""

    def __init__(self, block):
        self.block = block
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop.is_set():
            self.block.update()
            time.sleep(0.001)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(5)


@pytest.fixture
def provider(manager, unique):
    c = ln.client("prov_" + unique)
    yield c
    c.close()


@pytest.fixture
def caller(manager, unique):
    c = ln.client("caller_" + unique)
    yield c
    c.close()


def make_block(provider, group, **extra):
    block = provider.parameter_block(group)
    block.add("gain", 1.5, description="the gain")
    block.add("n", 3)
    block.add("vec", [1.0, 2.0, 3.0])
    block.add("mat", np.arange(6, dtype=np.int16).reshape(2, 3), description="m")
    block.add("flag", True)
    block.add("sub.deep", 0.25)
    for name, add_arguments in extra.items():
        block.add(name, **add_arguments)
    return block.register()


def test_ln29_names():
    assert (ln.LN_PARAM_DOUBLE, ln.LN_PARAM_SINGLE, ln.LN_PARAM_BOOLEAN, ln.LN_PARAM_UINT64) == (0, 1, 8, 10)
    assert ln.ParameterBlock and ln.ParameterSignal and ln.ParameterOutputs and ln.parameters_proxy


def test_block_values_types_and_outputs(provider, unique):
    block = make_block(provider, "b" + unique)
    assert (block.gain.dtype, block.n.dtype, block.vec.dtype, block.mat.dtype, block.flag.dtype) == (
        np.float64,
        np.int64,
        np.float64,
        np.int16,
        np.bool_,
    )
    assert block.vec.shape == (3,) and block.mat.shape == (2, 3) and block.gain.shape == ()
    out = block.update()
    assert out.gain == 1.5 and isinstance(out.gain, float)
    assert out["n"] == 3 and out.flag is True
    assert out.mat.tolist() == [[0, 1, 2], [3, 4, 5]]
    assert list(out.keys()) == ["gain", "n", "vec", "mat", "flag", "sub.deep"]
    out = block.update(gain=2.0, vec=np.array([4, 5, 6]))
    assert out.gain == 2.0 and block.gain.input == 2.0 and out.vec.tolist() == [4.0, 5.0, 6.0]
    block.vec.input[0] = 9  # arrays changed in place are published too
    assert block.update().vec.tolist() == [9.0, 5.0, 6.0]


def test_proxy_reads_overrides_and_resets(provider, caller, unique):
    group = "p" + unique
    block = make_block(provider, group)
    block.update()
    params = caller.get_parameters(group)
    assert params.gain == 1.5 and params.n == 3 and params.flag is True
    assert params.vec.tolist() == [1.0, 2.0, 3.0] and params.mat.dtype == np.int16
    assert params.sub.deep == 0.25
    assert params.get_dict(full=True)["gain"] == {
        "input": 1.5,
        "output": 1.5,
        "override_enabled": False,
        "description": "the gain",
    }
    assert params["gain"]["full_name"] == group + ".gain"
    with Loop(block):
        params.gain = 2.5
        params.vec = [7, 8, 9]
        params.mat = np.ones((2, 3))
        params.sub.deep = -1e-20  # exact, also where LN 2.9's text is not
        params.set_override("n", 5, wait_step=True)
        assert block.gain.output == 2.5 and block.gain.input == 1.5
        assert params.gain == 2.5 and params.get_input("gain") == 1.5
        assert block.n.output == 5
        assert params.sub.deep == -1e-20
        params.gain = None  # ends the override
        params.refresh(wait_step=True)
        assert params.get_output("gain") == 1.5
    assert block.vec.output.tolist() == [7.0, 8.0, 9.0]
    assert block.mat.output.tolist() == [[1, 1, 1], [1, 1, 1]]
    assert sorted(params.get_dict()) == ["flag", "gain", "mat", "n", "sub", "vec"]
    assert str(params).startswith("<ln_parameters_proxy %r" % group)


def test_callbacks_check_and_learn_of_overrides(provider, caller, unique):
    group = "c" + unique
    block = provider.parameter_block(group)
    seen, threads = [], []
    block.add(
        "limit",
        5,
        dtype="int32",
        before_update=lambda v: v < 10,
        after_update=lambda v: (seen.append(v), threads.append(threading.current_thread())),
    )
    block.add("plain", 0.0, output=False)
    block.register()
    block.update()
    params = caller.get_parameters(group)
    with Loop(block) as loop:
        params.set_override("limit", 7, wait_step=True)
        with pytest.raises(ln.LNError, match="refused the value 12"):
            params.limit = 12
        params.set_override("plain", 3.0, wait_step=True)
    assert seen == [7] and threads == [loop.thread]
    assert block.limit.output == 7
    # Without an output the program keeps seeing its own value.
    assert block.plain.output == 0.0 and params.get_output("plain") == 3.0


def test_prefix_groups_and_empty_results(manager, provider, caller, unique, monkeypatch):
    monkeypatch.setenv("LN_PARAMETER_PREFIX", "robot%s." % unique)
    block = provider.parameter_block("arm")
    block.add("speed", 1.0)
    block.register()
    block.update()
    # The proxy puts the prefix in front as well.
    assert caller.get_parameters("arm").speed == 1.0
    monkeypatch.delenv("LN_PARAMETER_PREFIX")
    everything = caller.get_parameters("robot%s" % unique)
    assert everything.arm.speed == 1.0
    assert caller.get_parameters("robot%s.arm.speed" % unique).value == 1.0
    with pytest.raises(ln.LNError, match="no parameters matching"):
        caller.get_parameters("nothing" + unique)
    assert caller.get_parameters("nothing" + unique, allow_empty=True).get_dict() == {}


def test_bad_input_gets_clear_errors(provider, caller, unique):
    group = "e" + unique
    block = provider.parameter_block(group)
    with pytest.raises(ValueError, match="scalars, vectors or matrices"):
        block.add("cube", np.zeros((2, 2, 2)))
    with pytest.raises(TypeError, match="dtype"):
        block.add("x", 1, dtype="complex64")
    with pytest.raises(ValueError, match="does not fit"):
        block.add("small", 300, dtype="int8")
    with pytest.raises(ValueError, match="integral"):
        block.add("whole", 2.5, dtype="int32")
    with pytest.raises(RuntimeError, match="register"):
        block.update()
    block.add("s8", -5, dtype="int8")
    block.add("d", [1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ValueError, match="added already"):
        block.add("s8", 1)
    block.register()
    with pytest.raises(RuntimeError, match="after register"):
        block.add("late", 1)
    with pytest.raises(KeyError):
        block.update(bogus=1)
    with pytest.raises(ValueError, match="shape"):
        block.update(d=[1, 2])
    params = caller.get_parameters(group)
    with Loop(block):
        with pytest.raises(ln.LNError, match="300 does not fit int8"):
            params.s8 = 300
        with pytest.raises(ln.LNError, match="takes 4 values"):
            params.d = [1, 2, 3]
        with pytest.raises(TypeError):
            params.d = "abc"
        with pytest.raises(KeyError):
            params.set_override("nothere", 1)
    assert params.s8 == -5


def test_a_second_block_cannot_take_a_name(provider, unique):
    group = "d" + unique
    first = provider.parameter_block(group)
    first.add("a", 1.0)
    first.register()
    second = provider.parameter_block(group)
    second.add("a", 2.0)
    with pytest.raises(ln.LNError, match="provided by block"):
        second.register()


def test_values_on_topics(provider, caller, unique):
    group = "t" + unique
    block = make_block(provider, group)
    block.update()
    params = caller.get_parameters(group)
    with Loop(block):
        ports = params.subscribe()
        assert len(ports) == 1
        params.gain = 2.5
        params.read()
        params.read()  # a packet written after the override
        assert params.get_output("gain", refresh=False) == 2.5
        assert params["gain"]["override_enabled"] is True
        assert params.get_input("mat", refresh=False).tolist() == [[0, 1, 2], [3, 4, 5]]
        assert params.get_input("mat", refresh=False).dtype == np.int16
        assert params.sub.get_input("deep", refresh=False) == 0.25
    # A block that always publishes, on a topic of its choice.
    always = provider.parameter_block("a" + unique, always_publish=True, topic_name="always." + unique)
    always.add("x", 1.0)
    always.add("v", [1, 2], dtype="int16")
    always.register()
    port = caller.subscribe("always." + unique)
    with Loop(always):
        packet = port.read(2.0)
        assert packet is not None
    part = getattr(packet, "a" + unique)
    assert part.x.dict() == {"input": 1.0, "output": 1.0, "override_enabled": 0}
    assert list(part.v.input) == [1, 2]


def test_topics_of_names_that_are_no_tree(provider, caller, unique):
    block = provider.parameter_block("n" + unique)
    block.add("a", 1.0)
    block.add("a.b", 2.0)
    block.register()
    block.update()
    params = caller.get_parameters("n" + unique)
    with pytest.raises(ln.LNError, match="also the name of a group"):
        params.subscribe()
    always = provider.parameter_block("m" + unique, always_publish=True)
    always.add("c", 1.0)
    always.add("c.d", 2.0)
    with pytest.raises(ln.LNError, match="also the name of a group"):
        always.register()


# ------------------------------------------------------------------ with C++


@pytest.fixture(scope="module")
def cpp(tmp_path_factory):
    """param_provider and param_client, built against ln_core's headers and libln."""
    lib = os.environ.get("LN_CORE_LIB")
    include = os.environ.get("LN_CORE_INCLUDE_DIR", os.path.join(LN_CORE, "include"))
    compiler = which_compiler()
    if not (lib and os.path.exists(lib) and compiler):
        pytest.skip("needs libln (LN_CORE_LIB) and g++")
    out = tmp_path_factory.mktemp("param_cpp")
    return build_cpp_programs(compiler, lib, [include], ("param_provider", "param_client"), out)


def test_cpp_provider_python_client(manager, caller, cpp, unique):
    group = "cpp" + unique
    program = subprocess.Popen(
        [cpp["param_provider"], group], env=manager.env(), stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert program.stdout.readline().strip() == "ready"
        params = caller.get_parameters(group)
        assert params.gain == 1.5 and params.flag is True
        assert params.vec.tolist() == [1.0, 2.0, 3.0] and params.vec.dtype == np.float64  # dtype=float, as LN 2.9
        assert params.mat.tolist() == [[1, -2], [3, -4]] and params.mat.dtype == np.int16
        assert params.get_dict(full=True)["limit"]["description"] == "below 100"
        params.set_override("limit", 42, wait_step=True)
        assert program.stdout.readline().strip() == "applied limit 42"
        with pytest.raises(ln.LNError, match="refused"):
            params.limit = 100
        params.gain = 0.125
        params.vec = [7, 8, 9]
        params.mat = [[5, 6], [7, 8]]
        params.set_override("flag", False, wait_step=True)
        program.stdin.close()
        assert program.wait(10) == 0
        assert program.stdout.read().strip() == "out gain=0.125 vec=7,8,9 mat=5,6,7,8 flag=0 limit=42"
    finally:
        if program.poll() is None:
            program.kill()
            program.wait()


def test_python_provider_cpp_client(manager, provider, cpp, unique):
    group = "py" + unique
    block = make_block(provider, group, small=dict(value=3, dtype="int8"))
    block.update()
    with Loop(block):
        result = subprocess.run(
            [cpp["param_client"], group], env=manager.env(), capture_output=True, text=True, timeout=60
        )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[:9] == [
        "gain: 1.500000",
        "n: 3",
        "mat: 2x3 5",
        "flag: true",
        "description: the gain",
        "set gain: 2.500000",
        "set vec: 6.000000",
        "set n: 2",
        "set mat: 6",
    ]
    assert lines[9].startswith("wrong shape: error ") and "shape [3]" in lines[9]
    assert lines[10].startswith("too big: error ") and "1000 does not fit int8" in lines[10]
    assert lines[11].startswith("unknown: error ") and "'%s.nothere'" % group in lines[11]
    assert block.gain.output == 2.5 and block.n.output == 2
    assert block.mat.output.tolist() == [[9, 8, 7], [6, 5, 4]]
