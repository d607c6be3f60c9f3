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
    # without --strategy and --full-observation, a posg property is answered by synthesis
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--memory", "1",
            "--timeout", "5", "-v")
    assert r.exit_code == EXIT_OK, r.output
    assert "guaranteed:" in r.output and "(full_observation)" in r.output
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--full-observation")
    assert r.exit_code == EXIT_OK, r.output
    assert "full-observation value" in r.output


def test_export_strategy_writes_the_coalition_s_memoryless_fss(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """A model checker's strategy is written as posgmc-fss/1 with one memory node, the format of
    every other strategy file: the coalition's (here the rover's) choice in each of its states."""
    from posgmc import api
    from posgmc.checking.property_checker import CheckOptions

    out = tmp_path / "strategy.json"
    prop = '<<rover>> Pmax=? [ F "goal" ]'
    r = run("check", ROVER, "--prop", prop, "--export-strategy", str(out))
    assert r.exit_code == EXIT_OK, r.output
    assert f"wrote {out}" in r.output
    doc = json.loads(out.read_text())
    assert (doc["format"], doc["player"], doc["memory_size"]) == ("posgmc-fss/1", "rover", 1)
    assert doc["observables"] == ["turn", "x", "budget", "spoofed"]
    report = api.check(api.load(ROVER), properties=[prop], options=CheckOptions(keep_strategy=True))
    m, strategy = report.model, report.results[0].strategy
    rover = [s for s in range(m.num_states) if m.state_players[s] == 0]
    assert len(doc["rules"]) == len(rover)  # one rule per state the rover sees (all of it)
    rules = {tuple(rule["observation"].values()): rule["action"] for rule in doc["rules"]}
    for s in rover:
        action = rules[tuple(int(v) for v in m.state_values[s])]
        c = int(strategy[s]) if strategy[s] >= 0 else int(m.row_groups[s])  # no decision: first
        assert action == {m.action_names[int(m.choice_actions[c])]: 1.0}


def test_export_strategy_of_a_strategy_that_chooses_nowhere(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """``F true``: every state is a target, so no state decides; the file still holds a rule for
    each of the rover's states (its first choice) and checks to 1."""
    out = tmp_path / "strategy.json"
    prop = "<<rover>> Pmax=? [ F true ]"
    r = run("check", ROVER, "--prop", prop, "--export-strategy", str(out))
    assert r.exit_code == EXIT_OK, r.output
    assert json.loads(out.read_text())["format"] == "posgmc-fss/1"
    again = run("check", ROVER, "--prop", prop, "--strategy", str(out), "--json")
    assert again.exit_code == EXIT_OK, again.output
    assert json.loads(again.output)["results"][0]["guaranteed"]["value"] == 1.0


def test_export_strategy_needs_an_unbounded_query(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "strategy.json"
    r = run(
        "check", ROVER, "--prop", '<<rover>> Pmax=? [ F<=3 "goal" ]', "--export-strategy", str(out)
    )
    assert r.exit_code == EXIT_ERROR
    assert "--export-strategy: no property checked here has a strategy to export" in r.output
    assert not out.exists()


def test_json_gives_constants_as_numbers_and_booleans(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "flag.nm"
    path.write_text(COIN.replace("const double p;", "const double p;\nconst bool flag;\n"
                                 "const int n;\nconst double q;")
                    .replace("label \"a\" = s=1;", "label \"a\" = s=1 & (flag | n>0 | q>0);"))
    r = run("check", str(path), "--const", "p=0.5,flag=true,n=3,q=1/4", "--prop",
            'Pmax=? [ F "a" ]', "--json")
    assert r.exit_code == EXIT_OK, r.output
    assert json.loads(r.output)["constants"] == {"p": 0.5, "flag": True, "n": 3, "q": "1/4"}
    r = run("check", str(path), "--const", "p=0.5,flag=false,n=0:1,q=0", "--prop",
            'Pmax=? [ F "a" ]', "--json")
    assert [run_["constants"] for run_ in json.loads(r.output)["runs"]] == [
        {"p": 0.5, "flag": False, "n": 0, "q": 0}, {"p": 0.5, "flag": False, "n": 1, "q": 0}]


def test_export_strategy_refuses_an_extension_other_than_json(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "s.tra"
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--export-strategy",
            str(out))
    assert r.exit_code == EXIT_ERROR
    assert f"--export-strategy {out}: strategies are written as JSON, not .tra" in r.output
    assert "Model " not in r.output and not out.exists()  # refused before any work


def test_values_print_as_the_shortest_decimal_inside_their_bounds(run) -> None:  # type: ignore[no-untyped-def]
    # red_and_black's bold play from start=1 wins with exactly 0.064 (models/red_and_black
    # README.md); interval iteration proves [0.06399999999, 0.06400100001] around 0.0640005
    model = str(ROOT / "models" / "red_and_black" / "red_and_black.smg")
    prop = '<<gambler,casino>> Pmax=? [ F "rich" ]'
    r = run("check", model, "--prop", prop, "--const", "start=1")
    assert r.exit_code == EXIT_OK, r.output
    assert f"{prop}: 0.064  [0.06399999999, 0.06400100001]" in r.output
    r = run("check", model, "--prop", prop, "--const", "start=1", "--json")
    res = json.loads(r.output)["results"][0]
    assert res["value"] != 0.064 and res["lower"] <= 0.064 <= res["upper"]  # full precision
    r = run("check", model, "--prop", prop, "--const", "start=1:2")
    assert r.output.splitlines()[-2:] == ["1\t0.064", "2\t0.16"]


@pytest.mark.parametrize("timeout", ["0.01", "0.3", "2"])
def test_exit_0_only_when_every_printed_number_is_proven(run, timeout: str) -> None:  # type: ignore[no-untyped-def]
    """Synthesis cut short at random points of its budget (rover.posg): whatever the machine's
    speed, exit 0 comes with every printed number proven, an unproven one with exit 1 and
    ``converged`` false; no number is a placeholder and the printed points keep the order
    guaranteed <= vs_fss_adversary <= upper_bound (before: upper_bound 0.5 [0, 1] below
    guaranteed 0.98763, ``sound: true``, exit 0)."""
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ !"crash" U "goal" ]',
            "--memory", "1", "--timeout", timeout, "--json")
    assert r.exit_code in (0, 1), r.output
    (res,) = json.loads(r.stdout)["results"]
    numbers = [res[k] for k in ("guaranteed", "vs_fss_adversary", "upper_bound") if k in res]
    assert numbers[0] is res["guaranteed"]
    values = [n["value"] for n in numbers]
    assert values == sorted(values)
    assert all(n["lower"] <= n["value"] <= n["upper"] for n in numbers)
    if "upper_bound" in res:
        assert res["upper_bound"]["upper"] - res["upper_bound"]["lower"] < 1e-3  # computed
    if r.exit_code == 0:
        assert res["converged"] is True and res["sound"] is True
    if res["converged"] is False or res["sound"] is False:
        assert r.exit_code == 1


def test_a_synthesis_refuses_a_json_file_name_for_its_directory(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "s.json"
    r = run("check", ROVER_POSG, "--prop", '<<rover>> Pmax=? [ F "goal" ]', "--memory", "1",
            "--export-strategy", str(out))
    assert r.exit_code == EXIT_ERROR
    assert f"--export-strategy {out}: a synthesis writes a directory" in r.output
    assert "Model " not in r.output and not out.exists()  # refused before any work


# -- --select and --strict ----------------------------------------------------------------------

# by hand: s=0 moves to s=1 with 1/3, else to s=2
THIRD = """dtmc
module m
  s : [0..2] init 0;
  [] s=0 -> 1/3:(s'=1) + 2/3:(s'=2);
  [] s>0 -> true;
endmodule
"""
SELECT_PROPS = '"first": P=? [ F s=1 ];\n"mission": P=? [ F s=2 ];\nP>1/3 [ F s=1 ];\n'


def _third(tmp_path: Path) -> tuple[str, str]:
    m, p = tmp_path / "m.prism", tmp_path / "m.props"
    m.write_text(THIRD)
    p.write_text(SELECT_PROPS)
    return str(m), str(p)


@pytest.mark.parametrize(
    ("select", "shown"),
    [
        (["mission"], ['"mission":']),
        (['"mission"'], ['"mission":']),
        (["3,first"], ['"first":', "P>1/3"]),  # in file order, whatever the selection's order
        (["2", "1"], ['"first":', '"mission":']),
    ],
)
def test_select_picks_properties_by_name_or_position(
    tmp_path: Path, select: list[str], shown: list[str]
) -> None:
    m, p = _third(tmp_path)
    args = ["check", m, p]
    for s in select:
        args += ["--select", s]
    r = CliRunner().invoke(main, args)
    lines = [ln for ln in r.output.splitlines() if ": " in ln and not ln.startswith("Model")]
    assert [ln.split(" ")[0] for ln in lines] == shown, r.output
    # P>1/3 on exactly 1/3 is decided false (exit 1), the =? queries exit 0
    assert r.exit_code == (EXIT_PROPERTY_FALSE if "P>1/3" in shown else EXIT_OK)


@pytest.mark.parametrize(
    ("select", "message"),
    [
        ("4", "there is no property 4: the properties are numbered 1 to 3"),
        ("nope", 'no property is named "nope"'),
        ("a,,b", "an empty property name or position"),
    ],
)
def test_a_wrong_selection_is_refused_before_any_work(
    tmp_path: Path, select: str, message: str
) -> None:
    m, p = _third(tmp_path)
    r = CliRunner().invoke(main, ["check", m, p, "--select", select])
    assert r.exit_code == EXIT_ERROR
    assert message in r.output and "Model" not in r.output


# an int variable given int/int and an observable named like a label: Storm reads both
STORMISH = """pomdp
const int N = 4;
module m
  x : [0..4] init N/2;
  [] x<4 -> (x'=(x+2)/2*2);
  [] x=4 -> true;
endmodule
label "top" = x=4;
observable "top" = x=4;
"""


def test_storms_reading_warns_and_strict_refuses(tmp_path: Path) -> None:
    m = tmp_path / "m.prism"
    m.write_text(STORMISH)
    r = CliRunner().invoke(main, ["build", str(m)])
    assert r.exit_code == EXIT_OK, r.output
    warnings = [ln for ln in r.output.splitlines() if ln.startswith("warning:")]
    assert [w.split(": ")[1] for w in warnings] == [f"{m}:4:19", f"{m}:5:17", f"{m}:9:1"]
    assert all("accepted as in Storm" in w and "PRISM's rule" in w for w in warnings)
    # by hand: x = 2 -> (2+2)/2*2 = 4; two states
    assert "States:       2" in r.output
    r = CliRunner().invoke(main, ["build", str(m), "--strict"])
    assert r.exit_code == EXIT_ERROR
    assert r.output.count("error:") == 3 and "PRISM's rule" in r.output
    r = CliRunner().invoke(main, ["lint", str(m), "--strict"])
    assert r.exit_code == EXIT_ERROR and "3 error(s)" in r.output
