"""Optimistic interval iteration must not accept an upper bound that is not one, however slowly
the system contracts (PRISM's ``bugfixes/export-precision/rare.nm``, where posgmc reported
``Rmin=? [F rare]`` in [2e-13, 1e-6] as sound although the value is 1).

By hand: from ``!rare`` each step collects p and reaches ``rare`` with probability p, so the
expected reward until ``rare`` is p * (1/p) = 1 (PRISM's RESULT: ``0.99 <= Rmin=? [F rare]`` is
true)."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.engines.options import SolverOptions

MODEL = """
{kind}
const double p = {p};
module rare
  rare : bool init false;
  [tick] !rare -> p : (rare'=true) + 1-p : true;
  [tick] rare -> true;
endmodule
rewards
  rare : 1-p;
  !rare : p;
endrewards
"""


@pytest.mark.parametrize("kind", ["dtmc", "mdp"])
@pytest.mark.parametrize("p", ["1e-13", "1e-9"])
def test_bounds_hold_under_a_slow_contraction(kind: str, p: str) -> None:
    session = api.load(text=MODEL.format(kind=kind, p=p))
    assert api.build(session).model.num_states == 2
    options = CheckOptions(solver=SolverOptions(max_iterations=20_000))
    prop = "R=? [ F rare ]" if kind == "dtmc" else "Rmin=? [ F rare ]"
    (r,) = api.check(session, properties=[prop], options=options).results
    # whatever the iteration reached, the reported bounds hold -- for the model as written: the
    # stored 1-p is rounded, and the stored model's value is 0.99969 at p = 1e-13
    assert r.lower <= 1.0 <= r.upper, (r.lower, r.upper)
    # PRISM's RESULT line is decided on those bounds, at once (the certificate, not 10^13 steps)
    threshold = "0.99 <= " + prop
    (t,) = api.check(session, properties=[threshold], options=options).results
    assert t.value is True and t.converged and t.sound
