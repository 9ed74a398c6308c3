"""LN -> ROS generation: names, escaping, collisions, package layout, the CLI and the CMake function."""

import json
import os
import re
import shutil
import subprocess

import pytest

import msg_mapping
from msg_mapping import cli

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "ln_corpus")

# rosidl_adapter's own patterns (parser.py), to check our names independently.
PACKAGE_RE = re.compile(r"^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$")
TYPE_RE = re.compile(r"^[A-Z][A-Za-z0-9]*$")


def library(**texts):
    lib = msg_mapping.Library()
    for name, text in texts.items():
        lib.add_source(name.replace("__", "/"), text)
    return lib


def generate(lib, *names, **naming):
    gen = msg_mapping.LnToRos(**naming)
    for name in names:
        gen.add(lib, name)
    return gen


def test_camel_to_snake_matches_rosidl():
    rosidl_pycommon = pytest.importorskip("rosidl_pycommon")
    import random

    rng = random.Random(5)
    alphabet = "aAbB1_Zz9"
    for _ in range(3000):
        word = "".join(rng.choice(alphabet) for _ in range(rng.randint(1, 10)))
        assert msg_mapping.camel_to_snake(word) == rosidl_pycommon.convert_camel_case_to_lower_case_underscore(word), (
            word
        )


def test_names_follow_rosidl_rules_for_the_corpus():
    lib = msg_mapping.Library([CORPUS])
    gen = generate(lib, *msg_mapping.definition_names_under(CORPUS))
    for package in gen.packages():
        assert PACKAGE_RE.match(package["name"])
        for path, text in package["files"].items():
            if path.endswith((".msg", ".srv")):
                assert TYPE_RE.match(os.path.basename(path).rsplit(".", 1)[0])
                for line in text.splitlines():
                    if line and not line.startswith("#") and line != "---":
                        field = line.split()[1]
                        assert PACKAGE_RE.match(field), (path, line)
                        assert not msg_mapping._native.is_reserved_identifier(field)


def test_field_escaping_and_mapping_record():
    lib = msg_mapping.Library([CORPUS])
    gen = generate(lib, "mmtest/keywords")
    package = gen.packages()[0]
    msg = package["files"]["msg/Keywords.msg"]
    for ros in (
        "yield_field",
        "string_field",
        "from_field",
        "int8_field",
        "num_counts",
        "http_server",
        "private_field",
        "trailing",
        "double_under",
        "true_field",
        "sequence_field",
    ):
        assert re.search(rf"^\S+ {ros}$", msg, re.M), ros
    mapping = json.loads(package["files"]["ln_mapping.json"])
    fields = {f["ln"]: f["ros"] for f in mapping["interfaces"][0]["message"]["fields"]}
    assert fields["string"] == "string_field" and fields["numCounts"] == "num_counts"
    assert '"mmtest/keywords"' in msg and mapping["interfaces"][0]["ln_hash"] in msg  # source name and hash


def test_types_and_len_companions():
    lib = msg_mapping.Library([CORPUS])
    gen = generate(
        lib,
        "mmtest/all_primitives",
        "mmtest/dynamic_plain",
        "mmtest/odd_lengths",
        "mmtest/tree",
        "mmtest/alarm_event",
        "mmtest/empty_service",
    )
    files = {path: text for p in gen.packages() for path, text in p["files"].items()}
    prims = files["msg/AllPrimitives.msg"]
    for line in (
        "float32 f",
        "float64 d",
        "uint8 c",
        "int8 i8",
        "uint8 u8",
        "int16 i16",
        "uint16 u16",
        "int32 i32",
        "uint32 u32",
        "int64 i64",
        "uint64 u64",
        "float32 f_alias",
        "float64 d_alias",
        "int16 s_alias",
        "int32 i_alias",
        "float32[3] fa",
        "float64[4] da",
        "uint8[16] text",
    ):
        assert re.search(rf"^{re.escape(line)}$", prims, re.M), line

    def declarations(text):
        return [line for line in text.splitlines() if line and not line.startswith("#")]

    dyn = files["msg/DynamicPlain.msg"]
    assert "float64[] values" in dyn and "string name" in dyn and "mmtest_ln_msgs/Point[] points" in dyn
    assert not any("_len" in line for line in declarations(dyn))  # the companions are gone
    odd = files["msg/OddLengths.msg"]  # uint64_t / int companions, one declared far from its field
    assert declarations(odd) == ["uint8 marker", "uint8[] blob", "int16 small", "string note"]
    assert "uint8[] children" in files["msg/Tree.msg"]  # recursion -> opaque bytes
    assert "string pattern" in files["msg/AlarmEventConnect.msg"] and "float64 stamp" in files["msg/AlarmEventCall.msg"]
    assert files["srv/EmptyService.srv"].rstrip().endswith("---")


def test_collisions_are_errors():
    lib = library(robot__arm_pose="double x\n", robot__armPose="double y\n")
    gen = msg_mapping.LnToRos()
    gen.add(lib, "robot/arm_pose")
    with pytest.raises(
        msg_mapping.MappingError,
        match=r"'robot/arm_pose' and 'robot/armPose' both map to ROS type "
        r"'robot_ln_msgs/msg/ArmPose'",
    ):
        gen.add(lib, "robot/armPose")
    gen.add(lib, "robot/arm_pose")  # the failed add left nothing behind

    lib = library(robot__foo_BAR="double x\n", robot__foo_bar="double y\n")
    gen = msg_mapping.LnToRos()
    gen.add(lib, "robot/foo_BAR")
    with pytest.raises(msg_mapping.MappingError, match="same generated file names"):
        gen.add(lib, "robot/foo_bar")

    lib = library(robot__fields="double numCounts\nuint8_t num_counts\n")
    with pytest.raises(
        msg_mapping.MappingError,
        match=r"LN definition 'robot/fields': fields 'numCounts' and "
        r"'num_counts' both map to the ROS field name 'num_counts'",
    ):
        generate(lib, "robot/fields")
    lib = library(robot__escape="double string\nuint8_t string_field\n")
    with pytest.raises(msg_mapping.MappingError, match="'string' and 'string_field' both map"):
        generate(lib, "robot/escape")
    lib = library(robot__svc="service\nrequest\ndouble a_b\ndouble aB\nresponse\n")
    with pytest.raises(msg_mapping.MappingError, match=r"'robot/svc' \(request\): fields 'a_b' and 'aB'"):
        generate(lib, "robot/svc")


def test_unmappable_names_are_errors():
    lib = library(**{"robot__pos\u00e9": "double x\n", "robot__a+b": "double x\n"})
    with pytest.raises(msg_mapping.MappingError, match=r"'robot/a\+b': its name contains '\+'"):
        generate(lib, "robot/a+b")
    with pytest.raises(msg_mapping.MappingError, match="byte 0xc3"):
        generate(lib, "robot/pos\u00e9")
    with pytest.raises(msg_mapping.MappingError, match="not a valid ROS package name"):
        generate(library(a__b="double x\n"), "a/b", single_package="Bad__name")


def test_package_cycles_need_one_package():
    lib = library(a__x='define y as "b/y"\ny inner\n', b__y='define z as "a/z"\nz inner\n', a__z="double v\n")
    gen = generate(lib, "a/x")
    with pytest.raises(msg_mapping.MappingError, match=r"cycle \(a_ln_msgs -> b_ln_msgs -> a_ln_msgs\).*--package"):
        gen.packages()
    single = generate(lib, "a/x", single_package="robot_interfaces")
    (package,) = single.packages()
    assert sorted(p for p in package["files"] if p.startswith("msg/")) == ["msg/AX.msg", "msg/AZ.msg", "msg/BY.msg"]


def test_package_files():
    lib = msg_mapping.Library([CORPUS])
    gen = generate(lib, "mmtest2/uses_other_package")
    packages = {p["name"]: p for p in gen.packages()}
    assert set(packages) == {"mmtest_ln_msgs", "mmtest2_ln_msgs"}
    p2 = packages["mmtest2_ln_msgs"]
    assert p2["dependencies"] == {"mmtest_ln_msgs"}
    assert "<depend>mmtest_ln_msgs</depend>" in p2["files"]["package.xml"]
    assert "<member_of_group>rosidl_interface_packages</member_of_group>" in p2["files"]["package.xml"]
    cmake = p2["files"]["CMakeLists.txt"]
    assert "rosidl_generate_interfaces(${PROJECT_NAME}" in cmake and "DEPENDENCIES mmtest_ln_msgs" in cmake
    # deterministic: a second run gives the same bytes
    again = {p["name"]: p for p in generate(msg_mapping.Library([CORPUS]), "mmtest2/uses_other_package").packages()}
    assert again["mmtest2_ln_msgs"]["files"] == p2["files"]


# ------------------------------------------------------------------ CLI


def test_cli_help(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for option in ("--dry-run", "--md-dir", "--recursive", "--out", "--rules", "--from-ros", "--package"):
        assert option in out


def test_cli_dry_run_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["--recursive", CORPUS, "--out", str(out), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "package mmtest_ln_msgs" in text and "mmtest_ln_msgs/msg/Nested.msg" in text and "  mmtest/tree" in text
    assert not out.exists()


def test_cli_writes_only_changes_and_removes_stale_files(tmp_path, capsys):
    defs = tmp_path / "defs" / "robot"
    defs.mkdir(parents=True)
    (defs / "pose").write_text("double x\n")
    (defs / "old").write_text("double y\n")
    out = tmp_path / "ws"
    args = ["--recursive", str(tmp_path / "defs"), "--out", str(out)]
    assert cli.main(args) == 0
    msg = out / "robot_ln_msgs" / "msg" / "Pose.msg"
    mtime = msg.stat().st_mtime_ns
    assert cli.main(args + ["--check"]) == 0
    assert cli.main(args) == 0
    assert msg.stat().st_mtime_ns == mtime  # unchanged content is not rewritten
    (defs / "old").unlink()
    (defs / "pose").write_text("double x\ndouble z\n")
    assert cli.main(args + ["--check"]) == 3
    assert "out of date" in capsys.readouterr().err
    assert cli.main(args) == 0
    assert "float64 z" in msg.read_text()
    assert not (out / "robot_ln_msgs" / "msg" / "Old.msg").exists()


def test_cli_errors(tmp_path, capsys):
    assert cli.main(["--md-dir", CORPUS, "--out", str(tmp_path), "mmtest/missing"]) == 1
    err = capsys.readouterr().err
    assert "ln_ros2_gen: error:" in err and "mmtest/missing" in err and "not found" in err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "broken").write_text("double\n")
    assert cli.main(["--recursive", str(bad), "--out", str(tmp_path / "o")]) == 1
    assert "broken" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--md-dir", CORPUS])
    assert exit_info.value.code == 2


def test_cli_depfile_and_single_package(tmp_path):
    depfile = tmp_path / "deps"
    assert (
        cli.main(
            [
                "--md-dir",
                CORPUS,
                "--package",
                "robot_interfaces",
                "--out",
                str(tmp_path / "o"),
                "--depfile",
                str(depfile),
                "mmtest/nested",
            ]
        )
        == 0
    )
    deps = depfile.read_text().split()
    assert sorted(os.path.basename(d) for d in deps) == ["empty", "mixed", "nested", "point"]
    msgs = sorted(os.listdir(tmp_path / "o" / "robot_interfaces" / "msg"))
    assert msgs == ["MmtestEmpty.msg", "MmtestMixed.msg", "MmtestNested.msg", "MmtestPoint.msg"]


def test_cli_from_ros(tmp_path, capsys):
    if not msg_mapping.ros_share_dirs():
        pytest.skip("no ROS share directories (AMENT_PREFIX_PATH)")
    out = tmp_path / "ln"
    assert (
        cli.main(
            [
                "--from-ros",
                "std_msgs/msg/Header",
                "std_srvs",
                "--out",
                str(out),
                "--capacity",
                "std_msgs/msg/Header.frame_id=64",
            ]
        )
        == 0
    )
    header = (out / "ros2" / "std_msgs" / "msg" / "Header").read_text()
    assert "char frame_id[64]" in header
    assert (out / "ros2" / "std_srvs" / "srv" / "SetBool").exists()
    assert (out / "ros2" / "builtin_interfaces" / "msg" / "Time").exists()
    mapping = json.loads((out / "ros2" / "ros_mapping.json").read_text())
    assert any(i["ros_type"] == "std_srvs/srv/Trigger" for i in mapping["interfaces"])
    lib = msg_mapping.Library([str(out)])  # what LN nodes will load
    assert lib.load("ros2/std_msgs/msg/Header")["packet_size"] == 8 + 4 + 64


# ------------------------------------------------------------------ CMake function

CMAKE_PROJECT = """cmake_minimum_required(VERSION 3.16)
project(demo_ln_interfaces NONE)
find_package(msg_mapping REQUIRED)
msg_mapping_generate_interfaces(RECURSIVE "{defs}" GENERATE_ONLY OUTPUT_VARIABLE files)
list(LENGTH files n)
message(STATUS "msg_mapping: ${{n}} interface files")
add_custom_target(show ALL)
"""


def test_cmake_function_regenerates_when_definitions_change(tmp_path):
    build_dir = os.environ.get("MSG_MAPPING_BUILD_DIR")
    cmake = shutil.which("cmake")
    if not build_dir or not cmake:
        pytest.skip("needs MSG_MAPPING_BUILD_DIR and cmake")
    defs = tmp_path / "defs" / "robot"
    defs.mkdir(parents=True)
    (defs / "pose").write_text("double x\n")
    source, build = tmp_path / "src", tmp_path / "build"
    source.mkdir()
    (source / "CMakeLists.txt").write_text(CMAKE_PROJECT.format(defs=tmp_path / "defs"))
    run = lambda *a: subprocess.run(a, capture_output=True, text=True, timeout=120)  # noqa: E731
    r = run(cmake, "-S", str(source), "-B", str(build), f"-Dmsg_mapping_DIR={build_dir}")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "msg_mapping: 1 interface files" in r.stdout
    generated = build / "msg_mapping_interfaces" / "demo_ln_interfaces" / "msg" / "RobotPose.msg"
    assert "float64 x" in generated.read_text()
    # editing a definition re-runs the generator on the next build
    (defs / "pose").write_text("double x\ndouble y\n")
    r = run(cmake, "--build", str(build))
    assert r.returncode == 0, r.stdout + r.stderr
    assert "float64 y" in generated.read_text()
    # a new definition file is picked up too
    (defs / "twist").write_text("double vx\n")
    r = run(cmake, "--build", str(build))
    assert r.returncode == 0 and "msg_mapping: 2 interface files" in r.stdout, r.stdout + r.stderr
    # a broken definition fails the build with the generator's message
    (defs / "twist").write_text("double\n")
    r = run(cmake, "--build", str(build))
    assert r.returncode != 0 and "twist" in r.stdout + r.stderr
