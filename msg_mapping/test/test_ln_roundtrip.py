"""LN -> ROS 2 end to end: every definition LN 2.9 ships plus our corpus are generated, built
with colcon (one combined build of all packages, plus one package made by the CMake function
msg_mapping_generate_interfaces) and round-tripped byte-identically against rclpy
(roundtrip_worker.py).

The build takes ~2-4 min on 2 cores; its result is reused while the generated files are
unchanged (stamp in the workspace), so re-runs cost only the round trip.
"""

import glob
import hashlib
import json
import os
import shutil
import subprocess
import sys

import pytest

import msg_mapping
from msg_mapping import cli

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "ln_corpus")
SHIPPED_COUNT = 42  # files in LN 2.9's message_definitions + ln_runtime/message_definitions
BUILD_TIMEOUT = 1500


def ln29_dirs():
    candidates = [
        os.environ.get("LN_CORE_LN29_VENV", ""),
        os.path.expanduser("~/.cache/ln_core/venv-ln29"),
        "/tmp/ref/ln29",
    ]
    for venv in candidates:
        share = os.path.join(venv, "lib", "python3.11", "site-packages", "liblinks_and_nodes", "share")
        dirs = [os.path.join(share, "message_definitions"), os.path.join(share, "ln_runtime", "message_definitions")]
        if venv and all(os.path.isdir(d) for d in dirs):
            return dirs
    return None


@pytest.fixture(scope="session")
def md_dirs():
    dirs = ln29_dirs()
    if not dirs:
        pytest.skip("LN 2.9 reference venv not found (LN_CORE_LN29_VENV)")
    return [CORPUS] + dirs


def work_dir(tmp_path_factory):
    root = os.environ.get("MSG_MAPPING_TMP")
    if root:
        os.makedirs(root, exist_ok=True)
        return root
    return str(tmp_path_factory.mktemp("msg_mapping"))


CONSUMER_CMAKE = """cmake_minimum_required(VERSION 3.8)
project(mm_cmake_ln_interfaces)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(msg_mapping REQUIRED)
msg_mapping_generate_interfaces(MD_DIRS "{corpus}" DEFINITIONS mmtest/nested mmtest/sub/deep_service mmtest/alarm_event)
ament_package()
"""
CONSUMER_XML = """<?xml version="1.0"?>
<package format="3">
  <name>mm_cmake_ln_interfaces</name><version>0.0.0</version><description>test</description>
  <maintainer email="t@example.invalid">t</maintainer><license>Apache-2.0</license>
  <buildtool_depend>ament_cmake</buildtool_depend><buildtool_depend>rosidl_default_generators</buildtool_depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
"""


def tree_hash(directory):
    h = hashlib.sha256()
    for path in sorted(glob.glob(os.path.join(directory, "**", "*"), recursive=True)):
        if os.path.isfile(path):
            h.update(os.path.relpath(path, directory).encode())
            with open(path, "rb") as f:
                h.update(f.read())
    return h.hexdigest()


@pytest.fixture(scope="session")
def workspace(tmp_path_factory, md_dirs):
    ws = os.path.join(work_dir(tmp_path_factory), "ln_roundtrip_ws")
    src = os.path.join(ws, "src")
    args = [a for d in md_dirs for a in ("--recursive", d)]
    assert cli.main(args + ["--out", src]) == 0
    consumer = os.path.join(src, "mm_cmake_ln_interfaces")
    os.makedirs(consumer, exist_ok=True)
    for name, text in (("CMakeLists.txt", CONSUMER_CMAKE.format(corpus=CORPUS)), ("package.xml", CONSUMER_XML)):
        with open(os.path.join(consumer, name), "w", encoding="utf-8") as f:
            f.write(text)
    build_dir = os.environ.get("MSG_MAPPING_BUILD_DIR")
    if not build_dir or not os.path.isfile(os.path.join(build_dir, "msg_mappingConfig.cmake")):
        pytest.skip("MSG_MAPPING_BUILD_DIR (msg_mapping's build tree) is not set")
    stamp_file = os.path.join(ws, "install", ".msg_mapping_stamp")
    stamp = tree_hash(src) + tree_hash(os.path.join(os.path.dirname(HERE), "python"))
    if os.path.isfile(stamp_file) and open(stamp_file).read() == stamp:
        return ws
    colcon = shutil.which("colcon") or os.path.join(os.path.dirname(sys.executable), "colcon")
    env = dict(os.environ)
    env.pop("COLCON_PREFIX_PATH", None)
    command = [
        colcon,
        "--log-base",
        os.path.join(ws, "log"),
        "build",
        "--base-paths",
        src,
        "--build-base",
        os.path.join(ws, "build"),
        "--install-base",
        os.path.join(ws, "install"),
        "--event-handlers",
        "console_direct-",
        "desktop_notification-",
        "--cmake-args",
        "-DBUILD_TESTING=OFF",
        f"-Dmsg_mapping_DIR={build_dir}",
    ]
    if shutil.which("ninja"):
        command += ["-G", "Ninja"]
    result = subprocess.run(command, cwd=ws, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT)
    assert result.returncode == 0, f"colcon build failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}"
    with open(stamp_file, "w") as f:
        f.write(stamp)
    return ws


def test_every_shipped_definition_is_generated(md_dirs):
    shipped = [n for d in md_dirs[1:] for n in msg_mapping.definition_names_under(d)]
    assert len(shipped) == SHIPPED_COUNT
    library = msg_mapping.Library(md_dirs)
    gen = msg_mapping.LnToRos()
    for name in shipped:
        gen.add(library, name)
    ln_names = {i["ln_name"] for i in gen.interfaces()}
    assert set(shipped) <= ln_names
    kinds = {i["ln_name"]: i["kind"] for i in gen.interfaces()}
    assert kinds["ln/resource_event"] == "event" and kinds["ln/default_service"] == "service"


def test_colcon_build_and_round_trip(workspace, md_dirs):
    src, install = os.path.join(workspace, "src"), os.path.join(workspace, "install")
    env = dict(os.environ)
    pythonpath = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    libpath = [p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p]
    for prefix in sorted(glob.glob(os.path.join(install, "*"))):
        pythonpath += glob.glob(os.path.join(prefix, "lib", "python3*", "site-packages"))
        libpath.append(os.path.join(prefix, "lib"))
    env["PYTHONPATH"] = os.pathsep.join(pythonpath)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(libpath)
    consumer_mapping = os.path.join(
        install, "mm_cmake_ln_interfaces", "share", "mm_cmake_ln_interfaces", "ln_mapping.json"
    )
    assert os.path.isfile(consumer_mapping), "the CMake function did not install its ln_mapping.json"
    command = [
        sys.executable,
        os.path.join(HERE, "roundtrip_worker.py"),
        "--src",
        src,
        "--trials",
        "12",
        "--mapping",
        consumer_mapping,
    ] + [a for d in md_dirs for a in ("--md-dir", d)]
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-4000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["failure_count"] == 0, "\n".join(report["failures"])
    # 42 shipped + corpus definitions and their parts, plus the CMake-function package
    assert report["definitions"] >= 62 + 6
    assert report["parts"] >= 97 + 8
