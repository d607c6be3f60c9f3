"""Reachability probabilities: ``P[remain U target]``, ``P[remain U<=k target]``, ``P[X target]``.

Unbounded until: graph precomputation settles the states with probability 0 or 1 exactly (for
games the attractor-based versions, see :mod:`posgmc.engines.graph`); the rest is solved as a
:class:`~posgmc.engines.system.System` (see :mod:`posgmc.engines.solving`), and the strategy
comes from the almost-sure attractor, the minimiser's avoiding choices and the attractor fix.
Step-bounded ``U<=k`` and ``X`` are exact up to floating point: k Bellman steps (lower step bounds
are in :mod:`posgmc.engines.step_bounds`).
"""

from __future__ import annotations

import time

import numpy as np

from posgmc.engines.graph import Structure, almost_sure_reach, positive_reach, structure_of
from posgmc.engines.iteration import EndComponents
from posgmc.engines.options import SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.solving import (
    bool_mask,
    directions_of,
    engine_result,
    exact_result,
    first_choices,
    local_rows,
    reacher_fix,
    solve_system,
)
from posgmc.engines.stepped import bellman_steps
from posgmc.engines.system import argopt_rows, build_system, reduce_rows
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["reach_probability", "bounded_reach_probability", "next_probability"]


def reach_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[remain U target]`` optimised per state (``remain`` None: ``F target``).

    Args:
        model: a dtmc, mdp or smg (a pomdp/posg is read as fully observable).
        target: bool[S].
        remain: bool[S] or None.
        maximize: bool[S], True where the state's owner maximises the probability.
        options: solver options.

    Returns:
        The :class:`EngineResult`; qualitative answers (0 and 1) are exact. The strategy (if asked)
        is optimal up to the precision and reaches the target: the maximiser's choices come from
        the almost-sure attractor on the value-1 states and from an attractor among its
        near-optimal choices elsewhere; the minimiser stays out of the positive region where its
        value is 0.
    """
    started = time.perf_counter()
    S = model.num_states
    tgt = bool_mask(target, S, False)
    rem = bool_mask(remain, S, True)
    mx = directions_of(model, maximize)
    g = structure_of(model)
    layer = np.full(S, -1, dtype=np.int64)
    pos = positive_reach(g, tgt, rem, existential=mx, layer=layer)
    one, one_witness = almost_sure_reach(g, tgt, rem, existential=mx, start=pos)
    zero = ~pos
    unknown = pos & ~one
    known_values = one.astype(np.float64)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(
            g, unknown, maximize=mx, fixed=known_values, layer=layer, topological=True
        )
        nondet = model.model_type is not ModelType.DTMC
        solved = solve_system(
            sys,
            options,
            cap=1.0,
            ec=EndComponents.DEFLATE if nondet else EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=True,
            is_chain=not nondet,
            initial_rows=(None if options.initial_strategy is None
                          else local_rows(sys, options.initial_strategy)),
        )
    strategy = None
    if options.want_strategy:
        strategy = first_choices(model)
        if model.model_type is not ModelType.DTMC:
            # value 1: the maximiser follows the almost-sure attractor
            w = one & mx & (one_witness >= 0)
            strategy[w] = one_witness[w]
            # value 0: the minimiser keeps out of the positive region
            avoid = _any_choice_avoiding(g, pos, zero & ~mx & ~tgt)
            a = avoid >= 0
            strategy[a] = avoid[a]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                reacher_fix(
                    g, strategy, solved, sys, goal=tgt | one, goal_choices=None, reacher=mx
                )
            # target states and states outside ``remain`` decide nothing
            strategy[tgt | ~rem] = -1
    return engine_result(
        model,
        ~unknown,
        known_values,
        sys,
        solved,
        method=options.method,
        started=started,
        strategy=strategy,
    )


def bounded_reach_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[remain U<=steps target]``: exactly ``steps`` Bellman steps (no strategy: it needs a step
    counter).

    Args:
        model, target, remain, maximize, options: as for :func:`reach_probability`.
        steps: the step bound k >= 0.

    Returns:
        The :class:`EngineResult` (``lower = upper = values``, ``strategy = None``).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    S = model.num_states
    tgt = bool_mask(target, S, False)
    rem = bool_mask(remain, S, True)
    mx = directions_of(model, maximize)
    g = structure_of(model)
    pos = positive_reach(g, tgt, rem, existential=mx)
    unknown = pos & ~tgt
    x = tgt.astype(np.float64)
    iterations = 0
    if unknown.any() and steps > 0:
        sys = build_system(g, unknown, maximize=mx, fixed=x)
        local, iterations = bellman_steps(sys, np.zeros(sys.n), steps)
        x[sys.states] = local
    return exact_result(x, iterations, options.method, started)


def next_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[X target]``: one step, optimised per state.

    Returns:
        The :class:`EngineResult` with the optimal choice per state as strategy.
    """
    started = time.perf_counter()
    S = model.num_states
    tgt = bool_mask(target, S, False)
    mx = directions_of(model, maximize)
    g = structure_of(model)
    sys = build_system(g, np.ones(S, dtype=bool), maximize=mx, fixed=tgt.astype(np.float64))
    # all states are unknown, so the target mass must enter through the offset
    y = np.asarray(model.transitions[sys.rows] @ tgt.astype(np.float64)).ravel()
    local = reduce_rows(sys, y)
    x = np.zeros(S)
    x[sys.states] = local
    strategy = None
    if options.want_strategy:
        strategy = np.full(S, -1, dtype=np.int64)
        strategy[sys.states] = sys.rows[argopt_rows(sys, y)]
    return exact_result(x, 1, options.method, started, strategy=strategy)


def _any_choice_avoiding(g: Structure, avoid: np.ndarray, states: np.ndarray) -> np.ndarray:
    """int64[S]: for each state in ``states`` a choice with no edge into ``avoid`` (-1 if none)."""
    hits = np.asarray(g.transitions @ avoid.astype(np.float64)) > 0
    out = np.full(g.num_states, -1, dtype=np.int64)
    idx = np.flatnonzero(~hits & states[g.choice_state])
    out[g.choice_state[idx[::-1]]] = idx[::-1]  # the first such choice wins
    return out
