"""A threshold that the proven bounds leave open, decided in rational arithmetic on a small model.

When ``P>=p [...]`` or ``R<=r [...]`` has a value equal to its threshold (``P>1/3`` on a value of
exactly 1/3, ``<<a>> R<=4`` on a game whose value is 4), no floating-point bound decides it: the
interval around the value always contains the threshold. On a model of at most ``limit`` states
the value is then bracketed by exact bounds ``L <= v <= U`` (Fractions, or infinity) and the
threshold, itself read exactly, is compared with both: the answer is given when both comparisons
agree. Every comparison operator takes this one path.

Where the bounds come from:

* ``P[F b]``, ``P[a U b]`` on dtmcs, mdps and games: the exact value
  (:func:`~posgmc.engines.rational.exact_rational_reach`, nested policy iteration), so L = U;
* ``R[F b]`` on dtmcs and mdps: the exact value
  (:func:`~posgmc.engines.rational_rewards.exact_reach_reward`);
* ``R[F b]`` on games: each side's strategy read off the floating-point solution is fixed in turn
  and the other side's exact optimum computed on the mdp that remains. Fixing the maximiser's
  strategy can only lower the value, fixing the minimiser's only raise it: both are exact bounds
  whatever the strategies, and they meet when the strategies read off are optimal.

Probabilities and rewards are read as the decimals the model was written with (as
:mod:`posgmc.engines.rational` does). Anything else returns None: the threshold stays undecided.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from fractions import Fraction

import numpy as np

from posgmc.engines.graph import almost_sure_reach, structure_of
from posgmc.engines.rational import exact_rational_reach
from posgmc.engines.rational_rewards import exact_reach_reward
from posgmc.engines.steady import as_fractions
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType
from posgmc.syntax.ast import ComparisonOp

__all__ = ["INFINITY", "Exact", "decide", "reach_bounds", "reward_bounds"]

INFINITY = float("inf")
Exact = Fraction | float  # a Fraction, or INFINITY
"""An exact value: a Fraction, or ``INFINITY`` (an expected reward that is infinite)."""

_COMPARE: dict[ComparisonOp, Callable[[Exact, Exact], bool]] = {
    ComparisonOp.GE: operator.ge,
    ComparisonOp.GT: operator.gt,
    ComparisonOp.LE: operator.le,
    ComparisonOp.LT: operator.lt,
}


def decide(op: ComparisonOp, lower: Exact, upper: Exact, threshold: Fraction) -> bool | None:
    """``v op threshold`` for a value known to lie in ``[lower, upper]``, or None when the two
    ends answer differently (each comparison is monotone in v)."""
    low, high = _COMPARE[op](lower, threshold), _COMPARE[op](upper, threshold)
    return low if low == high else None


def reach_bounds(
    model: ExplicitModel, target: np.ndarray, remain: np.ndarray | None, maximize: np.ndarray
) -> tuple[list[Exact], list[Exact]]:
    """Exact ``P[remain U target]`` per state (lower and upper bounds coincide)."""
    values: list[Exact] = list(
        exact_rational_reach(model, target, remain=remain, maximize=maximize)
    )
    return values, values


def reward_bounds(
    model: ExplicitModel,
    choice_rewards: np.ndarray,
    target: np.ndarray,
    maximize: np.ndarray,
    approximate: np.ndarray,
) -> tuple[list[Exact], list[Exact]] | None:
    """Exact bounds on ``R[F target]`` per state (infinite where the target is not reached
    almost surely); None where they are not computed (negative rewards).

    Args:
        model: a dtmc, mdp or turn-based game.
        choice_rewards: float[C], state plus action reward of each choice.
        target: bool[S].
        maximize: bool[S], True where the state's owner maximises.
        approximate: float[S], a floating-point solution, from which a game's strategies are
            read (unused for dtmcs and mdps).
    """
    if np.any(choice_rewards < 0):
        return None
    rewards = as_fractions(choice_rewards)
    if not model.model_type.is_game:
        values = _exact_rewards(model, rewards, target, maximize=bool(np.any(maximize)))
        return values, values
    strategy = _read_strategy(model, choice_rewards, target, maximize, approximate)
    # the maximiser fixed: the minimiser's exact optimum is a lower bound; and the other way
    keep_low = _keep(model, strategy, fixed=maximize)
    keep_high = _keep(model, strategy, fixed=~maximize)
    low = _exact_rewards(_restricted(model, keep_low), _take(rewards, keep_low), target,
                         maximize=False)
    high = _exact_rewards(_restricted(model, keep_high), _take(rewards, keep_high), target,
                          maximize=True)
    return low, high


def _exact_rewards(
    model: ExplicitModel, rewards: list[Fraction], target: np.ndarray, *, maximize: bool
) -> list[Exact]:
    values, infinite = exact_reach_reward(model, rewards, target, maximize=maximize)
    return [INFINITY if inf else v for v, inf in zip(values, infinite.tolist())]


def _read_strategy(
    model: ExplicitModel,
    choice_rewards: np.ndarray,
    target: np.ndarray,
    maximize: np.ndarray,
    approximate: np.ndarray,
) -> np.ndarray:
    """int64[S]: each state's best choice against the floating-point values (global index).

    Among the choices within a relative 1e-9 of the best, the minimiser plays the attractor's
    choice of the graph analysis restricted to them (one that makes progress towards the
    target: a zero-reward loop can look as good as progress in floating point). Where the
    value is infinite the maximiser plays a spoiling choice (:func:`_spoiling_choices`): infinite
    values do not order the choices."""
    v = np.where(np.isfinite(approximate), approximate, np.finfo(np.float64).max / 4)
    q = choice_rewards + np.asarray(model.transitions @ v)
    rg = model.row_groups
    state_of = np.repeat(np.arange(model.num_states), np.diff(rg))
    sign = np.where(maximize[state_of], -1.0, 1.0)  # minimise sign * q
    key = sign * q
    best = np.minimum.reduceat(key, rg[:-1]) if key.size else key
    near = key <= best[state_of] + 1e-9 * np.maximum(1.0, np.abs(best[state_of]))
    # where the minimiser cannot force the target (the value is infinite), the maximiser
    # spoils: infinite values do not order the choices
    spoil = _spoiling_choices(model, target, maximize, state_of)
    near = np.where((spoil >= 0)[state_of], np.arange(q.size) == spoil[state_of], near)
    # the minimiser's near-optimal choices that reach the target almost surely (a zero-reward
    # loop can be as good as progress in the floating-point values, and is not)
    _, witness = almost_sure_reach(
        structure_of(model), target, np.ones(model.num_states, dtype=bool),
        existential=~maximize, allowed=near,
    )
    # the first near-optimal choice of each state, the witness where it is near-optimal
    rows = np.flatnonzero(near)
    states, at = np.unique(state_of[rows], return_index=True)
    first = np.full(model.num_states, -1, dtype=np.int64)
    first[states] = rows[at]
    w = np.asarray(witness, dtype=np.int64)
    use_witness = (w >= 0) & ~maximize
    use_witness[use_witness] = near[w[use_witness]]
    return np.where(use_witness, w, first)


def _spoiling_choices(
    model: ExplicitModel, target: np.ndarray, maximize: np.ndarray, state_of: np.ndarray
) -> np.ndarray:
    """int64[S]: for each maximiser state from which the minimiser cannot force the target
    almost surely, a choice that keeps the target unreached with positive probability (-1
    elsewhere). The minimiser's almost-sure winning region is the greatest fixpoint Y of the
    states that reach the target while staying in Y (an inner least fixpoint X); a maximiser
    state leaving Y is given, at that round, a choice that leaves Y or has no successor in X."""
    T = model.transitions
    rg = model.row_groups
    starts = rg[:-1]
    S = model.num_states
    spoil = np.full(S, -1, dtype=np.int64)
    has_choice = np.diff(rg) > 0
    Y = np.ones(S, dtype=bool)
    while True:
        all_in_y = np.asarray(T @ (~Y).astype(np.float64)).reshape(-1) == 0
        X = target.copy()
        while True:
            good = all_in_y & (np.asarray(T @ X.astype(np.float64)).reshape(-1) > 0)
            g = good.astype(np.int8)
            some = np.zeros(S, dtype=bool)
            every = np.zeros(S, dtype=bool)
            some[has_choice] = np.maximum.reduceat(g, starts[has_choice]) > 0
            every[has_choice] = np.minimum.reduceat(g, starts[has_choice]) > 0
            new = target | (Y & np.where(maximize, every, some))
            if np.array_equal(new, X):
                break
            X = new
        leaving = Y & ~X & maximize
        bad = leaving[state_of] & ~good
        rows = np.flatnonzero(bad)
        states, at = np.unique(state_of[rows], return_index=True)
        spoil[states] = rows[at]
        if np.array_equal(X, Y):
            return spoil
        Y = X


def _keep(model: ExplicitModel, strategy: np.ndarray, *, fixed: np.ndarray) -> np.ndarray:
    """bool[C]: every choice of the states not ``fixed``, the strategy's in those fixed."""
    state_of = np.repeat(np.arange(model.num_states), np.diff(model.row_groups))
    keep = ~fixed[state_of]
    chosen = strategy[fixed]
    keep[chosen[chosen >= 0]] = True
    return keep


def _take(values: list[Fraction], keep: np.ndarray) -> list[Fraction]:
    return [values[int(c)] for c in np.flatnonzero(keep)]


def _restricted(model: ExplicitModel, keep: np.ndarray) -> ExplicitModel:
    """The mdp of the kept choices (each state keeps at least one)."""
    rows = np.flatnonzero(keep)
    state_of = np.repeat(np.arange(model.num_states), np.diff(model.row_groups))
    counts = np.bincount(state_of[rows], minlength=model.num_states)
    row_groups = np.concatenate([[0], np.cumsum(counts)])
    return make_model(
        ModelType.MDP,
        row_groups,
        model.transitions[rows],
        initial_states=model.initial_states,
        labels=dict(model.labels),
    )
