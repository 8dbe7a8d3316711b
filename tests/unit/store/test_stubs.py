"""The stage packages' ``__init__.pyi`` stubs (what IDEs and type checkers read) list exactly the lazy exports."""

import ast
import importlib
from pathlib import Path

import pytest

import porepipe

ROOT = Path(porepipe.__file__).parent
STUBS = sorted(ROOT.glob("*/__init__.pyi"))


def test_every_package_with_lazy_exports_has_a_stub():
    lazy = {
        p.parent.name
        for p in ROOT.glob("*/__init__.py")
        if "_EXPORTS" in p.read_text() or "_PUBLIC" in p.read_text()
    }
    assert lazy == {p.parent.name for p in STUBS}


@pytest.mark.parametrize("stub", STUBS, ids=lambda p: p.parent.name)
def test_stub_names_are_the_exports_and_resolve_to_the_same_objects(stub):
    package = importlib.import_module(f"porepipe.{stub.parent.name}")
    tree = ast.parse(stub.read_text())
    imported = {
        a.asname: (node.module, a.name)
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for a in node.names
    }
    stub_all = next(
        ast.literal_eval(n.value)
        for n in tree.body
        if isinstance(n, ast.Assign) and n.targets[0].id == "__all__"
    )
    assert sorted(stub_all) == sorted(package.__all__) == sorted(imported)
    for name, (module, attr) in imported.items():
        assert getattr(importlib.import_module(module), attr) is getattr(package, name), name
