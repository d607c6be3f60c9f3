"""`posgmc check --strategy PLAYER=FILE`: the numbers, their words, JSON, exit codes, bad files."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.posg")
FORWARD = str(ROOT / "models" / "rover" / "forward.fss.json")
REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


def test_guaranteed_is_printed_with_its_meaning() -> None:
    r = run("check", ROVER, "--prop", REACH, "--strategy", f"rover={FORWARD}")
    assert r.exit_code == 0, r.output
    assert "guaranteed: 0.92156856" in r.output
    assert "ensures at least this against every adversary" in r.output
    assert "memory: rover=1" in r.output


def test_json_has_the_guaranteed_object() -> None:
    r = run("check", ROVER, "--prop", REACH, "--strategy", FORWARD, "--json")
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)["results"][0]
    assert set(res["guaranteed"]) == {"value", "lower", "upper"}
    # 0.92156856842: policy iteration on the product (tests/strategies/test_verify.py)
    assert res["guaranteed"]["lower"] <= 0.92156856842 <= res["guaranteed"]["upper"]
    assert res["memory"] == {"rover": 1} and res["value"] == res["guaranteed"]["value"]


def test_threshold_is_judged_on_guaranteed() -> None:
    holds = run(
        "check", ROVER, "--prop", '<<rover>> P>=0.9 [ !"crash" U "goal" ]', "--strategy", FORWARD
    )
    fails = run(
        "check", ROVER, "--prop", '<<rover>> P>=0.95 [ !"crash" U "goal" ]', "--strategy", FORWARD
    )
    assert (holds.exit_code, fails.exit_code) == (0, 1)
    assert ": true" in holds.output and ": false" in fails.output


def test_partially_observable_unsupported_objective_says_what_to_do() -> None:
    r = run("check", ROVER, "--prop", '<<rover>> R{"steps"}max=? [ I=5 ]', "--timeout", "5")
    assert r.exit_code == 2
    assert "synthesis supports" in r.output and "--strategy" in r.output


def test_bad_strategy_file_exits_2_with_file_and_path(tmp_path: Path) -> None:
    doc = json.loads(Path(FORWARD).read_text())
    doc["rules"][1]["action"] = {"fwd": 0.5}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    r = run("check", ROVER, "--prop", REACH, "--strategy", f"rover={bad}")
    assert r.exit_code == 2
    assert f"{bad}: rules[1].action: the probabilities of the action sum to 0.5, not 1" in r.output


def test_malformed_json_exits_2_with_line_and_column(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "posgmc-fss/1",\n  "player" "rover"}')
    r = run("check", ROVER, "--prop", REACH, "--strategy", f"rover={bad}")
    assert r.exit_code == 2
    assert f"{bad}:2:12: error: not valid JSON" in r.output


def test_strategy_and_full_observation_conflict() -> None:
    r = run("check", ROVER, "--prop", REACH, "--strategy", FORWARD, "--full-observation")
    assert r.exit_code == 2 and "ask different questions" in r.output


def test_one_strategy_per_player() -> None:
    r = run(
        "check",
        ROVER,
        "--prop",
        REACH,
        "--strategy",
        f"rover={FORWARD}",
        "--strategy",
        f"rover={FORWARD}",
    )
    assert r.exit_code == 2 and "two strategies for player 'rover'" in r.output
