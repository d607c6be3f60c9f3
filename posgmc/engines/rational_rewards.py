"""Exact expected rewards until a target, ``R[F target]``, on small dtmcs and mdps (PRISM's
``-exact``), by policy iteration over the rationals.

PRISM's rule decides where the value is infinite: where the minimiser (for ``Rmin``; every
strategy for ``Rmax`` and on a dtmc) cannot reach the target with probability 1 — graph analysis,
exact by nature (:func:`posgmc.engines.graph.almost_sure_reach`). On the remaining states only
choices that stay among them are usable, and the value is the optimum over the strategies that
reach the target almost surely.

Policy iteration starts from a strategy that reaches the target almost surely (the graph
analysis's witness for ``Rmin``; any usable choice for ``Rmax``, where every strategy does),
evaluates it exactly (dense Gaussian elimination over Fractions), and switches a state's choice
only on a *strict* improvement. With non-negative rewards this never enters a closed class that
avoids the target: summing the improvement inequalities over such a class with its stationary
distribution would give a negative total reward. So every evaluated system is nonsingular and the
fixpoint reached is the optimum over the almost-surely-reaching strategies. Negative rewards are
refused.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from posgmc.engines.graph import almost_sure_reach, structure_of
from posgmc.engines.rational import solve_dense
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["exact_reach_reward"]

_DENOMINATOR = 10**12


def _probabilities(model: ExplicitModel) -> list[Fraction]:
    if model.exact_probabilities is not None:
        return list(model.exact_probabilities)
    return [Fraction(float(p)).limit_denominator(_DENOMINATOR) for p in model.transitions.data]


def exact_reach_reward(
    model: ExplicitModel,
    rewards: list[Fraction],
    target: np.ndarray,
    *,
    maximize: bool,
) -> tuple[list[Fraction], np.ndarray]:
    """The exact ``R[F target]`` per state (``Rmax`` when ``maximize``, else ``Rmin``).

    Args:
        model: a small dtmc or mdp.
        rewards: per choice (state reward + action reward), non-negative.
        target: bool[S].
        maximize: the optimum asked for (irrelevant on a dtmc).

    Returns:
        ``(values, infinite)``: the value per state (0 where infinite) and bool[S], where the value
        is +infinity.

    Raises:
        UnsupportedError: a game, or a negative reward.
    """
    if model.model_type not in (ModelType.DTMC, ModelType.MDP):
        raise UnsupportedError("exact expected rewards are computed for dtmcs and mdps")
    if any(r < 0 for r in rewards):
        raise UnsupportedError("exact expected rewards need non-negative rewards",
                               hint="check without --exact: the interval method handles them")
    S = model.num_states
    g = structure_of(model)
    dtmc = model.model_type is ModelType.DTMC
    reacher = np.ones(S, dtype=bool) if (dtmc or not maximize) else np.zeros(S, dtype=bool)
    finite, witness = almost_sure_reach(g, target, np.ones(S, dtype=bool), existential=reacher)
    unknown = finite & ~target
    usable = ~(np.asarray(g.transitions @ (~finite).astype(np.float64)) > 0)
    states = [int(s) for s in np.flatnonzero(unknown)]
    index = {s: i for i, s in enumerate(states)}
    t = model.transitions
    probs = _probabilities(model)
    row_groups = model.row_groups

    def entries(c: int) -> list[tuple[int, Fraction]]:
        lo, hi = int(t.indptr[c]), int(t.indptr[c + 1])
        return [(int(t.indices[k]), probs[k]) for k in range(lo, hi)]

    choices = {s: [c for c in range(int(row_groups[s]), int(row_groups[s + 1])) if usable[c]]
               for s in states}
    policy = {}
    for s in states:
        w = int(witness[s]) if witness[s] >= 0 else -1
        policy[s] = w if (not maximize or dtmc) and w in choices[s] else choices[s][0]
    values = {s: Fraction(0) for s in states}
    while states:
        n = len(states)
        a = [[Fraction(0)] * n for _ in range(n)]
        b = [Fraction(0)] * n
        for i, s in enumerate(states):
            a[i][i] += 1
            c = policy[s]
            b[i] = rewards[c]
            for succ, p in entries(c):
                j = index.get(succ)
                if j is not None:
                    a[i][j] -= p
        solved = solve_dense(a, b)
        values = dict(zip(states, solved))
        switched = False
        for s in states:
            best, best_value = policy[s], values[s]
            for c in choices[s]:
                q = rewards[c] + sum((p * values.get(succ, Fraction(0)) for succ, p in entries(c)),
                                     Fraction(0))
                if (q > best_value) if maximize else (q < best_value):
                    best, best_value = c, q
            if best != policy[s]:
                policy[s] = best
                switched = True
        if not switched:
            break
    out = [values.get(s, Fraction(0)) for s in range(S)]
    return out, ~finite
