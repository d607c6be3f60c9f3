"""Defender trade-off fronts on partially observable games: one synthesised defence
per scalarisation weight, both objectives verified under each from its exported posgmc-fss/1
file, the front and the constrained answers taken from those proven numbers.

The games are small enough to solve by hand. In both, the defender picks once between ``safe``
(cost 10) and ``cheap`` (cost 1, success 1/2); ``safe`` succeeds with probability 0.9, or 0.7 when
the attacker of the posg has jammed first (the defender does not see it, the attacker always
jams against ``safe``). So the guaranteed points are (cost 1, mission 1/2) and (10, 0.9) resp.
(10, 0.7), and the scalarised cost ``cost - w * P(goal)`` prefers ``safe`` exactly when
10 - 0.9 w < 1 - 0.5 w, i.e. w > 22.5 (posg: 10 - 0.7 w < 1 - 0.5 w, w > 45).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.errors import InputError, UnsupportedError
from posgmc.tradeoffs.defence import best_under, defence_front, defence_front_to_csv
from tests.tradeoffs.helpers import CHOICE

JAM = """posg
player planner
  [safe], [cheap], [end]
  observables s endobservables
endplayer
player attacker
  [jam], [idle]
  observables s endobservables
endplayer
module m
  s : [0..3] init 0;
  jammed : bool init false;
  [jam]   s=0 -> (jammed'=true)&(s'=1);
  [idle]  s=0 -> (s'=1);
  [safe]  s=1 -> (jammed ? 0.7 : 0.9):(s'=2) + (jammed ? 0.3 : 0.1):(s'=3);
  [cheap] s=1 -> 0.5:(s'=2) + 0.5:(s'=3);
  [end]   s>1 -> true;
endmodule
label "goal" = s=2;
label "done" = s>1;
rewards "cost"
  [safe] true : 10;
  [cheap] true : 1;
endrewards
"""

MISSION, COST = 'Pmax=? [ F "goal" ]', 'R{"cost"}min=? [ F "done" ]'
PMISSION, PCOST = '<<planner>> Pmax=? [ F "goal" ]', '<<planner>> R{"cost"}min=? [ F "done" ]'


def _within(bound, want: float) -> bool:  # type: ignore[no-untyped-def]
    return bound.lower - 1e-9 <= want <= bound.upper + 1e-9


@pytest.fixture(scope="module")
def choice(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("defence") / "choice.pomdp"
    path.write_text(CHOICE)
    return path


@pytest.fixture(scope="module")
def pomdp_front(choice: Path, tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    out = tmp_path_factory.mktemp("defence_strategies")
    return defence_front(choice, MISSION, COST, weights=[0, 20, 30], timeout=3,
                         budgets=[0.5, 5, 10.5], strategy_dir=out)


def test_the_games_have_the_sizes_derived_by_hand(choice: Path, tmp_path: Path) -> None:
    assert api.build(api.load(choice)).model.num_states == 3
    jam = tmp_path / "jam.posg"
    jam.write_text(JAM)
    assert api.build(api.load(jam)).model.num_states == 7  # s=0; s=1, 2, 3 each jammed or not


def test_every_weight_gives_the_defence_derived_by_hand(pomdp_front) -> None:  # type: ignore[no-untyped-def]
    points = pomdp_front.points
    assert [p.weight for p in points] == [0.0, 20.0, 30.0, math.inf]
    # w = 0 and 20 < 22.5: cheap (1/2 for cost 1); w = 30 and the mission alone: safe (0.9 for 10)
    for p, (mission, cost) in zip(points, [(0.5, 1), (0.5, 1), (0.9, 10), (0.9, 10)]):
        assert p.verified and p.error is None
        assert _within(p.mission, mission) and _within(p.cost, cost)
    assert pomdp_front.front == (0, 2)  # the duplicates are not on the front
    fm, fc = pomdp_front.full_observation
    assert _within(fm, 0.9) and _within(fc, 1.0)  # each objective on its own


def test_constraints_are_answered_from_proven_bounds_only(pomdp_front) -> None:  # type: ignore[no-untyped-def]
    none, five, more = pomdp_front.budgets
    assert (none.budget, none.point, none.pure) == (0.5, None, None)
    assert (more.pure, more.mixed, more.point) == (2, None, pomdp_front.points[2])
    # cost <= 10 is not proven by the interval [10 - 1e-9, 10 + 1e-9] of the safe defence
    assert pomdp_front.points[2].cost.upper > 10
    assert best_under(pomdp_front.points, 10.0) == 0
    # cost <= 5: safe with probability alpha, cheap otherwise, 1 + 9 alpha = 5: alpha = 4/9 and
    # mission 1/2 + 0.4 * 4/9 = 0.6777..., the constrained optimum (randomising in s=0), up to
    # the margin left for the bounds' width
    assert five.pure == 0 and five.mixed is not None
    i, j, alpha = five.mixed
    assert (i, j) in {(0, 2), (0, 3), (1, 2), (1, 3)} and alpha == pytest.approx(4 / 9, abs=1e-8)
    assert five.point.verified and five.point.cost.upper <= 5
    assert _within(five.point.mission, 0.5 + 0.4 * alpha)
    assert five.point.mission.lower == pytest.approx(0.5 + 0.4 * 4 / 9, abs=1e-8)
    assert five.point.strategy.memory_size == 3  # undecided + one node of each


def test_every_point_reverifies_from_its_exported_file(choice: Path, pomdp_front) -> None:  # type: ignore[no-untyped-def]
    session = api.load(choice)
    for p in (*pomdp_front.points, pomdp_front.budgets[1].point):
        assert p.strategy_file is not None and Path(p.strategy_file).is_file()
        report = api.check(session, properties=[MISSION, COST], strategies={"": p.strategy_file})
        mission, cost = (r.guaranteed for r in report.results)
        assert mission.lower == pytest.approx(p.mission.lower, abs=1e-12)
        assert cost.upper == pytest.approx(p.cost.upper, abs=1e-12)


def test_the_csv_has_one_row_per_point_and_per_budget(pomdp_front) -> None:  # type: ignore[no-untyped-def]
    rows = list(csv.DictReader(io.StringIO(defence_front_to_csv(pomdp_front))))
    assert [r["kind"] for r in rows] == ["point"] * 4 + ["budget"] * 3
    assert [r["on_front"] for r in rows[:4]] == ["True", "False", "True", "False"]
    assert float(rows[2]["mission_lower"]) == pomdp_front.points[2].mission.lower
    assert rows[4]["error"] == "no verified point meets it"
    assert rows[5]["weight"].startswith("mix(") and float(rows[5]["cost_upper"]) <= 5
    assert rows[6]["weight"] == "30" and float(rows[6]["cost"]) == 10.5


def test_a_posg_front_holds_against_the_attacker(tmp_path: Path) -> None:
    jam = tmp_path / "jam.posg"
    jam.write_text(JAM)
    f = defence_front(jam, PMISSION, PCOST, weights=[0, 50], timeout=3, include_mission=False,
                      strategy_dir=tmp_path / "s")
    (cheap, safe) = f.points
    assert _within(cheap.mission, 0.5) and _within(cheap.cost, 1.0)
    assert _within(safe.mission, 0.7) and _within(safe.cost, 10.0)  # the attacker jams
    again = api.check(api.load(jam), properties=[PMISSION],
                      strategies={"planner": safe.strategy_file}).results[0]
    assert _within(again.guaranteed, 0.7)


def test_queries_outside_the_fragment_are_refused(choice: Path, tmp_path: Path) -> None:
    with pytest.raises(UnsupportedError, match="unbounded reachability"):
        defence_front(choice, 'Pmax=? [ F<=3 "goal" ]', COST, weights=[0])
    with pytest.raises(UnsupportedError, match="minimised reward"):
        defence_front(choice, MISSION, 'R{"cost"}max=? [ F "done" ]', weights=[0])
    with pytest.raises(InputError, match=">= 0"):
        defence_front(choice, MISSION, COST, weights=[-1])
    jam = tmp_path / "jam.posg"
    jam.write_text(JAM)
    with pytest.raises(InputError, match="same coalition"):
        defence_front(jam, PMISSION, '<<attacker>> R{"cost"}min=? [ F "done" ]', weights=[0])
    mdp = tmp_path / "m.nm"
    mdp.write_text("mdp\nmodule m s:[0..1] init 0; [a] s=0 -> (s'=1); [b] s=1 -> true; endmodule\n"
                   'label "goal" = s=1;\nrewards "cost" [a] true : 1; endrewards\n')
    with pytest.raises(UnsupportedError, match="not partially observable"):
        defence_front(mdp, MISSION, COST, weights=[0])


def test_the_cli_prints_the_front_and_writes_csv_and_plot(choice: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    out = CliRunner().invoke(main, [
        "pareto", str(choice), "--prop", MISSION, "--cost", COST, "--weights", "0,30",
        "--budget", "5", "--timeout", "2", "--csv", str(tmp_path / "f.csv"),
        "--plot", str(tmp_path / "f.png"), "--strategies", str(tmp_path / "s")])
    assert out.exit_code == 0, out.output
    assert "cost <= 5: mission >= 0.67777777" in out.output
    assert "by the mixture of w=30 (probability 0.444444" in out.output
    assert (tmp_path / "f.png").stat().st_size > 0
    assert (tmp_path / "s" / "w=30" / "agent.json").is_file()


def test_the_cli_refuses_weights_without_a_cost(choice: Path) -> None:
    out = CliRunner().invoke(main, ["pareto", str(choice), "--prop", MISSION, "--weights", "0,1"])
    assert out.exit_code == 2
    assert "--weights and --budget go with --cost" in out.output


def test_the_cli_refuses_bad_weights_and_mixing_with_a_sweep(choice: Path) -> None:
    out = CliRunner().invoke(main, ["pareto", str(choice), "--prop", MISSION, "--cost", COST,
                                    "--weights", "0,x"])
    assert out.exit_code == 2 and "comma-separated list of numbers" in out.output
    assert "--weights:1:3: error: --weights: 'x' is not a number" in out.output, out.output
    out = CliRunner().invoke(main, ["pareto", str(choice), "--prop", MISSION, "--cost", COST,
                                    "--sweep", "B=0:1"])
    assert out.exit_code == 2 and "do not apply" in out.output


def test_the_plotted_mixture_hull_drops_points_below_a_chord() -> None:
    from posgmc.tradeoffs.plot import _upper_hull

    # (5, 0.6) lies below the chord from (1, 0.5) to (10, 0.9) (0.678 there): not on the hull
    assert _upper_hull([(10, 0.9), (1, 0.5), (5, 0.6)]) == [(1, 0.5), (10, 0.9)]
    assert _upper_hull([(1, 0.5), (5, 0.8), (10, 0.9)]) == [(1, 0.5), (5, 0.8), (10, 0.9)]
