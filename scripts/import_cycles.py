"""Import cycles among the modules of a package (default: models), counting imports
wherever they are (inside functions too) but not those under ``if TYPE_CHECKING:``,
which never run. Prints each module's imports and the cycles; exits 1 if there is one.

    python scripts/import_cycles.py [PACKAGE_DIR]
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def imports(package: Path) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """Module -> the package's modules it imports when run, and those it imports
    for type checkers only."""
    name = package.name
    modules = {p.stem for p in package.glob("*.py") if p.stem != "__init__"}
    run: dict[str, set[str]] = {m: set() for m in modules}
    typing_only: dict[str, set[str]] = {m: set() for m in modules}

    def targets(node: ast.Import | ast.ImportFrom) -> set[str]:
        if isinstance(node, ast.Import):
            paths = [alias.name.split(".") for alias in node.names]
            return {p[1] for p in paths if p[0] == name and len(p) > 1} & modules
        path = (node.module or "").split(".")
        if node.level == 1:  # from .x import y, from . import x
            return ({path[0]} if node.module else {a.name for a in node.names}) & modules
        if node.level == 0 and path[0] == name:
            if len(path) > 1:
                return {path[1]} & modules
            return {a.name for a in node.names} & modules  # from models import parts
        return set()

    for module in modules:
        tree = ast.parse((package / f"{module}.py").read_text())
        guarded = {id(inner) for node in ast.walk(tree)
                   if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
                   for child in node.body for inner in ast.walk(child)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                (typing_only if id(node) in guarded else run)[module] |= targets(node)
    return run, typing_only


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every elementary cycle, each once (from its smallest module)."""
    found: list[list[str]] = []

    def walk(path: list[str]) -> None:
        for nxt in sorted(graph[path[-1]]):
            if nxt == path[0]:
                found.append([*path, nxt])
            elif nxt not in path and nxt > path[0]:
                walk([*path, nxt])

    for start in sorted(graph):
        walk([start])
    return found


def main() -> int:
    package = Path(sys.argv[1] if len(sys.argv) > 1 else "models")
    run, typing_only = imports(package)
    for module in sorted(run):
        guarded = sorted(typing_only[module] - run[module])
        note = f"   (TYPE_CHECKING only: {', '.join(guarded)})" if guarded else ""
        print(f"{module:15} -> {', '.join(sorted(run[module])) or '-'}{note}")
    found = cycles(run)
    print("cycles:", "none" if not found else len(found))
    for cycle in found:
        print("  " + " -> ".join(cycle))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
