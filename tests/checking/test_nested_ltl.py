"""Queries nested in LTL formulas are evaluated in every state (PRISM's
supersimple.pm.boundedltl.props): a product that followed only the initial states would leave a
nested query NaN, i.e. false, everywhere else."""

from __future__ import annotations

import pytest

from posgmc import api

# s=0 moves to s=1 ("a") with 0.7 and to s=2 with 0.3; both then stay. By hand: P>0 [X F "a"]
# holds in s=0 (0.7) and s=1 (1), not in s=2; from s=0 any F/X of it holds with 0.7.
MODEL = """
dtmc
module m
  s : [0..2] init 0;
  [] s=0 -> 0.7 : (s'=1) + 0.3 : (s'=2);
  [] s>0 -> true;
endmodule
label "a" = s=1;
"""


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ('P=? [ F>=1 P>0 [ X F "a" ] ]', 0.7),
        ('P>0.5 [ F>=1 P>0 [ X F "a" ] ]', True),
        ('P>0.75 [ F>=1 P>0 [ X F "a" ] ]', False),
        ('P=? [ X F P>0 [ X F<=4 "a" ] ]', 0.7),
        ('P=? [ X F<=1 P>0 [ X F "a" ] ]', 0.7),
        ('P=? [ X (P>=1 [ X "a" ]) ]', 0.7),
        ('P=? [ G<=3 P>0 [ X F "a" ] ]', 0.7),
        # the three forms PRISM refuses ("Error: not supported", no timed LTL in PRISM); their
        # meaning is defined (the inner query is a state formula) and posgmc answers them.
        # By hand: P>0 [ X F<=1 "a" ] holds in s=0 and s=1, so X F of it has 0.7 from s=0.
        ('P=? [ X F P>0 [ X F<=1 "a" ] ]', 0.7),
        ('P>0.5 [ X F P>0 [ X F<=4 "a" ] ]', True),
        ('P>0.5 [ X F<=1 P>0 [ X F "a" ] ]', True),
        ('P>0.5 [ X F P>0 [ X F<=1 "a" ] ]', True),
        ('P>0.75 [ X F P>0 [ X F<=1 "a" ] ]', False),
    ],
)
def test_nested_ltl_queries(prop: str, expected: float | bool) -> None:
    report = api.check(api.load(text=MODEL), properties=[prop])
    assert not report.errors, report.errors[0][1].render()
    r = report.results[0]
    if isinstance(expected, bool):
        assert r.value is expected
    else:
        assert r.lower <= expected <= r.upper and r.upper - r.lower < 1e-6
