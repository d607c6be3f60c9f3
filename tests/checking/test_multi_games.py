"""PRISM-games' coalition form <<C>> (q1 & q2) on stopping smgs (posgmc.checking.multi_games),
against hand-derived achievable sets."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from posgmc import api

# p1 at s0: a hands over to p2 at s1, b reaches s3/s4 with 1/2 each, e with 0.9/0.1; p2 at s1:
# c gives (0.8, 0.2), d (0.4, 0.6). For (P(F s=3), P(F s=4)) p1 gets, against p2:
# after a only what both of p2's choices give, (0.4, 0.2); so p1's achievable set is the
# downward closure of the hull of (0.5, 0.5), (0.9, 0.1), (0.4, 0.2): the segment x + y = 1
# between (0.9, 0.1) and (0.5, 0.5), and below it.
GAME = """smg
player p1 [a], [b], [e] endplayer
player p2 [c], [d] endplayer
module m
  s : [0..4] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> 0.5:(s'=3) + 0.5:(s'=4);
  [e] s=0 -> 0.9:(s'=3) + 0.1:(s'=4);
  [c] s=1 -> 0.8:(s'=3) + 0.2:(s'=4);
  [d] s=1 -> 0.4:(s'=3) + 0.6:(s'=4);
  [] s>=3 -> true;
endmodule
rewards "r" [a] true : 2; endrewards
"""


def _one(prop: str, text: str = GAME):  # type: ignore[no-untyped-def]
    report = api.check(api.load(text=text), properties=[prop])
    assert not report.errors, [e.render() for _, e in report.errors]
    return report.results[0]


def test_model_size() -> None:
    assert api.build(api.load(text=GAME)).model.num_states == 4  # s=2 is unreachable


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ("<<p1>> (P>=0.5 [ F s=3 ] & P>=0.5 [ F s=4 ])", True),
        ("<<p1>> (P>=0.6 [ F s=3 ] & P>=0.35 [ F s=4 ])", True),  # 0.95 <= 1
        ("<<p1>> (P>=0.8 [ F s=3 ] & P>=0.3 [ F s=4 ])", False),  # 1.1 > 1
        ("<<p1>> (P>=0.45 [ F s=3 ] & P>=0.55 [ F s=4 ])", False),  # beyond (0.5, 0.5)
        # p2 alone, against p1: e.g. after a p2 reaches (0.4, 0.6) but p1 picks e: (0.9, 0.1)
        ("<<p2>> (P>=0.2 [ F s=4 ] & P>=0 [ F s=3 ])", False),
    ],
)
def test_achievability(prop: str, expected: bool) -> None:
    r = _one(prop)
    assert r.kind.value == "boolean" and r.value is expected
    assert r.multi.decided is expected  # "true" is decided, "false" only not found
    if not expected:
        assert "not proven" in r.note


def test_numerical_is_a_lower_bound() -> None:
    r = _one("<<p1>> (Pmax=? [ F s=3 ] & P>=0.3 [ F s=4 ])")
    assert r.value == pytest.approx(0.7, abs=1e-9)  # on x + y = 1
    assert r.lower == r.value and math.isinf(r.upper) and "lower bound" in r.note


def test_pareto_front() -> None:
    front = _one("<<p1>> (Pmax=? [ F s=3 ] & Pmax=? [ F s=4 ])").front
    assert np.allclose(front.points, [[0.9, 0.1], [0.5, 0.5]], atol=1e-9)
    assert front.converged and len(front.corners) == 0 and math.isinf(front.precision)
    # reward 2 for a, after which p2 holds P(F s=3) to 0.4; else 0.9 with e
    front = _one('<<p1>> (R{"r"}max=? [ C ] & Pmax=? [ F s=3 ])').front
    assert np.allclose(front.points, [[2, 0.4], [0, 0.9]], atol=1e-9)
    # the grand coalition: every pure outcome lies on x + y = 1, from (0.9, 0.1) to (0.4, 0.6)
    front = _one("<<p1,p2>> (Pmax=? [ F s=3 ] & Pmax=? [ F s=4 ])").front
    assert np.allclose(front.points, [[0.9, 0.1], [0.4, 0.6]], atol=1e-9)


@pytest.mark.parametrize(
    ("prop", "words"),
    [
        ("<<p1>> (P<=0.5 [ F s=3 ] & P>=0.5 [ F s=4 ])", "maximises"),
        ('<<p1>> (R{"r"}>=1 [ F s=3 ])', "total rewards [C]"),
        ("<<p1>> (P>=0.1 [ F s=3 ] & P>=0.1 [ F s=4 ] & P>=0 [ F s=1 ])", "at most two"),
        ("<<p9>> (P>=0.5 [ F s=3 ])", "p9"),
        ("multi(Pmax=? [ F s=3 ])", "<<C>> (q1 & q2)"),
    ],
)
def test_outside_the_fragment(prop: str, words: str) -> None:
    report = api.check(api.load(text=GAME), properties=[prop])
    (error,) = [e for _, e in report.errors]
    text = error.render() if hasattr(error, "render") else str(error)
    assert words in text


def test_games_must_stop() -> None:
    root = Path(__file__).resolve().parents[2]
    report = api.check(api.load(root / "models" / "rover.smg"),
                       properties=['<<rover>> (P>=0.5 [ F "goal" ] & R{"steps"}>=1 [ C ])'])
    (error,) = [e for _, e in report.errors]
    assert "not stopping" in error.message and "Chen" in (error.hint or "")
