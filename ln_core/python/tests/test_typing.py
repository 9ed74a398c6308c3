"""The package's types: py.typed ships with it, and the stub of the native module
(_ln.pyi, made with `python -m nanobind.stubgen -m links_and_nodes._ln`) names exactly
what the module defines, class by class, so the stub cannot drift from module.cpp. Every public
function of the API is annotated, and mypy finds the annotations consistent."""

import ast
import os
import subprocess
import sys

import links_and_nodes
from links_and_nodes import _ln

PACKAGE = os.path.dirname(links_and_nodes.__file__)


def public(names):
    return {n for n in names if not n.startswith("_")}


def stub_names():
    """{None: module-level names, class name: its member names} of _ln.pyi."""
    with open(os.path.join(PACKAGE, "_ln.pyi")) as f:
        tree = ast.parse(f.read())
    names = {None: set()}

    def target(node):
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            return node.name
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            return node.target.id
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            return node.targets[0].id
        return None

    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            names[None].update(a.asname or a.name for a in node.names if a.asname)  # re-exports: "X as X"
        name = target(node)
        if name:
            names[None].add(name)
        if isinstance(node, ast.ClassDef):
            names[name] = {target(member) for member in node.body} - {None}
    return names


def test_the_package_is_marked_typed():
    assert os.path.isfile(os.path.join(PACKAGE, "py.typed"))


def test_the_stub_names_what_the_native_module_defines():
    stub = stub_names()
    assert public(stub[None]) == public(dir(_ln)), "regenerate _ln.pyi (see this file's docstring)"
    for name in public(dir(_ln)):
        kind = getattr(_ln, name)
        if isinstance(kind, type) and name in stub:
            assert public(stub[name]) == public(vars(kind)), "%s: regenerate _ln.pyi" % name


def public_functions_without_hints():
    """'module.py:line name' of every public function or method of the API (not the command-line
    tools in cli/) that leaves a parameter or its return type unannotated."""
    missing = []
    for name in sorted(os.listdir(PACKAGE)):
        if not name.endswith(".py"):
            continue
        with open(os.path.join(PACKAGE, name)) as f:
            tree = ast.parse(f.read())

        def visit(node, public_scope):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.ClassDef):
                    visit(child, public_scope and not child.name.startswith("_"))
                elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    dunder = child.name.startswith("__") and child.name.endswith("__")
                    if not public_scope or (child.name.startswith("_") and not dunder):
                        continue
                    args = child.args.posonlyargs + child.args.args + child.args.kwonlyargs
                    args += [a for a in (child.args.vararg, child.args.kwarg) if a is not None]
                    unannotated = [a.arg for a in args if a.annotation is None and a.arg not in ("self", "cls")]
                    if unannotated or (child.returns is None and child.name != "__init__"):
                        missing.append("%s:%d %s" % (name, child.lineno, child.name))

        visit(tree, True)
    return missing


def test_the_public_api_is_annotated():
    assert public_functions_without_hints() == []


def test_mypy_accepts_the_package(tmp_path):
    """The annotations are consistent with the code and with the stub (mypy is installed by setup.sh)."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--check-untyped-defs",
            "--cache-dir",
            str(tmp_path / "cache"),
            "--exclude",
            "/cli/",
            PACKAGE,
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stdout + result.stderr
