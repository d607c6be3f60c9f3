"""Policy iteration's values turned into proven bounds (posgmc/engines/certify.py).

References: the exact rational solver (``objectives.exact_rational_reach``, itself checked
against brute force in test_engine_random.py) and hand derivations.
"""

from __future__ import annotations

import os
from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import as_floats, small_models

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


def _rare(p: float, model_type: ModelType) -> ExplicitModel:
    """PRISM's ``bugfixes/export-precision/rare.nm`` shape: state 0 loops with 1 - p and reaches
    the target 1 with p (the floats as a PRISM model stores them: ``1 - p`` is rounded)."""
    return make_model(
        model_type,
        row_groups=[0, 1, 2],
        transitions=[[1.0 - p, p], [0.0, 1.0]],
        labels={"rare": [False, True]},
    )


def test_a_loop_left_with_1e_13_is_certified_exactly() -> None:
    """A count of 10^13 expected steps amplifies every float residual past any precision, and
    interval iteration would need ~10^13 steps: the certificate is redone in rationals, widened by
    the rounding of the model's numbers along the count. Reference (hand derivation): a reward p
    per step until the target gives p * (1/p) = 1 for the written model and
    p / (1 - fl(1 - p)) = 0.99968915... for the stored floats (``1 - p`` kept three digits of
    p); the bounds hold for both, in a few thousand steps, not converged to 1e-6 (no method on the
    stored floats can say more). Both for the mdp's Rmin and the dtmc's R."""
    p = 1e-13
    stored = Fraction(p) / (1 - Fraction(1.0 - p))
    assert abs(stored - Fraction(99968915, 10**8)) < Fraction(1, 10**8)
    for model_type in (ModelType.MDP, ModelType.DTMC):
        model = _rare(p, model_type)
        rare = model.label("rare")
        res = obj.expected_reach_reward(
            model, np.array([p, 1.0 - p]), rare, maximize=np.zeros(2, bool)
        )
        assert res.sound and res.iterations < 3_000 and not res.converged
        assert Fraction(res.lower[0]) <= min(stored, Fraction(1))
        assert max(stored, Fraction(1)) <= Fraction(res.upper[0])
        assert 0.99 < res.lower[0] and res.upper[0] < 1.01
        prob = obj.reach_probability(model, rare, maximize=np.ones(2, bool))
        assert prob.sound and prob.lower[0] <= 1.0 <= prob.upper[0]


def test_an_end_component_of_the_minimiser_gets_no_certificate() -> None:
    """R[F] counts a path that never reaches the target as infinite: a minimiser that may idle
    forever at no cost in state 0 must still leave through state 1 (reward 2) to the target 2,
    so Rmin = 2, while the least fixpoint of the Bellman operator is 0 (idle). The idle loop is
    an end component: the step counts are infinite and no certificate, exact or not, may answer
    (hand derivation)."""
    model = make_model(
        ModelType.MDP,
        row_groups=[0, 2, 3, 4],
        transitions=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]],
        labels={"t": [False, False, True]},
    )
    for options in (SolverOptions(), POLICY):
        res = obj.expected_reach_reward(
            model, np.array([0.0, 0.0, 2.0, 0.0]), model.label("t"), maximize=np.zeros(3, bool),
            options=options,
        )
        assert res.sound and res.lower[0] <= 2.0 <= res.upper[0]
        assert res.upper[0] - res.lower[0] <= 2e-6


def _stiff_near_tie(p_leave: float, gap: float, lead: int = 30) -> ExplicitModel:
    """``lead`` states in a line (state i moves to i + 1 surely) end in the stiff state
    ``s = lead``: its first choice reaches the goal (``s + 2``) at once with 1/2 (else the sink,
    ``s + 3``); its second moves to ``s + 1`` (which returns to s surely) with probability
    1 - p_leave and otherwise reaches the goal with 1/2 - ``gap`` (else the sink), worth 1/2 - gap
    whatever p_leave. The line makes the system too large for the exact certificate, the
    two-state loop one strongly connected component that the topological solver iterates."""
    s = lead
    n = lead + 4
    rows: list[list[float]] = []
    for i in range(lead):
        rows.append([1.0 if j == i + 1 else 0.0 for j in range(n)])
    direct = [0.0] * n
    direct[s + 2], direct[s + 3] = 0.5, 0.5
    loop = [0.0] * n
    loop[s + 1] = 1.0 - p_leave
    loop[s + 2], loop[s + 3] = (0.5 - gap) * p_leave, (0.5 + gap) * p_leave
    back = [0.0] * n
    back[s] = 1.0
    goal = [0.0] * n
    goal[s + 2] = 1.0
    sink = [0.0] * n
    sink[s + 3] = 1.0
    rows += [direct, loop, back, goal, sink]
    return make_model(
        ModelType.MDP,
        row_groups=list(range(lead + 1)) + [lead + 2, lead + 3, lead + 4, lead + 5],
        transitions=rows,
        labels={"goal": [i == s + 2 for i in range(n)]},
    )


def test_a_gain_below_the_switching_tolerance_is_certified() -> None:
    """Pmin of the goal in ``_stiff_near_tie(1e-6, 1e-4)`` is 1/2 - 1e-4 = 0.4999 in the line
    and the loop (hand derivation: the minimiser loops, since the loop is left surely and then
    reaches the goal with 1/2 - 1e-4, against 1/2 directly). Value iteration from below needs
    about 10^6 steps per digit here, so the stiff check's first 2,000 steps leave the loop's
    bounds wide and the direct choice looks better; policy iteration starts there and keeps it
    (x = 1/2): looping gains only p_leave * 1e-4 = 1e-10 in one step, below its switching
    tolerance (1e-10 relative: 1.5e-10 here). The certificate multiplies that leftover by the
    loop's 10^6 expected steps (1e-4, past the precision), so the iteration cap of 20,000 steps
    used to leave the interval unconverged. The certificate's ulp-level switches prove the
    value with one more solve; the upper bound below 1/2 shows the loop was taken."""
    gap = 1e-4
    model = _stiff_near_tie(1e-6, gap)
    assert (model.num_states, model.num_choices) == (34, 35)
    value = 0.5 - gap
    goal = model.label("goal")
    options = SolverOptions(max_iterations=20_000)
    res = obj.reach_probability(model, goal, maximize=np.zeros(34, bool), options=options)
    assert res.sound and res.converged and res.iterations < 3_000
    assert np.all(res.lower[:32] <= value) and np.all(value <= res.upper[:32])
    assert res.upper[0] < 0.5 and res.upper[0] - res.lower[0] <= 2e-6
