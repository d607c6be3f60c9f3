"""How a command fails (posgmc/cli/running.py): with --json every failure is a JSON answer on
stdout, strategy-file errors with their file and JSON path."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]
POSG = str(ROOT / "models" / "rover.posg")
REACH = '<<rover>> Pmax=? [ F "goal" ]'


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


def test_a_strategy_error_in_json_has_its_file_and_json_path(tmp_path: Path) -> None:
    """Before: ``"file": null`` and no JSON path."""
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "posgmc-fss/1", "player": "rover"}')
    r = run("check", POSG, "--prop", REACH, "--strategy", f"rover={bad}", "--json")
    assert r.exit_code == 2
    (error,) = json.loads(r.stdout)["errors"]
    assert error["file"] == str(bad) and error["json_path"] == "memory_size"
    assert "the field 'memory_size' is missing" in error["message"]
    assert error["line"] is None and error["column"] is None


def test_a_source_error_in_json_has_no_json_path(tmp_path: Path) -> None:
    r = run("check", POSG, "--prop", 'Pmax=? [ F "nowhere" ', "--json")
    assert r.exit_code == 2
    (error,) = json.loads(r.stdout)["errors"]
    assert error["file"] is not None and error["line"] == 1 and error["json_path"] is None


def test_an_internal_error_is_a_json_answer_too(monkeypatch: pytest.MonkeyPatch) -> None:
    """Before, an internal error printed no JSON at all: a machine reading stdout got nothing."""
    from posgmc import api

    def broken(*_: object, **__: object) -> None:
        raise ValueError("something posgmc did not expect")

    monkeypatch.setattr(api, "check", broken)
    r = run("check", POSG, "--prop", REACH, "--json")
    assert r.exit_code == 2
    (error,) = json.loads(r.stdout)["errors"]
    assert error["message"] == "internal error: ValueError: something posgmc did not expect"
    assert "bug in posgmc" in error["hint"]


def test_a_missing_matplotlib_is_reported_before_the_sweep(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Before, only after every point of the sweep was computed."""
    monkeypatch.setitem(__import__("sys").modules, "matplotlib", None)  # import fails
    model = tmp_path / "coin.prism"
    model.write_text("dtmc\nconst double p;\nmodule m\n x : [0..1] init 0;\n"
                     " [] x=0 -> p:(x'=1) + 1-p:(x'=0);\n [] x=1 -> true;\nendmodule\n")
    for args in (("check", str(model), "--prop", "P=? [ F x=1 ]", "--const", "p=0.1:0.1:0.3",
                  "--plot", str(tmp_path / "p.png")),
                 ("pareto", str(model), "--prop", "P=? [ F x=1 ]", "--sweep", "p=0.1:0.1:0.3",
                  "--plot", str(tmp_path / "p.png"))):
        r = run(*args)
        assert r.exit_code == 2 and "plots need matplotlib" in r.output, r.output
        assert "0.1" not in r.stdout  # no point was computed
