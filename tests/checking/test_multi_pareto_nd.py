"""Pareto fronts of three and more objectives on mdps (posgmc.engines.multi.pareto_nd), against
hand-derived vertices, and invariants on random mdps against the sound single-objective engine
and against the achievability LP."""

from __future__ import annotations

import csv
import io

import numpy as np
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.cli import main
from posgmc.tradeoffs.front import front_to_csv

# s0 picks one action, each a distribution over the targets A (s=1), B (s=2), C (s=3):
# a: A; b: A or B, 1/2 each; c: C; d: A 0.2, B 0.6, C 0.2 (by hand: none of the four points is
# below a convex combination of the others, e.g. b needs v2 >= 1/2, only b and d have v2 > 0,
# and d's v1 = 0.2 cannot make up b's 0.5; so all four are vertices)
PICK = """mdp
module m
  s : [0..3] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [c] s=0 -> (s'=3);
  [d] s=0 -> 0.2:(s'=1) + 0.6:(s'=2) + 0.2:(s'=3);
  [e] s>0 -> true;
endmodule
label "A" = s=1;
label "B" = s=2;
label "C" = s=3;
rewards "cost" [d] true : 1; endrewards
"""
THREE = 'multi(Pmax=? [ F "A" ], Pmax=? [ F "B" ], Pmax=? [ F "C" ])'


def _front(model: str, prop: str):  # type: ignore[no-untyped-def]
    report = api.check(api.load(text=model), properties=[prop])
    assert not report.errors, [e.render() for _, e in report.errors]
    (result,) = report.results
    assert result.sound is False  # LP values, not proven bounds
    return result.multi.front


def _rows(a: np.ndarray) -> set[tuple[float, ...]]:
    return {tuple(round(float(v), 6) for v in row) for row in a}


def test_the_model_has_four_states() -> None:
    assert api.build(api.load(text=PICK)).model.num_states == 4


def test_three_objectives_give_the_vertices_derived_by_hand() -> None:
    f = _front(PICK, THREE)
    assert len(f.objectives) == 3
    assert _rows(f.points) == {(1, 0, 0), (0.5, 0.5, 0), (0, 0, 1), (0.2, 0.6, 0.2)}
    assert f.converged and f.precision <= 1e-6
    # the over-approximation closes on the same vertices (every corner is an achievable vertex)
    assert _rows(f.corners) <= _rows(f.points)
    assert f.text().count("(") == 4


def test_a_minimised_reward_as_fourth_objective() -> None:
    # 'cost' is paid by d only: minimising it adds the cost-free vertices with cost 0 and keeps
    # d's (with cost 1)
    f = _front(PICK, 'multi(Pmax=? [ F "A" ], Pmax=? [ F "B" ], Pmax=? [ F "C" ], '
                     'R{"cost"}min=? [ C ])')
    assert [d.value for d in f.directions] == ["max", "max", "max", "min"]
    assert _rows(f.points) == {(1, 0, 0, 0), (0.5, 0.5, 0, 0), (0, 0, 1, 0), (0.2, 0.6, 0.2, 1)}


def test_a_constraint_cuts_the_front() -> None:
    # P(F C) >= 0.5: c itself, and c mixed with a (1/2 each: (0.5, 0, 0.5)), with b ((0.25,
    # 0.25, 0.5)) and with d (0.2 t + (1 - t) = 0.5 at t = 5/8: (0.125, 0.375, 0.5)); by hand
    # the b mixture is not a vertex: it is 1/3 of the a mixture plus 2/3 of the d mixture
    f = _front(
        PICK, 'multi(Pmax=? [ F "A" ], Pmax=? [ F "B" ], Pmax=? [ F "C" ], P>=0.5 [ F "C" ])'
    )
    assert _rows(f.points) == {(0.5, 0, 0.5), (0.125, 0.375, 0.5), (0, 0, 1)}


def test_csv_and_cli_take_every_objective(tmp_path) -> None:  # type: ignore[no-untyped-def]
    f = _front(PICK, THREE)
    rows = list(csv.reader(io.StringIO(front_to_csv(f))))
    assert rows[0] == ["kind", 'Pmax=? [ F "A" ]', 'Pmax=? [ F "B" ]', 'Pmax=? [ F "C" ]']
    assert [r[0] for r in rows].count("achievable") == 4 and rows[-1][0] == "precision"
    path = tmp_path / "pick.nm"
    path.write_text(PICK)
    out = CliRunner().invoke(main, ["pareto", str(path), "--prop", THREE,
                                    "--csv", str(tmp_path / "f.csv")])
    assert out.exit_code == 0, out.output
    assert "Pareto front, 4 vertices" in out.output and (tmp_path / "f.csv").is_file()
    out = CliRunner().invoke(main, ["pareto", str(path), "--prop", THREE,
                                    "--plot", str(tmp_path / "f.png")])
    assert out.exit_code == 2 and "the plot is 2-D" in out.output


def test_more_than_five_objectives_are_refused() -> None:
    prop = "multi(" + ", ".join(['Pmax=? [ F "A" ]'] * 6) + ")"
    report = api.check(api.load(text=PICK), properties=[prop])
    (error,) = [e for _, e in report.errors]
    assert "at most 5 objectives" in error.message


@st.composite
def _mdps(draw):  # type: ignore[no-untyped-def]
    n = draw(st.integers(4, 6))
    lines = ["mdp", "module m", f"  s : [0..{n - 1}] init 0;"]
    for s in range(n):
        for k in range(draw(st.integers(1, 3))):
            succ = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=3, unique=True))
            weights = draw(st.lists(st.integers(1, 4), min_size=len(succ), max_size=len(succ)))
            total = sum(weights)
            upd = " + ".join(f"{w}/{total}:(s'={t})" for w, t in zip(weights, succ))
            lines.append(f"  [a{s}_{k}] s={s} -> {upd};")
    lines.append("endmodule")
    return "\n".join(lines) + "\n"


@settings(max_examples=20, deadline=None)
@given(_mdps())
def test_vertices_are_achievable_and_the_extremes_are_the_single_optima(model: str) -> None:
    """Each coordinate's largest vertex value is the ordinary Pmax (sound value iteration); each
    vertex passes the achievability LP just below it; every corner of the over-approximation is
    within the precision of the vertices."""
    targets = ["s=1", "s=2", "s=3"]
    prop = "multi(" + ", ".join(f"Pmax=? [ F {t} ]" for t in targets) + ")"
    session = api.load(text=model)
    report = api.check(session, properties=[prop] + [f"Pmax=? [ F {t} ]" for t in targets])
    front, *singles = report.results
    f = front.multi.front
    assert f.converged
    for axis, single in enumerate(singles):
        assert single.lower - 1e-6 <= f.points[:, axis].max() <= single.upper + 1e-6
    for p in f.points[:3]:
        ach = "multi(" + ", ".join(f"P>={max(0.0, v - 1e-5):.9f} [ F {t} ]"
                                   for v, t in zip(p, targets)) + ")"
        assert api.check(session, properties=[ach]).results[0].value is True
    assert f.precision <= 1e-5


@settings(max_examples=15, deadline=None)
@given(_mdps())
def test_a_constant_third_objective_leaves_the_two_objective_front(model: str) -> None:
    """P(true) = 1 for every strategy: the three-objective front is the two-objective one (the
    engine of pareto.py) with a 1 appended to every vertex."""
    session = api.load(text=model)
    two, three = api.check(session, properties=[
        "multi(Pmax=? [ F s=1 ], Pmax=? [ F s=2 ])",
        "multi(Pmax=? [ F s=1 ], Pmax=? [ F s=2 ], Pmax=? [ true ])",
    ]).results
    f2, f3 = two.multi.front, three.multi.front
    assert np.allclose(f3.points[:, 2], 1.0, atol=1e-7)
    assert _rows(f3.points[:, :2]) == _rows(f2.points)
