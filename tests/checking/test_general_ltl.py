"""LTL that is neither co-safe nor safety (``G F``, ``F G``, ...) inside ``P``: dtmcs and mdps
through the limit-deterministic automaton (:mod:`posgmc.engines.ltl.ldba`), games refused by
name. Every expected value is derived by hand next to its model."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.errors import UnsupportedError

# mdp: in x=0, [a] goes to x=1 or x=2 (1/2 each), [b] to x=3; x=1 returns to x=0; x=2 absorbs;
# x=3 moves to x=1 or stays (1/2 each). By hand: always [b] visits x=1 infinitely often with
# probability 1 (x=3 is left almost surely); always [a] ends in x=2 with probability 1.
MDP = """
mdp
module m
  x : [0..3] init 0;
  [a] x=0 -> 0.5:(x'=1) + 0.5:(x'=2);
  [b] x=0 -> (x'=3);
  [] x=1 -> (x'=0);
  [] x=2 -> true;
  [] x=3 -> 0.5:(x'=1) + 0.5:(x'=3);
endmodule
label "one" = x=1;
"""

# dtmc: s=0 moves to s=1 or s=2 (1/2 each); s=1 and s=4 alternate forever; s=2 absorbs.
DTMC = """
dtmc
module m
  s : [0..4] init 0;
  [] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [] s=1 -> (s'=4);
  [] s=2 -> true;
  [] s=4 -> (s'=1);
endmodule
"""

SMG = """
smg
player p1 m endplayer
module m
  x : [0..1] init 0;
  [] x=0 -> (x'=1);
  [] x=1 -> (x'=0);
endmodule
"""


def values(model: str, *props: str) -> list[object]:
    report = api.check(api.load(text=model), properties=list(props))
    assert not report.errors, report.errors[0][1].render()
    return [r.value for r in report.results]


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ('Pmax=? [ G F "one" ]', 1.0),
        ('Pmin=? [ G F "one" ]', 0.0),
        ('Pmax=? [ F G !"one" ]', 1.0),
        ('Pmin=? [ F G !"one" ]', 0.0),
        ("Pmax=? [ G F x=3 ]", 1.0),
        ("Pmin=? [ G (x=0 => F (x=1)) ]", 0.0),
        ("Pmax=? [ G (x=0 => F (x=1)) ]", 1.0),
        # [a] once: 1/2 to x=1 then back, 1/2 absorbed; the best is [b] forever
        ('Pmax=? [ (G F "one") & (G F x=3) ]', 1.0),
        ('Pmin=? [ (G F "one") | (F G (x=2)) ]', 1.0),  # every scheduler does one or the other
    ],
)
def test_mdp_by_hand(prop: str, expected: float) -> None:
    assert api.build(api.load(text=MDP)).model.num_states == 4
    (value,) = values(MDP, prop)
    assert value == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ("P=? [ G F s=4 ]", 0.5),
        ("P=? [ (G F s=4) & (F G s=2) ]", 0.0),
        ("P=? [ (G F s=1) | (F G s=2) ]", 1.0),
        ("P=? [ X (G F s=1) ]", 0.5),
        ("P>=0.5 [ G F s=1 ]", True),
        ("P>0.5 [ G F s=1 ]", False),
        # nested: in every state but s=0 the chance is 0 or 1; s=0 itself has 1/2
        ("filter(count, P>=1 [ G F s=4 ])", 2),
    ],
)
def test_dtmc_by_hand(prop: str, expected: object) -> None:
    assert api.build(api.load(text=DTMC)).model.num_states == 4
    (value,) = values(DTMC, prop)
    if isinstance(expected, float):
        assert value == pytest.approx(expected, abs=1e-6)
    else:
        assert value == expected


def test_bounds_bracket_the_value() -> None:
    report = api.check(api.load(text=DTMC), properties=["P=? [ G F s=4 ]"])
    r = report.results[0]
    assert r.sound and r.lower <= 0.5 <= r.upper
    assert "LDBA" in r.method


def test_games_refuse_it_by_name() -> None:
    report = api.check(api.load(text=SMG), properties=["<<p1>> Pmax=? [ G F x=1 ]"])
    ((_, err),) = report.errors
    assert isinstance(err, UnsupportedError)
    assert "not supported on an SMG" in err.message and "co-safe" in err.message
    # the co-safe fragment and its negation are still answered on games
    assert values(SMG, "<<p1>> Pmax=? [ F x=1 ]", "<<p1>> Pmax=? [ G x=0 ]") == [1.0, 0.0]


def test_rewards_still_need_a_cosafe_formula() -> None:
    text = DTMC + 'rewards true : 1; endrewards\n'
    report = api.check(api.load(text=text), properties=["R=? [ G F s=4 ]"])
    ((_, err),) = report.errors
    assert isinstance(err, UnsupportedError) and "co-safe" in err.message
