"""Optimistic interval iteration with deflated end components (:mod:`posgmc.engines.iteration`).

The game below has the shape of PAYNT's attacker-one-defender under a fixed deterministic defence
(``tests/strategies/test_verify.py`` checks that product): the defender's states keep one choice
each and randomise between the attacker's states, so the attacker (the maximiser) has end
components that mix both players' states; deflation brings their upper bound down to the best exit,
which here is exactly representable. The lower iterate may sit a few ulps above that value (every
step rounds, and the lower phase updates its row values incrementally), and verification must
not take that rounding for a guess below the value.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from posgmc.engines import iteration as it
from posgmc.engines import objectives as obj
from posgmc.engines.graph import structure_of
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.system import System, build_system
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType

# A, B: the maximiser (player "attacker"); M1, M2, C and the chain P, Q, R: single-choice
# minimiser states (the fixed defender); then goal and sink
A, B, M1, M2, C, P, Q, R, GOAL, SINK = range(10)
MAXIMIZE = np.zeros(10, dtype=bool)
MAXIMIZE[[A, B]] = True
TARGET = np.zeros(10, dtype=bool)
TARGET[GOAL] = True
UNKNOWN = 8
VALUE = np.array([0.84, 0.84, 0.84, 0.84, 0.2, 0.5, 0.5, 0.5])
"""By hand: C = 0.2, P = Q = R = 0.5; in {A, B, M1, M2} the minimiser has no choice, so the
maximiser roams it and leaves by its best exit, B's: 0.8 + 0.2 * C = 0.84 (exact_rational_reach
below agrees: 21/25)."""


def _mixing_end_component() -> ExplicitModel:
    """A: stay -> M1, leave -> 0.8 goal + 0.2 sink; B: stay -> M2, leave -> 0.8 goal + 0.2 C;
    M1: 0.2 A + 0.8 B; M2: 0.8 A + 0.2 B; C: 0.2 goal + 0.8 sink; P -> Q -> R, R: 0.5 goal +
    0.5 sink (a chain apart, along which a guessed upper bound takes steps to settle); goal, sink
    absorbing. 10 states, 12 choices, 18 transitions."""
    T = np.zeros((12, 10))
    T[0, M1] = 1.0
    T[1, GOAL], T[1, SINK] = 0.8, 0.2
    T[2, M2] = 1.0
    T[3, GOAL], T[3, C] = 0.8, 0.2
    T[4, A], T[4, B] = 0.2, 0.8
    T[5, A], T[5, B] = 0.8, 0.2
    T[6, GOAL], T[6, SINK] = 0.2, 0.8
    T[7, Q] = 1.0
    T[8, R] = 1.0
    T[9, GOAL], T[9, SINK] = 0.5, 0.5
    T[10, GOAL] = 1.0
    T[11, SINK] = 1.0
    return make_model(
        ModelType.SMG,
        [0, 2, 4, 5, 6, 7, 8, 9, 10, 11, 12],
        T,
        state_players=MAXIMIZE.astype(np.int64),
        player_names=("defender", "attacker"),
    )


def _system(model: ExplicitModel) -> System:
    unknown = np.arange(10) < UNKNOWN
    return build_system(
        structure_of(model), unknown, maximize=MAXIMIZE, fixed=TARGET.astype(np.float64)
    )


def test_mixing_end_component_sizes() -> None:
    m = _mixing_end_component()
    assert (m.num_states, m.num_choices, m.num_transitions) == (10, 12, 18)
    sys = _system(m)
    assert (sys.n, sys.m, sys.num_max) == (8, 10, 2)
    family = it._family(sys, np.ones(sys.m, dtype=bool), it.EndComponents.DEFLATE)
    assert family is not None and family.num == 1
    # the one end component holds both players' states: A, B, M1, M2 (not C)
    assert sorted(sys.states[family.states].tolist()) == [A, B, M1, M2]


@pytest.mark.parametrize("method", [Method.INTERVAL, Method.POLICY, Method.EXACT])
def test_mixing_end_component_converges(method: Method) -> None:
    m = _mixing_end_component()
    res = obj.reach_probability(
        m, TARGET, maximize=MAXIMIZE, options=SolverOptions(method=method)
    )
    assert res.converged and res.sound
    assert np.all(res.lower[:UNKNOWN] <= VALUE) and np.all(res.upper[:UNKNOWN] >= VALUE)
    assert np.all(res.upper[:UNKNOWN] - res.lower[:UNKNOWN] <= 2e-6)
    assert obj.exact_rational_reach(m, TARGET, maximize=MAXIMIZE)[:UNKNOWN] == (
        [Fraction(21, 25)] * 4 + [Fraction(1, 5)] + [Fraction(1, 2)] * 3
    )


def _ulps_above(x: np.ndarray, k: int) -> np.ndarray:
    out = x.copy()
    for _ in range(k):
        out = np.nextafter(out, np.inf)
    return out


@settings(max_examples=30, deadline=None)
@given(ulps=st.integers(min_value=0, max_value=1000))
@example(ulps=56)  # about the 6e-15 seen on the product
def test_a_lower_bound_rounded_above_the_value_does_not_fail_the_guess(ulps: int) -> None:
    """The product's failure: deflation puts the upper iterate of the end component exactly on
    its value (the best exit, 0.84, from the second step on) while the lower iterate is some ulps
    above it, and elsewhere (the chain, guessed with margins that grow along it) the guess is not
    a pre-fixpoint yet. The crossing is rounding, not a guess below the value: the guess must
    verify (with a crossing tolerance of a few ulps every guess failed, and the upper bound stayed
    at 1)."""
    sys = _system(_mixing_end_component())
    family = it._family(sys, np.ones(sys.m, dtype=bool), it.EndComponents.DEFLATE)
    treatment = it._Treatment(it.EndComponents.DEFLATE, family=family, deflating=True)
    value = VALUE[sys.states]
    lower = _ulps_above(value, ulps)
    margin = np.full(10, 1e-6)
    margin[[Q, R]] = 1e-5, 1e-4
    upper = value + margin[sys.states]
    n = sys.n
    run = it._Run(
        X=np.stack([lower, upper], axis=1),
        Xn=np.empty((n, 2)),
        Y=np.empty((sys.m, 2)),
        T=np.empty((n, 2)),
        proven_upper=np.ones(n),
    )
    it._verify(sys, SolverOptions(method=Method.INTERVAL), treatment, run, budget=16)
    assert run.verified and run.converged
    bounds = it._final_bounds(run, run.X[:, 0], 1.0, treatment)
    assert np.all(bounds.lower <= value) and np.all(bounds.upper >= value)
    assert np.all(bounds.upper - bounds.lower <= 2e-6)
