"""Exact ``R[F b]`` on dtmcs and mdps (``--exact``), by policy iteration over the rationals."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.compiler.options import BuildOptions

# dtmc: s=0 reaches s=1 with 1/2 per step, reward 1 per step: 2 steps expected (geometric).
DTMC = """dtmc
module m
  s : [0..2] init 0;
  [] s=0 -> 1/2:(s'=1) + 1/2:(s'=0);
  [] s>0 -> true;
endmodule
rewards true : 1; endrewards
"""

# mdp, by hand: in s=0, [a] pays 5 and reaches s=1; [b] pays 3 and reaches s=1 with 1/2 (else
# stays): 6 expected; [c] stays forever for free (never reaches s=1). Rmin = 5 (c is not
# counted: it never reaches the target, PRISM's rule), Rmax = infinity (c avoids the target).
MDP = """mdp
module m
  s : [0..1] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> 1/2:(s'=1) + 1/2:(s'=0);
  [c] s=0 -> (s'=0);
  [] s=1 -> true;
endmodule
rewards
  [a] true : 5;
  [b] true : 3;
endrewards
"""

MDP_NO_LOOP = MDP.replace("  [c] s=0 -> (s'=0);\n", "")


@pytest.mark.parametrize(
    ("model", "prop", "expected"),
    [
        (DTMC, "R=? [ F s=1 ]", Fraction(2)),
        (DTMC, "R=? [ F s=2 ]", math.inf),  # never reached
        (DTMC, "R>=2 [ F s=1 ]", True),
        (DTMC, "R<2 [ F s=1 ]", False),
        (MDP, "Rmin=? [ F s=1 ]", Fraction(5)),
        (MDP, "Rmax=? [ F s=1 ]", math.inf),
        (MDP_NO_LOOP, "Rmax=? [ F s=1 ]", Fraction(6)),
        (MDP_NO_LOOP, "Rmin=? [ F s=1 ]", Fraction(5)),
    ],
)
def test_exact_reach_rewards(model: str, prop: str, expected: object) -> None:
    session = api.load(text=model)
    built = api.build(session, options=BuildOptions(exact=True))
    (r,) = api.check(session, properties=[prop], built=built,
                     options=CheckOptions(exact=True)).results
    if isinstance(expected, bool):
        assert r.value is expected
    elif expected == math.inf:
        assert r.value == math.inf
    else:
        assert r.exact == expected
        # the interval engine's proven bounds agree
        (f,) = api.check(api.load(text=model), properties=[prop]).results
        assert f.lower <= expected <= f.upper
