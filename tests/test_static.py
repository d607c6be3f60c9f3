"""The static checks run with the tests, so that CI (``.ci/run``, the README's test command)
enforces them: ``mypy --strict`` over the package and ``ruff check`` over the package, the tests
and the benchmarks, each with its configuration in ``pyproject.toml`` (the ``test`` extra
installs both). Also the layering that the architecture promises (``docs/architecture.md``): the
compiled game needs nothing but numpy and scipy, and the engines read no syntax tree (except the
LTL translation, whose input is a formula)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "posgmc"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, timeout=900
    )


def test_mypy_strict_passes() -> None:
    result = _run("mypy", "--strict", "posgmc")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_passes() -> None:
    result = _run("ruff", "check", "--no-cache", "posgmc", "tests", "benchmarks")
    assert result.returncode == 0, result.stdout + result.stderr


def _imports(path: Path) -> set[str]:
    """The modules a file imports (absolute names; relative imports are not used in posgmc)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module is not None:
            names.add(node.module)
    return names


def _package_files(folder: str) -> list[Path]:
    return sorted((PACKAGE / folder).rglob("*.py"))


@pytest.mark.parametrize("path", _package_files("model"), ids=lambda p: p.name)
def test_the_compiled_game_needs_only_numpy_and_scipy(path: Path) -> None:
    own = {n for n in _imports(path) if n.split(".")[0] == "posgmc"}
    assert own <= {"posgmc.errors"} | {n for n in own if n.startswith("posgmc.model")}, own


@pytest.mark.parametrize(
    "path",
    [p for p in _package_files("engines") if "ltl" not in p.parts],
    ids=lambda p: str(p.relative_to(PACKAGE)),
)
def test_engines_read_no_syntax_tree(path: Path) -> None:
    upward = {
        n
        for n in _imports(path)
        if n.split(".")[:2]
        in (["posgmc", "syntax"], ["posgmc", "semantics"], ["posgmc", "checking"])
    }
    assert not upward, upward
