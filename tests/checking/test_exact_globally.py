"""``P[ G a ]`` and ``P[ G<=k a ]`` in exact mode, as the complement of ``F !a`` with the
opposite optimum (PRISM's ``dtmc_pctl.pm.props`` under ``-exact``: ``P=? [ G<=4 s<2 ]`` = 1/16)."""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.compiler.options import BuildOptions

# dtmc: s=0 stays with 1/2, else moves to the absorbing s=1. By hand: P(G s=0) = 0,
# P(G<=k s=0) = (1/2)^k (k steps staying; the state at step 0 is s=0).
DTMC = (
    "dtmc\nmodule m\n  s : [0..1] init 0;\n"
    "  [] s=0 -> 1/2:(s'=0) + 1/2:(s'=1);\n  [] s=1 -> true;\nendmodule\n"
)
# mdp: in s=0 [a] stays, [b] moves to s=1. Pmax G s=0 = 1 (always a), Pmin = 0.
MDP = (
    "mdp\nmodule m\n  s : [0..1] init 0;\n"
    "  [a] s=0 -> (s'=0);\n  [b] s=0 -> (s'=1);\n  [] s=1 -> true;\nendmodule\n"
)


@pytest.mark.parametrize(
    ("model", "prop", "expected"),
    [
        (DTMC, "P=? [ G s=0 ]", Fraction(0)),
        (DTMC, "P=? [ G<=4 s=0 ]", Fraction(1, 16)),
        (DTMC, "P=? [ G<=0 s=0 ]", Fraction(1)),
        (MDP, "Pmax=? [ G s=0 ]", Fraction(1)),
        (MDP, "Pmin=? [ G s=0 ]", Fraction(0)),
        (MDP, "Pmin=? [ G<=3 s=0 ]", Fraction(0)),
    ],
)
def test_globally_in_exact_mode(model: str, prop: str, expected: Fraction) -> None:
    session = api.load(text=model)
    built = api.build(session, options=BuildOptions(exact=True))
    assert built.model.num_states == 2
    (r,) = api.check(
        session, properties=[prop], built=built, options=CheckOptions(exact=True)
    ).results
    assert r.exact == expected
