"""Invariants on random small dtmcs, mdps and games (hypothesis).

Reference values: reachability from the exact rational solver (itself checked against brute force
over all memoryless deterministic profiles, which are optimal for reachability and total/reach
rewards in finite turn-based games); rewards by brute force in floating point.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import (
    as_floats,
    chain_reach,
    chain_reward,
    game_value,
    small_models,
)

SETTINGS = settings(
    max_examples=int(os.environ.get("POSGMC_EXAMPLES", "60")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
TOL = 1e-9


@st.composite
def problems(draw: st.DrawFn) -> tuple[ExplicitModel, np.ndarray, np.ndarray]:
    model = draw(small_models())
    S = model.num_states
    target = np.array(draw(st.lists(st.booleans(), min_size=S, max_size=S)), dtype=bool)
    if model.model_type is ModelType.SMG:
        flip = draw(st.booleans())
        maximize = (model.state_players == 0) ^ flip
    else:
        maximize = np.full(S, draw(st.booleans()))
    return model, target, maximize


def _strategy_rows(model: ExplicitModel, strategy: np.ndarray) -> np.ndarray:
    return np.where(strategy < 0, model.row_groups[:-1], strategy)


def test_rows_of_random_models_are_stochastic() -> None:
    @SETTINGS
    @given(small_models())
    def check(model: ExplicitModel) -> None:
        sums = np.asarray(model.transitions.sum(axis=1)).ravel()
        assert np.allclose(sums, 1.0, atol=0, rtol=0)

    check()


@SETTINGS
@given(problems(), st.booleans())
def test_reach_bounds_enclose_exact_value(problem: tuple, with_remain: bool) -> None:
    model, target, maximize = problem
    S = model.num_states
    remain = None
    if with_remain:
        remain = np.ones(S, dtype=bool)
        remain[::2] = False
    exact = obj.exact_rational_reach(model, target, remain=remain, maximize=maximize)
    ref = as_floats(exact)
    # the rational solver agrees with brute force over all memoryless profiles
    if remain is None:
        brute = game_value(model, maximize, lambda rows: chain_reach(model, rows, target))
        assert np.allclose(ref, brute, atol=1e-9)
    res = obj.reach_probability(model, target, remain=remain, maximize=maximize)
    assert res.sound and res.converged
    assert np.all(res.lower <= ref + TOL) and np.all(ref <= res.upper + TOL)
    assert np.all(res.upper - res.lower <= 2e-6 + TOL)
    for method in (Method.POLICY, Method.EXACT):
        r = obj.reach_probability(
            model, target, remain=remain, maximize=maximize, options=SolverOptions(method=method)
        )
        assert np.allclose(r.values, ref, atol=1e-9)
    r = obj.reach_probability(
        model, target, remain=remain, maximize=maximize, options=SolverOptions(method=Method.VALUE)
    )
    assert not r.sound
    assert np.all(r.values <= ref + TOL)  # value iteration from below


@SETTINGS
@given(problems())
def test_reach_strategy_attains_the_value(problem: tuple) -> None:
    model, target, maximize = problem
    ref = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
    for method, tol in ((Method.INTERVAL, 1e-4), (Method.EXACT, 1e-9)):
        res = obj.reach_probability(
            model, target, maximize=maximize, options=SolverOptions(method=method)
        )
        assert res.strategy is not None
        # the profile's value (exact rational evaluation of the induced chain) is the optimal value
        chain = obj.induced_chain(model, res.strategy)
        assert chain.num_states == model.num_states and chain.model_type is ModelType.DTMC
        got = as_floats(
            obj.exact_rational_reach(chain, target, maximize=np.ones(model.num_states, bool))
        )
        assert np.allclose(got, ref, atol=tol), (method, got, ref)
        assert np.allclose(got, chain_reach(model, _strategy_rows(model, res.strategy), target))


@st.composite
def reward_problems(draw: st.DrawFn) -> tuple[ExplicitModel, np.ndarray, np.ndarray, np.ndarray]:
    model, target, maximize = draw(problems())
    rewards = np.array(
        draw(
            st.lists(
                st.sampled_from([0.0, 0.0, 1.0, 2.0, 0.5]),
                min_size=model.num_choices,
                max_size=model.num_choices,
            )
        )
    )
    return model, rewards, target, maximize


def _check_bounds(res, ref: np.ndarray, gap: float = 2e-6) -> None:  # type: ignore[no-untyped-def]
    inf = np.isinf(ref)
    assert np.array_equal(np.isinf(res.values), inf), (res.values, ref)
    fin = ~inf
    assert np.all(res.lower[fin] <= ref[fin] + 1e-7), (res.lower, ref)
    assert np.all(ref[fin] <= res.upper[fin] + 1e-7), (res.upper, ref)
    if res.converged:
        assert np.all(
            res.upper[fin] - res.lower[fin] <= gap * np.maximum(1.0, np.abs(ref[fin])) + 1e-9
        )


@SETTINGS
@given(reward_problems(), st.sampled_from(["inf", "cum"]))
def test_reach_reward_bounds_enclose_brute_force(problem: tuple, mode: str) -> None:
    model, rewards, target, maximize = problem
    ref = game_value(model, maximize, lambda rows: chain_reward(model, rows, rewards, target, mode))
    # memoryless determinacy: the other order of quantifiers gives the same values
    neg = game_value(
        model, ~maximize, lambda rows: -chain_reward(model, rows, rewards, target, mode)
    )
    if not np.allclose(ref, -neg, atol=1e-9, equal_nan=True):
        pytest.skip("brute force reference not determined")  # pragma: no cover
    rmode = obj.ReachRewardMode.INFINITY if mode == "inf" else obj.ReachRewardMode.CUMULATIVE
    res = obj.expected_reach_reward(model, rewards, target, maximize=maximize, mode=rmode)
    assert res.sound
    assert res.converged
    _check_bounds(res, ref)
    for method in (Method.EXACT, Method.POLICY):
        r = obj.expected_reach_reward(
            model,
            rewards,
            target,
            maximize=maximize,
            mode=rmode,
            options=SolverOptions(method=method),
        )
        fin = np.isfinite(ref)
        assert np.array_equal(np.isinf(r.values), ~fin)
        assert np.allclose(r.values[fin], ref[fin], atol=1e-7), (method, r.values, ref)
    # the strategy attains the value
    assert res.strategy is not None
    rows = _strategy_rows(model, res.strategy)
    got = chain_reward(model, rows, rewards, target, mode)
    assert np.array_equal(np.isinf(got), np.isinf(ref)), (got, ref)
    fin = np.isfinite(ref)
    assert np.allclose(
        got[fin], ref[fin], atol=1e-3 * max(1.0, float(np.abs(ref[fin]).max(initial=0.0)))
    ), (got, ref)


@SETTINGS
@given(reward_problems(), st.sampled_from([0.0, 0.5, 0.9]))
def test_discounted_bounds_enclose_brute_force(problem: tuple, discount: float) -> None:
    model, rewards, target, maximize = problem
    S = model.num_states

    def evaluate(rows: np.ndarray) -> np.ndarray:
        P = model.transitions[rows].toarray()
        return np.linalg.solve(np.eye(S) - discount * P, rewards[rows])

    ref = game_value(model, maximize, evaluate)
    res = obj.discounted_total_reward(model, rewards, discount=discount, maximize=maximize)
    _check_bounds(res, ref)
    assert res.strategy is not None
    P = model.transitions[res.strategy].toarray()
    got = np.linalg.solve(np.eye(S) - discount * P, rewards[res.strategy])
    assert np.allclose(got, ref, atol=1e-4)
    exact = obj.discounted_total_reward(
        model,
        rewards,
        discount=discount,
        maximize=maximize,
        options=SolverOptions(method=Method.EXACT),
    )
    assert np.allclose(exact.values, ref, atol=1e-9)
