"""CTL's ``A [ ... ]`` and ``E [ ... ]`` over the model's graph (PRISM's ``NonProbModelChecker``):
probabilities do not matter, only which states can follow which, through any choice."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.errors import UnsupportedError

# dtmc: s=0 stays with 0.9 or moves to s=1 (0.1); s=1 moves to s=2 "goal" or back to s=0; s=2
# absorbs. By hand: every state can reach s=2 (E F), but the path staying in s=0 forever exists,
# so A F goal fails in s=0 and s=1 although P(F goal) = 1 everywhere.
DTMC = """
dtmc
module m
  s : [0..2] init 0;
  [] s=0 -> 0.9:(s'=0) + 0.1:(s'=1);
  [] s=1 -> 0.5:(s'=2) + 0.5:(s'=0);
  [] s=2 -> true;
endmodule
label "goal" = s=2;
"""

# mdp: in s=0 choice [a] goes to s=1 (a dead end), [b] to s=2 ("goal", absorbing).
MDP = """
mdp
module m
  s : [0..2] init 0;
  [a] s=0 -> (s'=1);
  [b] s=0 -> (s'=2);
  [] s>0 -> true;
endmodule
label "goal" = s=2;
"""


@pytest.mark.parametrize(
    ("model", "prop", "expected"),
    [
        (DTMC, 'E [ F "goal" ]', True),
        (DTMC, 'A [ F "goal" ]', False),  # the path 0 0 0 ... never reaches it
        (DTMC, 'P>=1 [ F "goal" ]', True),  # ... yet with probability 1 it does
        (DTMC, 'E [ G s=0 ]', True),
        (DTMC, 'A [ G s<=2 ]', True),
        (DTMC, 'A [ X s<=1 ]', True),  # from s=0 both successors satisfy s<=1
        (DTMC, 'E [ X "goal" ]', False),
        (DTMC, 'A [ s<2 U "goal" ]', False),
        (DTMC, 'A [ s<2 W "goal" ]', True),  # weak: staying below 2 forever is fine
        (DTMC, 'E [ "goal" R s<2 ]', True),  # s<2 may hold forever
        (DTMC, 'A [ "goal" R s<2 ]', False),
        (DTMC, 'filter(count, A [ F "goal" ])', 1),  # only s=2
        (DTMC, 'filter(forall, E [ F "goal" ])', True),
        (MDP, 'E [ F "goal" ]', True),  # choice [b]
        (MDP, 'A [ F "goal" ]', False),  # choice [a]
        (MDP, 'E [ X A [ G s=1 ] ]', True),  # nested
        (MDP, 'A [ X (s>0) ]', True),
        (MDP, 'E [ s=0 ]', True),  # a state formula under E is itself
        # LTL under A/E (PRISM's checkExistsLTL: some path of the graph; A = !E !), by hand:
        (DTMC, 'A [ G F "goal" ]', False),  # the path 0 0 0 ...
        (DTMC, 'E [ (F s=1) & (F s=2) ]', True),  # 0 1 2 2 ...
        (DTMC, 'E [ G F s=0 ]', True),
        (DTMC, 'E [ (G F s=0) & (G F s=1) ]', True),  # 0 1 0 1 ...
        (DTMC, 'A [ F G s=0 ]', False),  # 0 1 2 2 ...
        # a path that stays in {0, 1} visits 0 infinitely often (s=1 never loops on itself)
        (DTMC, 'A [ (G F s=0) | F "goal" ]', True),
        (DTMC, 'A [ G (s=1 => X (s!=1)) ]', True),
        (DTMC, 'filter(count, E [ G F s=1 ])', 2),  # s=0 and s=1
        (MDP, 'E [ F G "goal" ]', True),  # choice [b]
        (MDP, 'A [ F G "goal" ]', False),  # choice [a]
        (MDP, 'A [ F G (s>0) ]', True),
        (MDP, 'E [ G F s=0 ]', False),  # s=0 is left for good at the first step
    ],
)
def test_ctl(model: str, prop: str, expected: bool | int) -> None:
    session = api.load(text=model)
    assert api.build(session).model.num_states == 3
    report = api.check(session, properties=[prop])
    assert not report.errors, report.errors[0][1].render()
    assert report.results[0].value == expected
    if isinstance(expected, bool):
        assert report.results[0].value is expected


@pytest.mark.parametrize("prop", ['E [ F<=3 "goal" ]', 'A [ G F<=2 "goal" ]'])
def test_step_bounds_under_a_and_e_are_refused(prop: str) -> None:
    """PRISM refuses them too ("Time-bounded operators not supported in LTL")."""
    report = api.check(api.load(text=DTMC), properties=[prop])
    (_, err), = report.errors
    assert isinstance(err, UnsupportedError)


def test_a_and_e_stay_names_without_a_bracket() -> None:
    text = DTMC.replace("s : [0..2] init 0;", "s : [0..2] init 0;\n  E : bool init true;")
    report = api.check(api.load(text=text), properties=["E", "E & A [ G E ]"])
    assert [r.value for r in report.results] == [True, True]
