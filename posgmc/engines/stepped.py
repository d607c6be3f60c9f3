"""Step-bounded rewards: ``R[C<=k]`` (cumulative) and ``R[I=k]`` (instantaneous).

Both are exact up to floating point: k Bellman steps over all states, optimised per state and per
remaining step, cut short when the iteration reaches an exact fixpoint (:func:`bellman_steps`).
Their optimal strategies need a step counter, so none is returned (step-bounded
probabilities are in :mod:`posgmc.engines.reach` and :mod:`posgmc.engines.step_bounds`).
"""

from __future__ import annotations

import time

import numpy as np

from posgmc.engines.graph import structure_of
from posgmc.engines.options import SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.solving import check_rewards, directions_of, exact_result
from posgmc.engines.system import System, bellman, build_system
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel

__all__ = ["cumulative_reward", "instantaneous_reward", "bellman_steps"]


def bellman_steps(sys: System, local: np.ndarray, steps: int) -> tuple[np.ndarray, int]:
    """``steps`` Bellman steps from ``local``, stopping early at an exact fixpoint.

    Once one step leaves the vector unchanged bit for bit, every later step does too, so the
    result is exactly what all ``steps`` steps would give: a bound like ``F<=10^20`` costs only
    the steps until the floating-point iteration settles.

    Returns:
        The vector after ``steps`` steps and the number of steps actually computed.
    """
    done = 0
    while done < steps:
        nxt = bellman(sys, local)
        done += 1
        if np.array_equal(nxt, local):
            return nxt, done
        local = nxt
    return local, done


def cumulative_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[C<=k]``: the choice rewards of the first ``steps`` steps, by k Bellman steps.

    Returns:
        The :class:`EngineResult` (exact up to floating point; no strategy).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    r = check_rewards(model, rewards, nonnegative=False)
    mx = directions_of(model, maximize)
    S = model.num_states
    x = np.zeros(S)
    if steps > 0:
        sys = build_system(
            structure_of(model), np.ones(S, dtype=bool), maximize=mx, choice_offset=r
        )
        local, done = bellman_steps(sys, np.zeros(S), steps)
        x[sys.states] = local
        return exact_result(x, done, options.method, started)
    return exact_result(x, 0, options.method, started)


def instantaneous_reward(
    model: ExplicitModel,
    state_rewards: np.ndarray,
    *,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[I=k]``: the expected state reward of the state occupied after ``steps`` steps.

    Returns:
        The :class:`EngineResult` (exact up to floating point; no strategy).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    S = model.num_states
    sr = np.asarray(state_rewards, dtype=np.float64)
    if sr.shape != (S,):
        raise PosgmcError(f"state rewards need one entry per state ({S}), got {sr.shape}")
    mx = directions_of(model, maximize)
    x = sr.copy()
    if steps > 0:
        sys = build_system(structure_of(model), np.ones(S, dtype=bool), maximize=mx)
        local, done = bellman_steps(sys, sr[sys.states], steps)
        x = np.empty(S)
        x[sys.states] = local
        return exact_result(x, done, options.method, started)
    return exact_result(x, 0, options.method, started)
