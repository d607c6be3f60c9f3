"""Discounted rewards: ``R[Cdiscount=g]`` and the discounted reward until a target.

Every step leaks probability ``1 - g``, so the system has no end components and the Bellman
operator is a contraction: sound bounds come from the contraction factor and rewards of any sign
are fine (see :func:`~posgmc.engines.iteration.solve_discounted`); ``Method.EXACT``/``POLICY`` use
policy iteration. The strategy is an optimal memoryless one.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from posgmc.engines.graph import structure_of
from posgmc.engines.iteration import EndComponents, solve_discounted
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.solving import (
    bool_mask,
    check_rewards,
    directions_of,
    exact_result,
    local_rows,
    solve_system,
)
from posgmc.engines.system import build_system
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["discounted_total_reward", "discounted_reach_reward"]


def discounted_total_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    discount: float,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[Cdiscount=g]`` = E[sum_t g^t r_t]; bounds from the contraction factor
    (``|x_k - x*| <= g / (1 - g) |x_k - x_{k-1}|``), so rewards of any sign are fine.

    Returns:
        The :class:`EngineResult` with an optimal memoryless strategy.
    """
    r = check_rewards(model, rewards, nonnegative=False)
    S = model.num_states
    return _discounted(
        model, r, np.ones(S, dtype=bool), float(discount), directions_of(model, maximize), options
    )


def discounted_reach_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    target: np.ndarray,
    *,
    discount: float,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """Discounted reward collected until ``target`` (absorbing, nothing collected there).

    Returns:
        The :class:`EngineResult` with an optimal memoryless strategy.
    """
    r = check_rewards(model, rewards, nonnegative=False)
    tgt = bool_mask(target, model.num_states, False)
    return _discounted(model, r, ~tgt, float(discount), directions_of(model, maximize), options)


def _discounted(
    model: ExplicitModel,
    r: np.ndarray,
    unknown: np.ndarray,
    discount: float,
    mx: np.ndarray,
    options: SolverOptions,
) -> EngineResult:
    """``x = opt(r + discount * T x)`` on ``unknown`` (other states 0)."""
    started = time.perf_counter()
    if not 0.0 <= discount < 1.0:
        raise PosgmcError(f"a discount factor must lie in [0, 1), got {discount}")
    S = model.num_states
    g = structure_of(model)
    x = np.zeros(S)
    lower = np.zeros(S)
    upper = np.zeros(S)
    strategy = np.full(S, -1, dtype=np.int64) if options.want_strategy else None
    if not unknown.any():
        return exact_result(x, 0, options.method, started, strategy=strategy)
    base = build_system(g, unknown, maximize=mx, choice_offset=r)
    scaled = base.matrix.copy()
    scaled.data *= discount
    # every row leaks probability 1 - discount, so no part of the system is closed
    sys = replace(base, matrix=scaled, stays=np.zeros(base.m, dtype=bool))
    iterations = 0
    converged = True
    solved = None
    if options.method in (Method.EXACT, Method.POLICY) and sys.n:
        solved = solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=False,
            is_chain=model.model_type is ModelType.DTMC,
            initial_rows=(None if options.initial_strategy is None
                          else local_rows(sys, options.initial_strategy)),
            interval=lambda: solve_discounted(sys, replace(options, method=Method.INTERVAL))[0],
        )
        lo, hi = solved.lower, solved.upper
        iterations, converged = solved.iterations, solved.converged
        best = solved.best_rows
    else:
        bounds, best_local = solve_discounted(sys, options)
        lo, hi = bounds.lower, bounds.upper
        iterations, converged = bounds.iterations, bounds.converged
        best = sys.rows[best_local]
    lower[sys.states] = lo
    upper[sys.states] = hi
    x[sys.states] = (
        0.5 * (lo + hi) if solved is None or solved.estimate is None else solved.estimate
    )
    if strategy is not None and best is not None:
        strategy[sys.states] = best
    return EngineResult(
        values=x,
        lower=lower,
        upper=upper,
        iterations=iterations,
        converged=converged,
        method=options.method,
        seconds=time.perf_counter() - started,
        sound=options.method is not Method.VALUE,
        strategy=strategy,
    )
