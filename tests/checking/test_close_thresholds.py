"""A threshold within the solver's precision of the value is decided, not refused (PRISM's
``functionality/verify/close_bounds.prism.props`` expects ``Error "accuracy"`` from its
floating-point engines there; posgmc refines to an exact solve, and answers as PRISM's
``-exact`` mode does, whose RESULT in the same file is ``true``)."""

from __future__ import annotations

import pytest

from posgmc import api

# s=0 picks d=1..6 uniformly (by hand: P(F d=6) = 1/6 exactly).
MODEL = """
dtmc
module die
  d : [0..6] init 0;
  [] d=0 -> 1/6:(d'=1) + 1/6:(d'=2) + 1/6:(d'=3) + 1/6:(d'=4) + 1/6:(d'=5) + 1/6:(d'=6);
  [] d>0 -> true;
endmodule
"""


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ("P>=0.1666666666 [ F d=6 ]", True),  # 1/6 = 0.16666666666... is above
        ("P>=1/6 [ F d=6 ]", True),  # equal
        ("P>0.1666666667 [ F d=6 ]", False),
    ],
)
def test_close_thresholds_are_decided_exactly(prop: str, expected: bool) -> None:
    session = api.load(text=MODEL)
    assert api.build(session).model.num_states == 7
    (r,) = api.check(session, properties=[prop]).results
    assert r.value is expected and r.sound


# by hand: s=0 moves to s=1 with p = 1/3, else to s=2: P(F s=1) = 1/3 exactly
CHAIN = """
dtmc
const double p = 1/3;
module m
  s : [0..2] init 0;
  [] s=0 -> p:(s'=1) + 1-p:(s'=2);
  [] s>0 -> true;
endmodule
"""


@pytest.mark.parametrize(
    ("op", "expected"), [(">=", True), (">", False), ("<=", True), ("<", False)]
)
def test_every_comparison_takes_the_same_exact_path(op: str, expected: bool) -> None:
    session = api.load(text=CHAIN)
    assert api.build(session).model.num_states == 3
    (r,) = api.check(session, properties=[f"P{op}1/3 [ F s=1 ]"]).results
    assert r.value is expected and r.sound and r.method == "exact (rational)"


# the 4-state game of the compatibility issue: player a goes (or waits forever), then b picks
# left (to the goal) or right (one more state). By hand, with cost 1 in s=0 and 2 in s=1, s=2:
# <<a>> Rmin = 1 + 0.5 * (2 + 2) + 0.5 * 2 = 4 (b takes right); <<a,b>> Rmin = 1 + 1 + 1 = 3
GAME = """
smg
player a  [go], [wait] endplayer
player b  [left], [right] endplayer
module m
  s : [0..3] init 0;
  [go]    s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [wait]  s=0 -> (s'=0);
  [left]  s=1 -> (s'=3);
  [right] s=1 -> (s'=2);
  [] s=2 -> (s'=3);
  [] s=3 -> true;
endmodule
label "done" = s=3;
rewards "cost" s=1 : 2; s=2 : 2; s=0 : 1; endrewards
"""


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ('<<a>> R{"cost"}<=4 [ F "done" ]', True),
        ('<<a>> R{"cost"}<4 [ F "done" ]', False),
        ('<<a,b>> R{"cost"}<=3 [ F "done" ]', True),
        ('<<a,b>> R{"cost"}<3 [ F "done" ]', False),
        ('<<b>> R{"cost"}>=4 [ F "done" ]', True),  # b maximises, a minimises: the same 4
        ('<<b>> R{"cost"}>4 [ F "done" ]', False),
        ('<<a>> P>=1/2 [ F s=1 ]', True),  # a goes; s=1 is reached with 1/2
        ('<<a>> P>1/2 [ F s=1 ]', False),
    ],
)
def test_a_game_threshold_equal_to_the_value_is_decided(prop: str, expected: bool) -> None:
    session = api.load(text=GAME)
    assert api.build(session).model.num_states == 4
    (r,) = api.check(session, properties=[prop]).results
    assert r.value is expected and r.sound and r.method == "exact (rational)"
