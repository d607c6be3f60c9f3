"""Until with a lower step bound, ``remain U[k1,k2] target``, by backward induction over the steps.

Semantics (PRISM's): a path satisfies ``phi U[k1,k2] psi`` iff some step t with ``k1 <= t <= k2``
has ``psi`` and every step ``j < t`` has ``phi`` (``k2`` may be infinite). Split the path at step
``k1``: the first ``k1`` states must all satisfy ``phi``, and from step ``k1`` on the path must
satisfy ``phi U<=(k2-k1) psi`` (``phi U psi`` when ``k2`` is infinite). Hence, with ``Step`` the
one-step operator restricted to ``phi``::

    v_0        = P_opt[phi U<=(k2-k1) psi]        (or P_opt[phi U psi])
    v_{i+1}(s) = phi(s) ? opt_{c in choices(s)} sum_t P(s, c, t) v_i(t) : 0
    P_opt[phi U[k1,k2] psi] = v_{k1}

(PRISM's ``computeRestrictedNext`` repeated ``k1`` times). This is the dynamic programme of the
finite-horizon game whose last ``k1`` steps are the prefix, so the optimum is taken per state and
per remaining step, as for ``U<=k``; the optimal strategies need a step counter, so none is
returned (as for :func:`~posgmc.engines.reach.bounded_reach_probability`).

``Step`` is monotone and non-expansive in the sup norm, so the proven lower and upper bounds of an
unbounded ``v_0`` stay proven bounds after the ``k1`` steps, and their gap does not grow: lower,
upper and reported values are propagated as three columns of one iteration.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from posgmc.engines.graph import structure_of
from posgmc.engines.options import SolverOptions
from posgmc.engines.reach import bounded_reach_probability, reach_probability
from posgmc.engines.result import EngineResult
from posgmc.engines.system import bellman, build_system, reduce_rows
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel

__all__ = ["interval_reach_probability"]


def _states(a: np.ndarray | None, num_states: int, default: bool, what: str) -> np.ndarray:
    if a is None:
        return np.full(num_states, default, dtype=bool)
    out = np.asarray(a, dtype=bool)
    if out.shape != (num_states,):
        raise PosgmcError(f"{what} needs one entry per state ({num_states}), got shape {out.shape}")
    return out


def interval_reach_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    lower_steps: int,
    upper_steps: int | None,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[remain U[lower_steps, upper_steps] target]`` optimised per state (``remain`` None:
    ``F[lower_steps, upper_steps] target``).

    Args:
        model: a dtmc, mdp or smg (a pomdp/posg is read as fully observable).
        target: bool[S].
        remain: bool[S] or None (every state).
        lower_steps: k1 >= 0, the first step at which ``target`` counts.
        upper_steps: k2 >= k1, the last such step; None for no upper bound.
        maximize: bool[S], True where the state's owner maximises the probability (the convention
            of :func:`~posgmc.engines.solving.maximize_mask`).
        options: solver options, used for the unbounded part (``upper_steps`` None).

    Returns:
        The :class:`EngineResult`. With ``upper_steps`` given the values are exact up to floating
        point (``lower = upper = values``); without, ``lower``/``upper`` are the proven bounds of
        :func:`~posgmc.engines.reach.reach_probability` carried through the ``k1`` steps,
        ``iterations`` counts both phases. ``strategy`` is None when ``lower_steps > 0`` (it needs a
        step counter); with ``lower_steps == 0`` the result is that of ``reach_probability`` or
        ``bounded_reach_probability`` unchanged.

    Raises:
        PosgmcError: a negative bound, an empty interval (``upper_steps < lower_steps``; callers
            reject those with a source position first), or arrays of the wrong shape.
    """
    started = time.perf_counter()
    if lower_steps < 0 or (upper_steps is not None and upper_steps < 0):
        raise PosgmcError(f"step bounds must be non-negative, got [{lower_steps}, {upper_steps}]")
    if upper_steps is not None and upper_steps < lower_steps:
        raise PosgmcError(f"the step interval [{lower_steps}, {upper_steps}] is empty")
    S = model.num_states
    tgt = _states(target, S, False, "target")
    rem = _states(remain, S, True, "remain")
    mx = _states(maximize, S, False, "maximize")
    if lower_steps == 0:
        if upper_steps is None:
            return reach_probability(model, tgt, remain=rem, maximize=mx, options=options)
        return bounded_reach_probability(
            model, tgt, remain=rem, steps=upper_steps, maximize=mx, options=options
        )
    # the tail's strategy would be discarded: a prefix of k1 > 0 steps needs a step counter
    tail_options = dataclasses.replace(options, want_strategy=False)
    if upper_steps is None:
        tail = reach_probability(model, tgt, remain=rem, maximize=mx, options=tail_options)
    else:
        tail = bounded_reach_probability(
            model,
            tgt,
            remain=rem,
            steps=upper_steps - lower_steps,
            maximize=mx,
            options=tail_options,
        )
    # columns: lower bound, upper bound, reported value
    x0 = np.stack([tail.lower, tail.upper, tail.values], axis=1).astype(np.float64)
    x = np.zeros((S, 3))
    if rem.any():
        # The unknowns are the ``remain`` states: every other state has value 0 once a step has
        # been taken. The first step still reads the tail's values of all states (a target outside
        # ``remain`` counts there), so it multiplies the full rows; the later ones use the system.
        sys = build_system(structure_of(model), rem, maximize=mx)
        y = np.asarray(model.transitions[sys.rows] @ x0)
        columns = [reduce_rows(sys, np.ascontiguousarray(y[:, j])) for j in range(3)]
        local = np.stack(columns, axis=1)
        for _ in range(lower_steps - 1):
            local = bellman(sys, local)
        x[sys.states] = local
    return EngineResult(
        values=x[:, 2].copy(),
        lower=x[:, 0].copy(),
        upper=x[:, 1].copy(),
        iterations=tail.iterations + lower_steps,
        converged=tail.converged,
        method=tail.method,
        seconds=time.perf_counter() - started,
        sound=tail.sound,
        strategy=None,
    )
