"""Huge step bounds stop at the iteration's exact fixpoint (F<=10^20 must not run
for ever); the result is bit for bit what all the steps would give."""

from __future__ import annotations

import time

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines.graph import structure_of
from posgmc.engines.stepped import bellman_steps
from posgmc.engines.system import bellman, build_system
from posgmc.model.explicit import make_model
from posgmc.syntax.ast import ModelType


def _loop_chain():  # type: ignore[no-untyped-def]
    """0 -> goal with 1/2, else back to 0: P(F<=k goal) = 1 - 2^-k, which reaches 1.0 in floats."""
    T = np.array([[0.5, 0.5], [0.0, 1.0]])
    return make_model(ModelType.DTMC, [0, 1, 2], T, labels={"goal": np.array([False, True])})


def test_huge_bound_finishes_and_equals_the_limit() -> None:
    m = _loop_chain()
    goal = m.label("goal")
    started = time.perf_counter()
    r = obj.bounded_reach_probability(m, goal, steps=10**20, maximize=np.ones(2, bool))
    assert time.perf_counter() - started < 5  # generous: a handful of steps are needed
    assert r.values[0] == 1.0 and r.iterations < 100  # 1 - 2^-k rounds to 1.0 for k >= 54
    r10 = obj.bounded_reach_probability(m, goal, steps=10, maximize=np.ones(2, bool))
    assert r10.values[0] == 1 - 2**-10


def test_huge_cumulative_and_instantaneous_bounds_settle() -> None:
    m = _loop_chain()
    r = np.array([1.0, 0.0])  # one unit per step spent in state 0: expected total 2
    c = obj.cumulative_reward(m, r, steps=2**63, maximize=np.ones(2, bool))
    assert abs(c.values[0] - 2.0) < 1e-12
    i = obj.instantaneous_reward(m, np.array([1.0, 0.0]), steps=10**18, maximize=np.ones(2, bool))
    assert i.values[0] == 0.0


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 200))
def test_early_stop_is_bit_identical_to_all_steps(seed: int, steps: int) -> None:
    rng = np.random.default_rng(seed)
    S = int(rng.integers(2, 6))
    T = rng.random((S, S)) * (rng.random((S, S)) < 0.6)
    T[np.arange(S), rng.integers(0, S, S)] += 0.1
    T /= T.sum(axis=1, keepdims=True)
    m = make_model(ModelType.DTMC, np.arange(S + 1), T)
    sys = build_system(structure_of(m), np.ones(S, bool), maximize=np.ones(S, bool),
                       choice_offset=rng.random(S))
    start = rng.random(S)
    full = start.copy()
    for _ in range(steps):
        full = bellman(sys, full)
    early, done = bellman_steps(sys, start.copy(), steps)
    assert done <= steps and np.array_equal(early, full)
