#!/usr/bin/env python3
"""Docstrings of porepipe's public API, from the source alone (nothing is imported).

ruff's pydocstyle rules (D1xx) treat everything inside a ``_``-prefixed module as private, and porepipe keeps its
code in ``_api.py``, ``_run.py`` …, exporting it lazily from each package's ``__init__``. So this check follows the
exports instead: every name in a package's export table (``_EXPORTS`` / ``_PUBLIC``) and every public function of
``porepipe._shared`` modules and of the stages' ``_run.py`` must have a docstring (D100-D103 for the public API), and a
public function of ``_shared`` or ``_run.py`` with two or more parameters besides ``self`` needs a numpydoc
``Parameters`` section, unless its docstring is one line (a one-line summary may describe obvious parameters).
The same is reported, as a to-do count that does not fail, for the stages' exported functions.

Exits 1 and lists each violation. Usage: ``python .ci/check_docstrings.py [src/porepipe]``.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def exports(init: Path) -> dict[str, str]:
    """Name -> module (relative ``_api`` or absolute ``porepipe.x``) of a package's lazy export table."""
    tree = ast.parse(init.read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            getattr(t, "id", "") in ("_EXPORTS", "_PUBLIC") for t in node.targets
        ):
            table: dict[str, str] = {}
            value = node.value
            for key, val in zip(value.keys, value.values, strict=True):
                if key is None:  # **dict.fromkeys([...], "_mod")
                    names = [e.value for e in val.args[0].elts]
                    table.update(dict.fromkeys(names, val.args[1].value))
                else:
                    table[key.value] = val.value
            return table
    return {}


def definitions(path: Path) -> dict[str, ast.AST]:
    tree = ast.parse(path.read_text())
    return {n.name: n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}


def problems_of(node: ast.AST, where: str, sections: bool = True) -> list[str]:
    doc = ast.get_docstring(node)
    if not doc:
        return [
            f"{where}: public {type(node).__name__.removesuffix('Def').lower()} {node.name} has no docstring"
        ]
    if isinstance(node, ast.FunctionDef):
        args = [a.arg for a in node.args.args + node.args.kwonlyargs if a.arg not in ("self", "cls")]
        if sections and len(args) >= 2 and "\n" in doc.strip() and "Parameters\n" not in doc:
            return [
                f"{where}: {node.name}({', '.join(args)}) has a multi-line docstring without a numpydoc "
                "Parameters section"
            ]
    return []


def main(root: Path) -> int:
    problems, todo = [], []
    for init in sorted(root.glob("*/__init__.py")):
        package = init.parent
        for name, module in exports(init).items():
            rel = (
                module.removeprefix("porepipe.").replace(".", "/") if module.startswith("porepipe.") else None
            )
            path = root / f"{rel}.py" if rel else package / f"{module}.py"
            node = definitions(path).get(name)
            if node is not None:  # constants and re-exported enums' members have nothing to check
                problems += problems_of(node, f"{path}:{node.lineno}", sections=False)
                todo += problems_of(node, f"{path}:{node.lineno}")[
                    len(problems_of(node, "", sections=False)) :
                ]
    for path in sorted([*root.glob("_shared/*.py"), *root.glob("*/_run.py")]):
        for name, node in definitions(path).items():
            if not name.startswith("_"):
                problems += problems_of(node, f"{path}:{node.lineno}")
    for p in problems:
        print(p)
    print(
        f"check_docstrings: {len(problems)} problem(s); to do (not failing): {len(todo)} exported stage "
        "function(s) without a Parameters section"
        + ("".join(f"\n  {t}" for t in todo) if "-v" in sys.argv else "")
    )
    return 1 if problems else 0


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "-v"]
    sys.exit(main(Path(args[0] if args else Path(__file__).resolve().parents[1] / "src/porepipe")))
