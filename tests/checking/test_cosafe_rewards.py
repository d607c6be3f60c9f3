"""R[co-safe LTL] collects reward until the product reaches acceptance, PRISM's way.

PRISM's rule (its regression files dtmc_rewards.pm.cosafety.props / mdp_rewards.nm.cosafety.props):
a state formula, the constant ``true`` included, holds at a position of the path, so it is
satisfied only by reading that position: ``R[X true]`` collects exactly the first step's reward,
``R[(X X true) U a]`` the steps until two steps after the first ``a``. Each expected number below
is the sum of the step rewards of this file's chain, by hand.
"""

from __future__ import annotations

import pytest

from posgmc import api

# s: 0 -> 1 -> 2 -> 3 (absorbing). Step rewards (state + action): s=0: 1 + 4 = 5; s=1: 20 + 0 = 20;
# s=2: 300; s=3: 0 (structure "r"); "q" adds 7000 in s=3. The mdp and smg variants may also wait
# at s=0, which costs 1 + 1000 and never helps a minimiser.
CHAIN = """
{kind}
{players}
module m
  s : [0..3] init 0;
  [go]   s<3 -> (s'=s+1);
  {extra}
  [stay] s=3 -> true;
endmodule
rewards "r"
  [wait] true : 1000;
  s=0 : 1;
  [go] s=0 : 4;
  s=1 : 20;
  s=2 : 300;
endrewards
rewards "q"
  [wait] true : 1000;
  s=0 : 1;
  [go] s=0 : 4;
  s=1 : 20;
  s=2 : 300;
  s=3 : 7000;
endrewards
"""

VARIANTS = {
    "dtmc": dict(kind="dtmc", players="", extra="[wait] false -> true;"),
    # an mdp whose second action is never better for Rmin: it loops at s=0 at a cost of 1001
    "mdp": dict(kind="mdp", players="", extra="[wait] s=0 -> true;"),
    "smg": dict(
        kind="smg", players="player p [go], [stay], [wait] endplayer", extra="[wait] s=0 -> true;"
    ),
}

CASES = [
    ('R{"r"}{dir}=? [ true ]', 0),
    ('R{"r"}{dir}=? [ F s=0 ]', 0),
    ('R{"r"}{dir}=? [ X true ]', 5),
    ('R{"r"}{dir}=? [ X X true ]', 25),
    ('R{"r"}{dir}=? [ X X X true ]', 325),
    ('R{"r"}{dir}=? [ X s>=0 ]', 5),
    ('R{"r"}{dir}=? [ !(X false) ]', 5),
    ('R{"r"}{dir}=? [ (X X true) U s=0 ]', 0),
    ('R{"r"}{dir}=? [ (X X true) U s=1 ]', 25),
    ('R{"r"}{dir}=? [ (X X true) U s=2 ]', 325),
    ('R{"q"}{dir}=? [ (X X true) U s=3 ]', 7325),
    ('R{"r"}{dir}=? [ s=0 | (X true) ]', 0),
    ('R{"r"}{dir}=? [ F (s=1 & (X s=2)) ]', 25),
    ('R{"r"}{dir}=? [ F (X s=2) ]', 25),
]


@pytest.mark.parametrize("variant", sorted(VARIANTS))
@pytest.mark.parametrize(("template", "expected"), CASES)
def test_cosafe_reward_collects_prisms_steps(variant: str, template: str, expected: float) -> None:
    text = CHAIN.format(**VARIANTS[variant])
    prop = template.replace("{dir}", "" if variant == "dtmc" else "min")
    if variant == "smg":
        prop = "<<p>> " + prop
    report = api.check(api.load(text=text), properties=[prop])
    assert not report.errors, report.errors[0][1].render()
    r = report.results[0]
    assert r.lower <= expected <= r.upper and r.upper - r.lower <= 1e-5


@pytest.mark.parametrize("prop", ['R{"r"}=? [ X X X false ]', 'R{"r"}=? [ !(X true) ]'])
def test_unsatisfiable_cosafe_reward_is_infinite(prop: str) -> None:
    report = api.check(api.load(text=CHAIN.format(**VARIANTS["dtmc"])), properties=[prop])
    assert report.results[0].value == float("inf")
