"""Sentences of README and docs/ that state what the code does, held to the code."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from posgmc.cli import main
from posgmc.semantics.multi import MAX_PARETO_OBJECTIVES

ROOT = Path(__file__).resolve().parents[1]
_WORDS = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}


def test_the_language_page_gives_the_pareto_limit_of_the_code() -> None:
    text = " ".join((ROOT / "docs" / "language.md").read_text().split())
    limit = _WORDS[MAX_PARETO_OBJECTIVES]
    assert f"more than {limit} `=?` objectives" in text
    assert f"up to {limit}" in text
    assert "more than two `=?` objectives" not in text


def test_simulate_prints_a_path_only_with_trace(tmp_path: Path) -> None:
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert "with a 95 % interval; `--trace` also prints one sampled path" in readme
    assert "and prints a sampled path" not in readme
    rover = str(ROOT / "models" / "rover.posg")
    forward = str(ROOT / "models" / "rover" / "forward.fss.json")
    args = ["simulate", rover, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--strategy",
            f"rover={forward}", "--runs", "10"]
    plain = CliRunner().invoke(main, args)
    traced = CliRunner().invoke(main, [*args, "--trace"])
    assert plain.exit_code == traced.exit_code == 0, plain.output + traced.output
    assert "step" not in plain.output and "step" in traced.output


def test_no_page_promises_what_exists() -> None:
    for page in (ROOT / "docs").glob("*.md"):
        assert "once it exists" not in page.read_text(), page.name


def test_gitignore_keeps_environments_and_the_documented_outputs_out() -> None:
    # the tutorial exports to strategy/, docs/synthesis.md to out/
    ignored = (ROOT / ".gitignore").read_text().split()
    assert {".venv/", "/strategy/", "/out/"} <= set(ignored)
    assert "--export-strategy strategy" in (ROOT / "docs" / "tutorial.md").read_text()
    assert "--export-strategy out/" in (ROOT / "docs" / "synthesis.md").read_text()
