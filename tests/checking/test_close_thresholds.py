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
