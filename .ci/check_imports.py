#!/usr/bin/env python3
"""Structure checks of src/porepipe, from the source alone (nothing is imported).


1. no stage package imports a private module (``porepipe.<other>._x``) or a private name (``_x``) of another stage
   package; shared code lives in ``porepipe._shared`` (the assemblers ``scene.py``, ``cli.py`` and ``_registry.py``
   may read the stages' ``_settings``/``_cli``, which is their job);
2. no import circle between modules, counting every import (module level and inside functions alike).

Prints each violation and exits 1 if there is one. Usage: ``python .ci/check_imports.py [src/porepipe]``.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ASSEMBLERS = {"porepipe.scene", "porepipe.cli", "porepipe._registry"}


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(tree: ast.AST, name: str, is_package: bool) -> list[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) of every import statement in the tree."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_package else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - node.level + 1]
                base = ".".join(pkg + ([base] if base else []))
            out += [(base, a.name, node.lineno) for a in node.names]
    return out


def stage_of(module: str) -> str | None:
    """The stage package a module belongs to (``porepipe.lpt._api`` -> ``lpt``); None for shared/top-level code."""
    parts = module.split(".")
    if len(parts) < 2 or parts[0] != "porepipe" or parts[1].startswith("_") or parts[1] in ("scene", "cli"):
        return None
    return parts[1]


def main(root: Path) -> int:
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    graph: dict[str, set[str]] = {m: set() for m in files}
    problems = []
    for mod, path in files.items():
        tree = ast.parse(path.read_text(), str(path))
        for target, name, line in imports_of(tree, mod, path.name == "__init__.py"):
            full = f"{target}.{name}" if name and f"{target}.{name}" in files else target
            if full in files and full != mod:
                graph[mod].add(full)
            if mod in ASSEMBLERS:
                continue
            here, there = stage_of(mod), stage_of(full)
            if there is None or there == here:
                continue
            private = [p for p in full.split(".")[2:] if p.startswith("_") and not p.startswith("__")]
            if private or (name and name.startswith("_") and not name.startswith("__")):
                problems.append(
                    f"{path}:{line}: {mod} imports the private {full}{'.' + name if name and full == target else ''}"
                    f" of stage {there!r}"
                )
    problems += [f"import circle: {' -> '.join(c)}" for c in cycles(graph)]
    for p in problems:
        print(p)
    print(
        f"check_imports: {len(files)} modules, {sum(map(len, graph.values()))} imports, "
        f"{len(problems)} problem(s)"
    )
    return 1 if problems else 0


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One representative circle per strongly connected component with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp) + [sorted(comp)[0]])

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


if __name__ == "__main__":
    sys.exit(
        main(Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "src/porepipe"))
    )
