"""Proven bounds for multi(...) answers on mdps: the strategy of the LP's solution, re-checked by
the sound engines on the chain it induces (posgmc.engines.multi.scheduler). Hand-derived values
and invariants against the sound single-objective engine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from tests.checking.helpers import GAMBLE  # P(F s=1) = q/2, expected cost q (by hand, there)

# s0: a -> the end component {s1, s2} (s1 may stay or go to s2, s2 returns), b -> s3 absorbing
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


def test_the_models_have_their_sizes() -> None:
    assert api.build(api.load(text=GAMBLE)).model.num_states == 3
    assert api.build(api.load(text=LOOPS)).model.num_states == 4


def test_a_numerical_maximum_gets_a_proven_lower_bound() -> None:
    # Pmax with cost <= 0.6: q = 0.6, P = 0.3 (by hand); the strategy is re-checked with the
    # constraint tightened by 1e-6, so the proven bound is just below 0.3
    r = _one(GAMBLE, 'multi(Pmax=? [ F s=1 ], R{"cost"}<=0.6 [ C ])')
    assert r.value == pytest.approx(0.3, abs=1e-9)
    c = r.multi.certified
    assert 0.3 - 1e-5 <= c <= 0.3 and not r.multi.minimised
    assert r.lower <= c and "proven: the optimum is at least" in r.note
    assert r.sound is False  # one side only


def test_a_numerical_minimum_gets_a_proven_upper_bound() -> None:
    # Rmin of the cost with P(F s=1) >= 0.25: q = 0.5 (by hand)
    r = _one(GAMBLE, 'multi(R{"cost"}min=? [ C ], P>=0.25 [ F s=1 ])')
    assert r.value == pytest.approx(0.5, abs=1e-9)
    assert r.multi.minimised and 0.5 <= r.multi.certified <= 0.5 + 1e-5
    assert r.upper >= r.multi.certified and "at most" in r.note


def test_settling_in_an_end_component_is_re_checked() -> None:
    # G F s=2 and F G s=1 need the path to settle in {s1, s2} resp. {s1}: by hand both reach 1
    # through a, and G F s=2 & P(F G s=3) >= 0.5 is only met by mixing a and b half and half
    r = _one(LOOPS, "multi(Pmax=? [ G F s=2 ], P>=0.5 [ F G s=3 ])")
    assert r.value == pytest.approx(0.5, abs=1e-9)
    assert 0.5 - 1e-5 <= r.multi.certified <= 0.5
    r = _one(LOOPS, "multi(Pmax=? [ F G s=1 ])")
    assert r.multi.certified == pytest.approx(1.0, abs=1e-6)


def test_achievability_true_is_proven_and_sound() -> None:
    r = _one(GAMBLE, 'multi(P>=0.2 [ F s=1 ], R{"cost"}<=0.6 [ C ])')
    assert r.value is True and r.multi.proven and r.sound is True
    assert "proven" in r.note
    # false is the LP's verdict only (infeasibility is not certified)
    r = _one(GAMBLE, 'multi(P>=0.4 [ F s=1 ], R{"cost"}<=0.6 [ C ])')
    assert r.value is False and not r.multi.proven and r.sound is False


def test_at_the_boundary_nothing_is_proven() -> None:
    # q = 0.6 exactly meets both thresholds: no strategy has room, the strategy's own check
    # cannot prove both to the last bit
    r = _one(GAMBLE, 'multi(P>=0.3 [ F s=1 ], R{"cost"}<=0.6 [ C ])')
    assert r.value is True and r.sound is (r.multi.proven is True)


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


@settings(max_examples=30, deadline=None)
@given(_mdps(), st.sampled_from(["max", "min"]), st.floats(0.0, 1.0))
def test_proven_bounds_are_on_the_right_side_of_the_optimum(
    model: str, direction: str, p: float
) -> None:
    """The proven bound lies on its side of the sound engine's optimum (single objective), and
    close to the LP's value; with a constraint it never passes the LP's optimum."""
    session = api.load(text=model)
    prop = f"P{direction}=? [ F s=1 ]"
    single, multi = api.check(session, properties=[prop, f"multi({prop})"]).results
    c = multi.multi.certified
    assert not math.isnan(c)
    if direction == "max":
        assert c <= single.upper + 1e-9 and c >= single.lower - 1e-5
    else:
        assert c >= single.lower - 1e-9 and c <= single.upper + 1e-5
    report = api.check(session, properties=[f"multi(Pmax=? [ F s=1 ], P>={p:.4f} [ F s=0 ])"])
    if report.results:
        r = report.results[0]
        if not np.isnan(r.value) and not math.isnan(r.multi.certified):
            assert r.multi.certified <= r.value + 1e-7
