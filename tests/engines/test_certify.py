"""Policy iteration's values turned into proven bounds (posgmc/engines/certify.py).

References: the exact rational solver (``objectives.exact_rational_reach``, itself checked
against brute force in test_engine_random.py) and hand derivations.
"""

from __future__ import annotations

import os
from fractions import Fraction

import numpy as np
from engine_models import as_floats, small_models
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType

SETTINGS = settings(
    max_examples=int(os.environ.get("POSGMC_EXAMPLES", "60")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
POLICY = SolverOptions(method=Method.POLICY)


@SETTINGS
@given(small_models(), st.data())
def test_policy_bounds_enclose_the_exact_value(model: ExplicitModel, data: st.DataObject) -> None:
    S = model.num_states
    target = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)), dtype=bool)
    if model.model_type is ModelType.SMG:
        maximize = (model.state_players == 0) ^ data.draw(st.booleans())
    else:
        maximize = np.full(S, data.draw(st.booleans()))
    exact = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
    res = obj.reach_probability(model, target, maximize=maximize, options=POLICY)
    assert res.sound and res.converged
    assert np.all(res.lower <= exact + 1e-12) and np.all(exact <= res.upper + 1e-12)
    assert np.all(res.lower <= res.values) and np.all(res.values <= res.upper)
    assert np.all(res.upper - res.lower <= 2e-6)


def _stiff_chain(p_leave: float) -> ExplicitModel:
    """State 0 loops with probability 1 - p_leave and otherwise reaches goal (1) with 0.3 or the
    sink (2) with 0.7: P(F goal) = 0.3 exactly, whatever p_leave. A maximiser in state 0 may
    also take a second choice reaching the goal with 0.25 at once."""
    stay = 1.0 - p_leave
    return make_model(
        ModelType.MDP,
        row_groups=[0, 2, 3, 4],
        transitions=[[stay, 0.3 * p_leave, 0.7 * p_leave], [0.0, 0.25, 0.75], [0, 1, 0], [0, 0, 1]],
        labels={"goal": [False, True, False]},
    )


def test_a_stiff_loop_is_certified_in_a_few_solves() -> None:
    """Interval iteration needs about 10^4 steps per digit here; the certificate needs none, and
    its bounds enclose the exact values (hand derivation: the loop is left surely, so looping
    gives 0.3; the other choice gives 0.25: Pmax = 0.3, Pmin = 0.25)."""
    model = _stiff_chain(1e-4)
    goal = model.label("goal")
    for maximize, value in ((True, 0.3), (False, 0.25)):
        res = obj.reach_probability(model, goal, maximize=np.full(3, maximize), options=POLICY)
        assert res.sound and res.iterations <= 5
        assert res.lower[0] <= value <= res.upper[0]
        assert res.upper[0] - res.lower[0] < 1e-9


def test_end_components_of_the_maximiser_still_give_bounds() -> None:
    """A maximiser that may idle forever in state 0 (a self-loop choice) or leave to the goal
    with 1/2: Pmax = 1/2, Pmin = 0 (it idles). Idling is an end component: the lower certificate
    uses the maximiser's own (leaving) choice, the upper one the pre-fixpoint check."""
    model = make_model(
        ModelType.MDP,
        row_groups=[0, 2, 3, 4],
        transitions=[[1, 0, 0], [0, 0.5, 0.5], [0, 1, 0], [0, 0, 1]],
        labels={"goal": [False, True, False]},
    )
    goal = model.label("goal")
    res = obj.reach_probability(model, goal, maximize=np.full(3, True), options=POLICY)
    assert res.sound and res.lower[0] <= 0.5 <= res.upper[0] and res.upper[0] - res.lower[0] < 1e-9
    low = obj.reach_probability(model, goal, maximize=np.full(3, False), options=POLICY)
    assert low.sound and low.lower[0] <= 0.0 <= low.upper[0] < 1e-9


def test_rational_reference_of_the_stiff_chain() -> None:
    model = _stiff_chain(1e-4)
    exact = obj.exact_rational_reach(model, model.label("goal"), maximize=np.full(3, True))
    # the float model's leave probabilities are doubles: the exact value is within ulps of 0.3
    assert abs(exact[0] - Fraction(3, 10)) < Fraction(1, 10**12)


def test_stiff_interval_iteration_switches_to_the_certificate() -> None:
    """The default (interval) method on a loop left with probability 1e-6: value iteration from
    below would need millions of steps; after its first 2,000 the certificate takes over."""
    model = _stiff_chain(1e-6)
    goal = model.label("goal")
    res = obj.reach_probability(model, goal, maximize=np.full(3, True))
    assert res.sound and res.converged and res.iterations < 3_000
    assert res.lower[0] <= 0.3 <= res.upper[0] and res.upper[0] - res.lower[0] <= 2e-6
