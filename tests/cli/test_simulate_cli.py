"""`posgmc simulate`: text and JSON output, traces, errors."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.posg")
CAUTIOUS = str(ROOT / "models" / "rover" / "cautious.fss.json")
REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


def test_json_estimate_with_wilson_interval() -> None:
    r = run("simulate", ROVER, "--prop", REACH, "--strategy", f"rover={CAUTIOUS}", "--runs", "4000",
            "--seed", "0", "--opponent", "best", "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.output)
    assert set(doc) >= {"estimate", "lower", "upper", "runs"} and doc["runs"] == 4000
    assert doc["lower"] <= doc["estimate"] <= doc["upper"]


def test_text_output_and_trace_table() -> None:
    r = run("simulate", ROVER, "--prop", REACH, "--strategy", f"rover={CAUTIOUS}", "--runs", "100",
            "--trace")
    assert r.exit_code == 0, r.output
    assert "(Wilson 95 %; 100 runs, seed 0)" in r.output
    assert "step  owner" in r.output and "observations" in r.output and "memory" in r.output


def test_same_seed_same_output() -> None:
    args = ("simulate", ROVER, "--prop", REACH, "--strategy", f"rover={CAUTIOUS}", "--runs", "500",
            "--seed", "42", "--trace")
    assert run(*args).output == run(*args).output


def test_bad_strategy_exits_2() -> None:
    r = run("simulate", ROVER, "--prop", REACH, "--strategy", "rover=/nonexistent.json")
    assert r.exit_code == 2 and "no such file: /nonexistent.json" in r.output
