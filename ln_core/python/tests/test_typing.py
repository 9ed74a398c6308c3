"""The package's types: py.typed ships with it, and the stub of the native module
(_ln.pyi, made with `python -m nanobind.stubgen -m links_and_nodes._ln`) names exactly
what the module defines, class by class, so the stub cannot drift from module.cpp."""

import ast
import os

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
