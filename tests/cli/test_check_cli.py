"""``posgmc check``: output, ``--json``, sweeps, exit codes and error positions (docs/cli.md).

Expected numbers: models/rover.smg's values are derived in tests/test_models.py (reach 0.98765618,
within the proven bounds printed); the coin model below is hand-computed in each test.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import EXIT_ERROR, EXIT_OK, EXIT_PROPERTY_FALSE, main

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.smg")
ROVER_POSG = str(ROOT / "models" / "rover.posg")

# s=0 tosses a coin with bias p: heads (s=1, "a"), tails (s=2); both absorbing. The reward -1 in
# s=0 makes R[C] undefined without a target (mixed-sign total rewards are rejected).
COIN = """mdp
const double p;
module coin
  s : [0..2] init 0;
  [] s=0 -> p:(s'=1) + (1-p):(s'=2);
  [] s>0 -> true;
endmodule
rewards "r"
  s=0 : -1;
endrewards
label "a" = s=1;
"""


@pytest.fixture
def run():  # type: ignore[no-untyped-def]
    runner = CliRunner()

    def invoke(*args: str):  # type: ignore[no-untyped-def]
        return runner.invoke(main, list(args), catch_exceptions=False)

    return invoke


@pytest.fixture
def coin(tmp_path: Path) -> str:
    path = tmp_path / "coin.nm"
    path.write_text(COIN)
    return str(path)


def test_check_prints_size_value_bounds(run) -> None:  # type: ignore[no-untyped-def]
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [ F "goal" ]')
    assert r.exit_code == EXIT_OK, r.output
    assert "smg, 60 states, 100 choices, 125 transitions" in r.output
    assert "0.98765" in r.output and "[0.98765" in r.output


def test_check_json_is_documented_shape(run) -> None:  # type: ignore[no-untyped-def]
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--json")
    assert r.exit_code == EXIT_OK, r.output
    doc = json.loads(r.output)
    assert doc["model"] == {"type": "smg", "states": 60, "choices": 100, "transitions": 125}
    (res,) = doc["results"]
    assert res["property"] == '<<rover>> Pmax=? [ F "goal" ]'
    assert res["lower"] <= 0.9876561794 <= res["upper"]  # exact value: tests/test_models.py
    assert res["lower"] <= res["value"] <= res["upper"]
    assert res["seconds"] >= 0 and res["sound"] is True


def test_threshold_false_exits_one(run) -> None:  # type: ignore[no-untyped-def]
    r = run("check", ROVER, "--prop", '<<rover>> P>=0.99 [ F "goal" ]', "--json")
    assert r.exit_code == EXIT_PROPERTY_FALSE, r.output
    assert json.loads(r.output)["results"][0]["value"] is False
    r = run("check", ROVER, "--prop", '<<rover>> P>=0.95 [ F "goal" ]')
    assert r.exit_code == EXIT_OK, r.output


def test_const_sweep_prints_a_table(run, coin: str) -> None:  # type: ignore[no-untyped-def]
    r = run("check", coin, "--prop", 'Pmax=? [ F "a" ]', "--const", "p=0.25:0.25:0.75")
    assert r.exit_code == EXIT_OK, r.output
    for p in ("0.25", "0.5", "0.75"):
        assert p in r.output


def test_next_with_a_step_bound_is_an_error_with_position(run, coin: str) -> None:  # type: ignore[no-untyped-def]
    r = run("check", coin, "--const", "p=0.5", "--prop", 'Pmax=? [ X<=3 "a" ]')
    assert r.exit_code == EXIT_ERROR
    assert '<--prop 1>:1:11: error: the next operator X cannot have a step bound' in r.output
    assert 'Pmax=? [ X<=3 "a" ]' in r.output and "^~~" in r.output


def test_engine_refusal_points_at_the_property(run, coin: str, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    props = tmp_path / "coin.props"
    props.write_text('Pmax=? [ F "a" ];\n\nR{"r"}min=? [ C ];\n')
    r = run("check", coin, str(props), "--const", "p=0.5")
    assert r.exit_code == EXIT_ERROR
    # the first property is still answered (PRISM goes on after an error): p = 0.5
    assert "0.5" in r.output
    assert f"{props}:3:1: error: negative rewards are not supported" in r.output
    assert 'R{"r"}min=? [ C ]' in r.output


def test_negative_reach_rewards_with_a_sure_target(run, coin: str) -> None:  # type: ignore[no-untyped-def]
    # every path leaves s=0 after one step collecting -1, and "a | s=2" is reached surely: -1
    r = run("check", coin, "--const", "p=0.5", "--prop", 'R{"r"}min=? [ F s>0 ]', "--json")
    assert r.exit_code == EXIT_OK, r.output
    res = json.loads(r.output)["results"][0]
    assert res["lower"] <= -1.0 <= res["upper"] and abs(res["value"] + 1.0) < 1e-6


def test_partially_observable_needs_full_observation(run) -> None:  # type: ignore[no-untyped-def]
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ F "goal" ]')
    assert r.exit_code == EXIT_ERROR
    assert "partially observable synthesis is not available" in r.output
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--full-observation")
    assert r.exit_code == EXIT_OK, r.output
    assert "full-observation value" in r.output


def test_export_strategy_writes_one_entry_per_deciding_state(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from posgmc import api
    from posgmc.checking.dispatch import CheckOptions

    out = tmp_path / "strategy.json"
    prop = '<<rover>> Pmax=? [ F "goal" ]'
    r = run("check", ROVER, "--prop", prop, "--export-strategy", str(out))
    assert r.exit_code == EXIT_OK, r.output
    doc = json.loads(out.read_text())
    assert doc["property"] == prop and doc["memoryless"] is True
    report = api.check(api.load(ROVER), properties=[prop], options=CheckOptions(keep_strategy=True))
    m, strategy = report.model, report.results[0].strategy
    deciding = [s for s in range(m.num_states) if strategy[s] >= 0]
    assert [e["state"] for e in doc["states"]] == deciding
    for e in doc["states"]:
        s, c = e["state"], int(m.row_groups[e["state"]]) + e["choice"]
        assert c == strategy[s] and m.row_groups[s] <= c < m.row_groups[s + 1]
        assert e["action"] == m.action_names[int(m.choice_actions[c])]
        assert e["player"] == m.player_names[int(m.state_players[s])]
        assert list(e["valuation"].values()) == [int(v) for v in m.state_values[s]]


def test_export_strategy_needs_one_unbounded_query(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "strategy.json"
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [ F<=3 "goal" ]', "--export-strategy", str(out))
    assert r.exit_code == EXIT_ERROR
    assert "--export-strategy needs exactly one unbounded P or R query" in r.output
    assert not out.exists()


# -- thresholds decided on proven bounds only (the semantics issue) ----------------------------------

# From x=0: 1/4 to x=1, 1/4 to x=2, 1/2 to x=3, which goes back to x=0 or stays (1/2 each):
# P(F x=1) = (1/4) / (1 - 1/2) = 1/2 exactly; interval iteration never reaches it from either side.
HALF = """dtmc
module m
  x : [0..3] init 0;
  [] x=0 -> 0.25:(x'=1) + 0.25:(x'=2) + 0.5:(x'=3);
  [] x=3 -> 0.5:(x'=0) + 0.5:(x'=3);
  [] x=1|x=2 -> true;
endmodule
"""


@pytest.fixture
def half(tmp_path: Path) -> str:
    path = tmp_path / "half.pm"
    path.write_text(HALF)
    return str(path)


def test_threshold_at_the_exact_value_is_decided_by_refinement(run, half: str) -> None:  # type: ignore[no-untyped-def]
    r = run("check", half, "--prop", "P=? [ F x=1 ] > 0.5", "--prop", "P>0.5 [ F x=1 ]", "--json")
    assert r.exit_code == EXIT_PROPERTY_FALSE, r.output
    doc = json.loads(r.output)
    assert doc["model"]["states"] == 4
    assert [(x["value"], x["sound"]) for x in doc["results"]] == [(False, True), (False, True)]


def test_undecided_threshold_is_unknown_and_exits_three(run, half: str, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from posgmc.checking import dispatch
    from posgmc.cli import EXIT_UNDECIDED

    monkeypatch.setattr(dispatch, "EXACT_REFINEMENT_STATES", 0)  # as for a model too large
    r = run("check", half, "--prop", "P>0.5 [ F x=1 ]")
    assert r.exit_code == EXIT_UNDECIDED, r.output
    assert "P>0.5 [ F x=1 ]: unknown" in r.output and "UNDECIDED" in r.output
    r = run("check", half, "--prop", "P>0.5 [ F x=1 ]", "--json")
    (res,) = json.loads(r.output)["results"]
    assert res["value"] == "unknown" and res["sound"] is False


def test_unsound_method_threshold_exits_three(run, half: str) -> None:  # type: ignore[no-untyped-def]
    from posgmc.cli import EXIT_UNDECIDED

    r = run("check", half, "--prop", "P>0.4 [ F x=1 ]", "--method", "value")
    assert r.exit_code == EXIT_UNDECIDED and "NOT PROVEN" in r.output


def test_rover_comparison_below_the_exact_value_is_false(run) -> None:  # type: ignore[no-untyped-def]
    # exact value 0.98765618 (tests/test_models.py): 0.98765634 lies inside the first interval
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [F "goal"] >= 0.98765634', "--json")
    assert r.exit_code == EXIT_PROPERTY_FALSE, r.output
    (res,) = json.loads(r.output)["results"]
    assert res["value"] is False and res["sound"] is True


def test_query_divided_by_zero_prints_infinity(run, half: str) -> None:  # type: ignore[no-untyped-def]
    r = run("check", half, "--prop", "P=? [ F x=1 ] / 0", "--json")
    assert r.exit_code == EXIT_OK, r.output
    (res,) = json.loads(r.output)["results"]
    assert res["value"] == res["lower"] == res["upper"] == "inf"


def test_partial_operator_in_a_property_is_a_positioned_error(run, half: str) -> None:  # type: ignore[no-untyped-def]
    r = run("check", half, "--prop", "mod(3, x)")
    assert r.exit_code == EXIT_ERROR
    assert "<--prop 1>:1:1: error: mod() by a non-positive divisor (0) in state 0 (x=0)" in r.output
    assert "RuntimeWarning" not in r.output and "states.py" not in r.output


def test_guard_with_a_huge_double_is_compared_not_crashed(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    # pow(2.0, 2000) is Infinity for PRISM's doubles: the guard holds, the chain walks to x=2
    path = tmp_path / "big.pm"
    path.write_text(
        "dtmc\nmodule m\n  x : [0..2] init 0;\n"
        "  [] x < pow(2.0, 2000) & x < 2 -> (x'=x+1);\n  [] x = 2 -> true;\nendmodule\n"
    )
    r = run("check", str(path), "--prop", "P=? [ F x=2 ]", "--json")
    assert r.exit_code == EXIT_OK, r.output
    doc = json.loads(r.output)
    assert doc["model"]["states"] == 3 and doc["results"][0]["value"] == 1.0


# PAYNT-style POSMG export: players numbered from 0 in the file and in sketch.props
DRN_GAME = """\
@type: SMG
@parameters

@reward_models

@nr_states
2
@nr_choices
3
@model
state 0 <1> init
\taction a
\t\t1 : 1
\taction b
\t\t0 : 1
state 1 <0> goal
\taction __NOLABEL__
\t\t1 : 1
"""


def test_zero_player_on_drn_names_the_option_and_both_numberings(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "game.drn"
    path.write_text(DRN_GAME)
    r = run("check", str(path), "--prop", '<<0>> Pmax=? [ F "goal" ]')
    assert r.exit_code == EXIT_ERROR
    assert "player number 0 does not exist: the model has 2 players" in r.output
    assert "--zero-based-players" in r.output
    assert "1: 0, 2: 1" in r.output and "(0: 0, 1: 1)" in r.output
    r = run("check", str(path), "--prop", '<<1>> Pmax=? [ F "goal" ]', "--zero-based-players", "--json")
    assert r.exit_code == EXIT_OK, r.output
    assert json.loads(r.output)["model"]["states"] == 2
