"""Imports go one way (``docs/architecture.md``): no two of posgmc's modules import each other,
directly or through others. Every import counts, at module level, inside functions and under
``TYPE_CHECKING``, since each is a dependency a reader has to follow; a submodule importing its own
package's ``__init__`` does not (Python runs the package first anyway)."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "posgmc"


def _modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package."""
    out = {}
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        out[name.removesuffix(".__init__")] = path
    return out


def _targets(module: str, node: ast.Import | ast.ImportFrom, modules: dict[str, Path]) -> list[str]:
    """The package's modules one import statement names (``from a import b``: ``a.b`` when that
    is a module, else ``a``)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        parts = module.split(".")
        if not modules[module].name == "__init__.py":
            parts = parts[:-1]
        parts = parts[: len(parts) - node.level + 1]
        stem = ".".join(parts + ([node.module] if node.module else []))
    else:
        stem = node.module or ""
    return [f"{stem}.{a.name}" if f"{stem}.{a.name}" in modules else stem for a in node.names]


def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports."""
    modules = _modules()
    edges: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            for target in _targets(module, node, modules):
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                own_package = modules.get(target, Path()).name == "__init__.py" and (
                    module.startswith(target + ".")
                )
                if target and target != module and not own_package:
                    edges[module].add(target)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(edges)))
    try:
        for v in sorted(edges):
            if v not in index:
                visit(v)
    finally:
        sys.setrecursionlimit(limit)
    return found


def test_no_import_cycle() -> None:
    assert cycles(import_graph()) == []


def test_the_cycle_finder_finds_a_cycle() -> None:
    # the test above can fail: a two-module loop and a three-module loop are both reported
    edges = {"a": {"b"}, "b": {"a"}, "c": {"d"}, "d": {"e"}, "e": {"c"}, "f": {"a"}}
    assert sorted(cycles(edges)) == [["a", "b"], ["c", "d", "e"]]


def test_function_level_and_type_checking_imports_count() -> None:
    graph = import_graph()
    # ``from posgmc import api`` inside the check command's function body
    assert "posgmc.api" in graph["posgmc.cli.check_command"]
    # the checker protocol, imported under TYPE_CHECKING only
    assert "posgmc.checking.protocols" in graph["posgmc.checking.multi"]
    # the command modules register on the group: they import it, it imports none of them
    assert "posgmc.cli.group" in graph["posgmc.cli.check_command"]
    assert not {m for m in graph["posgmc.cli.group"] if m.startswith("posgmc.cli.")}
