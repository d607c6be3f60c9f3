"""PRISM's multi(...) queries on small mdps of our own, against hand-derived answers
(posgmc.checking.multi; PRISM's own RESULT lines are graded by benchmarks/prism_multi.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from posgmc import api
from tests.checking.helpers import GAMBLE

# s0: a -> s1 (r1 = 1), b -> s2 (r2 = 2); s1 -> s3 (r1 = 1); s2 -> s3 (r2 = 1); s3 absorbing.
STEPS = """mdp
module m
  s : [0..3] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> (s'=2);
  [c] s=1 -> (s'=3);
  [d] s=2 -> (s'=3);
  [] s=3 -> true;
endmodule
rewards "r1" [a] true : 1; [c] true : 1; endrewards
rewards "r2" [b] true : 2; [d] true : 1; endrewards
"""

# s0: a -> the end component {s1, s2} (s1 may stay or go to s2, s2 returns), b -> s3 absorbing.
LOOPS = """mdp
module m
  s : [0..3] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> (s'=3);
  [stay] s=1 -> (s'=1);
  [go] s=1 -> (s'=2);
  [back] s=2 -> (s'=1);
  [] s=3 -> true;
endmodule
"""


def _one(model: str, prop: str):  # type: ignore[no-untyped-def]
    report = api.check(api.load(text=model), properties=[prop])
    assert not report.errors, [e.render() for _, e in report.errors]
    (result,) = report.results
    return result


def test_model_sizes() -> None:
    sizes = [api.build(api.load(text=t)).model.num_states for t in (GAMBLE, STEPS, LOOPS)]
    assert sizes == [3, 4, 4]


# -- numerical --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("model", "prop", "expected"),
    [
        # max q/2 subject to q <= 1/2: q = 1/2
        (GAMBLE, 'multi(Pmax=? [ F s=1 ], R{"cost"}<=0.5 [ C ])', 0.25),
        # min P(F s=2) = 1 - q/2 subject to q >= 1/2: q = 1
        (GAMBLE, 'multi(Pmin=? [ F s=2 ], R{"cost"}>=0.5 [ C ])', 0.5),
        # an upper bound on a probability: P(F s=1) <= 0.1, so q <= 0.2, cost max 0.2
        (GAMBLE, 'multi(R{"cost"}max=? [ C ], P<=0.1 [ F s=1 ])', 0.2),
        # r1 within one step is q, r2 within two steps 3(1 - q) >= 1: q <= 2/3
        (STEPS, 'multi(R{"r1"}max=? [ C<=1 ], R{"r2"}>=1 [ C<=2 ])', 2 / 3),
        # within zero steps nothing is collected
        (STEPS, 'multi(R{"r1"}max=? [ C<=0 ])', 0.0),
        # total r1 is 2q, total r2 is 3(1 - q) >= 1.5: q <= 1/2
        (STEPS, 'multi(R{"r1"}max=? [ C ], R{"r2"}>=1.5 [ C ])', 1.0),
        # G F s=2 needs the loop (a) and its go/back cycle: 1 - P(F s=3)
        (LOOPS, 'multi(Pmax=? [ G F s=2 ], P>=0.5 [ F s=3 ])', 0.5),
        # co-safe LTL through a DFA product: s1 followed directly by s2
        (LOOPS, 'multi(Pmax=? [ F (s=1 & X (s=2)) ], P>=0.25 [ F s=3 ])', 0.75),
        # safety (its negation is co-safe): never s3
        (LOOPS, 'multi(Pmax=? [ G !(s=3) ], P>=0.4 [ F s=3 ])', 0.6),
        # P(F s=2) = 1 - q/2 >= 0.9: q <= 0.2
        (GAMBLE, 'multi(Pmax=? [ F s=1 ], R{"cost"}<=0.5 [ C ], P>=0.9 [ F s=2 ])', 0.1),
        # P(F s=1) = q/2 >= 0.9 cannot be met: PRISM's NaN
        (GAMBLE, 'multi(Pmax=? [ F s=2 ], P>=0.9 [ F s=1 ])', math.nan),
    ],
)
def test_numerical(model: str, prop: str, expected: float) -> None:
    r = _one(model, prop)
    assert r.kind.value == "number" and r.method == "lp (HiGHS)" and r.sound is False
    if math.isnan(expected):
        assert math.isnan(r.value) and "cannot be met" in (r.note or "")
    else:
        assert r.value == pytest.approx(expected, abs=1e-7)
        assert r.lower <= r.value <= r.upper


# -- achievability ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("bound", "achievable", "decided"),
    [("0.2", True, True), ("0.25", True, False), ("0.3", False, True)],
)
def test_achievability_with_margin(bound: str, achievable: bool, decided: bool) -> None:
    # q/2 >= bound and q <= 1/2: the boundary is bound = 0.25
    r = _one(GAMBLE, f'multi(P>={bound} [ F s=1 ], R{{"cost"}}<=0.5 [ C ])')
    assert r.kind.value == "boolean" and r.value is achievable
    assert r.multi.decided is decided
    if decided:
        # the margin is the LP's max-min slack t = min(q/2 - bound, 0.5 - q), best where the two
        # are equal: q = (1 + 2 bound)/3, t = (1 - 4 bound)/6: 1/30 for 0.2, -1/30 for 0.3
        expected = (1 - 4 * float(bound)) / 6
        assert r.multi.margin == pytest.approx(expected, abs=1e-7)
    else:
        assert "boundary" in r.note


def test_inside_conditions_need_sub_components() -> None:
    # F G s=1 needs the sub-component {s1} (stay), G F s=2 the whole loop: not both at once
    assert _one(LOOPS, "multi(P>=0.5 [ F G s=1 ], P>=0.5 [ G F s=2 ])").value is True
    assert _one(LOOPS, "multi(P>=0.6 [ F G s=1 ], P>=0.6 [ G F s=2 ])").value is False


# -- Pareto ------------------------------------------------------------------------------------


def test_pareto_front_vertices_and_band() -> None:
    r = _one(GAMBLE, 'multi(Pmax=? [ F s=1 ], R{"cost"}min=? [ C ])')
    front = r.front
    assert r.kind.value == "pareto" and front is not None and front.converged
    # (q/2, q) for q in [0, 1]: the vertices q = 1 and q = 0
    assert np.allclose(front.points, [[0.5, 1.0], [0.0, 0.0]], atol=1e-9)
    assert front.text() == "[(0.5,1),(0,0)]"
    assert front.precision <= 1e-6
    # the over-approximation's corners are the same points (the front is one segment)
    assert len(front.corners) == 2
    json = r.to_json()
    assert np.allclose(json["front"]["points"], [[0.5, 1.0], [0.0, 0.0]], atol=1e-9)


def test_pareto_with_sub_components() -> None:
    # mixing "stay at s1 forever" and "cycle s1-s2" traces the segment from (1, 0) to (0, 1)
    front = _one(LOOPS, "multi(Pmax=? [ F G s=1 ], Pmax=? [ G F s=2 ])").front
    assert np.allclose(front.points, [[1.0, 0.0], [0.0, 1.0]], atol=1e-9)


def test_pareto_points_are_achievable() -> None:
    # each vertex of a three-vertex front (numerical queries at the vertex agree)
    model = STEPS.replace(
        "[b] s=0 -> (s'=2);", "[b] s=0 -> (s'=2);\n  [e] s=0 -> 0.5:(s'=1) + 0.5:(s'=3);"
    )
    model = model.replace('rewards "r2"', 'rewards "r2" [e] true : 2.5;')
    front = _one(model, 'multi(R{"r1"}max=? [ C ], R{"r2"}max=? [ C ])').front
    # pure strategies: a (2, 0), b (0, 3), e (0.5, 2.5): e is not on the hull's boundary
    # since 0.5/2 + 2.5/3 = 1.083 > 1 it is: three vertices
    assert np.allclose(front.points, [[2, 0], [0.5, 2.5], [0, 3]], atol=1e-9)
    for x, y in front.points:
        r = _one(model, f'multi(R{{"r1"}}max=? [ C ], R{{"r2"}}>={y - 1e-9} [ C ])')
        assert r.value == pytest.approx(x, abs=1e-7)


# -- errors ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("prop", "words", "column"),
    [
        ("1 + multi(Pmax=? [ F s=1 ])", "must be a whole property", 5),
        ('multi(Pmax=? [ F s=1 ], R{"cost"}<=1 [ F s=2 ])', "total [C] and cumulative", 40),
        ("multi(P=? [ F s=1 ])", "needs a direction", 7),
        ("multi(Pmax=? [F s=1], Pmax=? [F s=2], Pmin=? [F s=0], Pmax=? [F s=1], "
         "Pmax=? [F s=2], Pmin=? [F s=0])", "at most 5 objectives", 1),
        ("multi(s=1)", "must be a P or R query", 7),
    ],
)
def test_errors_point_at_the_argument(prop: str, words: str, column: int) -> None:
    report = api.check(api.load(text=GAMBLE), properties=[prop])
    errors = [e for _, e in report.errors]
    assert errors, "expected an error"
    first = errors[0]
    messages = [first.message] + [e.message for e in getattr(first, "errors", [])]
    assert any(words in m for m in messages), messages
    assert (first.span.line, first.span.column) == (1, column) or any(
        words in e.message and e.span.column == column for e in getattr(first, "errors", [])
    )


def test_games_are_refused_with_a_message() -> None:
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    report = api.check(
        api.load(root / "models" / "rover.smg"), properties=['multi(Pmax=? [ F "goal" ])']
    )
    (error,) = [e for _, e in report.errors]
    assert "smg" in error.message and "docs/tradeoffs.md" in (error.hint or "")


# -- invariants --------------------------------------------------------------------------------


@st.composite
def _mdps(draw):  # type: ignore[no-untyped-def]
    n = draw(st.integers(2, 5))
    lines = ["mdp", "module m", f"  s : [0..{n - 1}] init 0;"]
    rewards = []
    for s in range(n):
        for k in range(draw(st.integers(1, 2))):
            succ = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=2, unique=True))
            weights = draw(st.lists(st.integers(1, 4), min_size=len(succ), max_size=len(succ)))
            total = sum(weights)
            upd = " + ".join(f"{w}/{total}:(s'={t})" for w, t in zip(weights, succ))
            lines.append(f"  [a{s}_{k}] s={s} -> {upd};")
            rewards.append(f"  [a{s}_{k}] true : {draw(st.integers(0, 3))};")
    lines.append("endmodule")
    lines += ['rewards "r"', *rewards, "endrewards"]
    return "\n".join(lines) + "\n"


@settings(max_examples=25, deadline=None)
@given(_mdps(), st.sampled_from(["max", "min"]))
def test_single_objective_agrees_with_the_engine(model: str, direction: str) -> None:
    """multi with one reachability objective is the ordinary Pmax/Pmin (sound value iteration)."""
    session = api.load(text=model)
    prop = f"P{direction}=? [ F s=1 ]"
    report = api.check(session, properties=[prop, f"multi({prop})"])
    single, multi = report.results
    assert single.lower - 1e-7 <= multi.value <= single.upper + 1e-7


# Found by hypothesis (the test below): every strategy's total is infinite, but one strategy
# settles in a zero-reward end component with probability 1/2; the LP (settling with
# probability 1) was infeasible and multi said NaN where the engine says infinity.
_HALF_SETTLES = """mdp
module m
  s : [0..2] init 0;
  [a0_0] s=0 -> 1/2:(s'=1) + 1/2:(s'=2);
  [a0_1] s=0 -> 1/1:(s'=0);
  [a1_0] s=1 -> 1/1:(s'=1);
  [a2_0] s=2 -> 1/1:(s'=2);
endmodule
rewards "r"
  [a0_0] true : 0;
  [a0_1] true : 1;
  [a1_0] true : 1;
  [a2_0] true : 0;
endrewards
"""


@settings(max_examples=25, deadline=None)
@given(_mdps())
@example(_HALF_SETTLES)
def test_min_total_reward_agrees_with_the_engine(model: str) -> None:
    """multi(R min [C]) is the ordinary minimal expected total reward (infinite when every
    strategy collects reward forever: then multi refuses, and the engine says infinity)."""
    report = api.check(
        api.load(text=model), properties=['R{"r"}min=? [ C ]', 'multi(R{"r"}min=? [ C ])']
    )
    errors = [e for _, e in report.errors]
    if errors:
        (single,) = report.results
        assert math.isinf(single.value) and "infinite" in errors[0].message
    else:
        single, multi = report.results
        assert single.lower - 1e-7 <= multi.value <= single.upper + 1e-7


def test_pareto_results_are_graded_vertex_by_vertex() -> None:
    from posgmc.checking.expected import grade
    from posgmc.syntax.ast import ExpectedResult

    r = _one(GAMBLE, 'multi(Pmax=? [ F s=1 ], R{"cost"}min=? [ C ])')
    assert grade(ExpectedResult("[(0.5,1),(0,0)]"), r).passed
    assert grade(ExpectedResult("[(0,0),(0.5,1.0))]"), r).passed  # PRISM's stray parenthesis
    assert not grade(ExpectedResult("[(0.5,1)]"), r).passed  # a vertex missing
    assert not grade(ExpectedResult("[(0.5,0.9),(0,0)]"), r).passed  # a vertex elsewhere
    assert not grade(ExpectedResult("0.5"), r).passed


def test_infinite_totals_are_refused_at_the_query() -> None:
    """The refusal of _HALF_SETTLES (every strategy's total is infinite) names the reason and
    points at the multi(...) query (line 1, column 1 of the property)."""
    report = api.check(api.load(text=_HALF_SETTLES), properties=['multi(R{"r"}min=? [ C ])'])
    ((_, error),) = report.errors
    assert "expected total rewards are infinite" in error.message
    assert (error.span.line, error.span.column) == (1, 1)
