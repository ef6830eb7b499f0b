"""The import graph of service/, for issue 18's layering: every import counts, at module
level or inside a function. Prints the import cycles among its modules (there must be
none), the folders whose modules import each other both ways, the modules over 500
lines and the functions over 60.

    python scripts/check_layers.py [-v] [--packages]

-v also prints the graph; --packages counts as imported the packages Python
initialises on the way to a module (importing a.b.c runs a/__init__.py and
a/b/__init__.py). Exits 1 when there is a cycle among modules."""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "service"
MAX_LINES, MAX_FUNCTION = 500, 60


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


FILES = {module_name(p): p for p in sorted((ROOT / PACKAGE).rglob("*.py"))}
PACKAGES = {m for m, p in FILES.items() if p.name == "__init__.py"}


def target(name: str, packages: bool) -> set[str]:
    """The service module an import names: `name`, or the nearest module holding it
    (`from a.b import f` names a.b.f); with `packages`, the packages above it too."""
    while name and name not in FILES:
        name = name.rpartition(".")[0]
    if name != PACKAGE and not name.startswith(f"{PACKAGE}."):
        return set()
    found = {name}
    while packages and "." in name:
        name = name.rpartition(".")[0]
        found.add(name)
    return found


def imports(name: str, tree: ast.AST, packages: bool) -> set[str]:
    """Every service module `name` imports."""
    found: set[str] = set()
    base = name if name in PACKAGES else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found |= target(alias.name, packages)
        elif isinstance(node, ast.ImportFrom):
            source = node.module or ""
            if node.level:
                anchor = base.split(".")[: len(base.split(".")) - node.level + 1]
                source = ".".join([*anchor, *([node.module] if node.module else [])])
            for alias in node.names:
                found |= target(f"{source}.{alias.name}", packages)
    found.discard(name)
    return found


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of `graph`, those of one node included."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while not component or component[-1] != v:
                component.append(stack.pop())
            components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return components


def folder(module: str) -> str:
    if module == f"{PACKAGE}.__main__":  # the entry point, above everything
        return module
    return module if module in PACKAGES else module.rpartition(".")[0]


def folder_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    folders: dict[str, set[str]] = {folder(m): set() for m in graph}
    for m, targets in graph.items():
        folders[folder(m)] |= {folder(t) for t in targets} - {folder(m)}
    return folders


def cycles(graph: dict[str, set[str]]) -> Iterable[list[str]]:
    return (c for c in strongly_connected(graph) if len(c) > 1)


def main(argv: list[str]) -> int:
    packages = "--packages" in argv
    trees = {m: ast.parse(p.read_text(), str(p)) for m, p in FILES.items()}
    graph = {m: imports(m, tree, packages) for m, tree in trees.items()}
    found = list(cycles(graph))
    print(f"{len(graph)} modules, {sum(map(len, graph.values()))} imports "
          f"(inside functions too{', package initialisation too' if packages else ''})")
    print(f"import cycles among modules: {len(found)}")
    for cycle in found:
        print("  ", " <-> ".join(cycle))
    print("folders whose modules import each other both ways:")
    for cycle in cycles(folder_graph(graph)):
        print("  ", " <-> ".join(cycle))
    print(f"modules over {MAX_LINES} lines:")
    for m, p in FILES.items():
        if (n := len(p.read_text().splitlines())) > MAX_LINES:
            print(f"   {m}: {n}")
    print(f"functions over {MAX_FUNCTION} lines:")
    for m, tree in trees.items():
        for node in ast.walk(tree):
            functions = ast.FunctionDef | ast.AsyncFunctionDef
            if isinstance(node, functions) and node.end_lineno - node.lineno >= MAX_FUNCTION:
                print(f"   {m}.{node.name}: {node.end_lineno - node.lineno + 1}")
    if "-v" in argv:
        for m in sorted(graph):
            print(m, "->", ", ".join(sorted(graph[m])))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
