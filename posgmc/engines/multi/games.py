"""Two-objective achievable sets of a coalition in a stopping turn-based stochastic game.

The value iteration of Chen, Forejt, Kwiatkowska, Simaitis and Wiltsche ("On stochastic games
with multiple objectives", MFCS 2013), which PRISM-games' multi-objective SMG engine implements,
for expected total rewards (non-negative) in **stopping** games (every strategy profile reaches a
terminal state, where nothing more is collected, with probability 1):

* ``X_s^0 = {0}`` (downward closed), for every state;
* a choice ``c``: ``Y_c = r(c) + sum_t P(c, t) X_t^k``;
* a coalition state: ``X_s^{k+1}`` = the convex hull of the union of its choices' ``Y_c``
  (the coalition may randomise); an opponent state: their intersection (the opponent picks);
* terminal states keep ``{0}``.

Every ``X_s^k`` is a set of points the coalition can achieve from ``s`` against every opponent
(a strategy with k steps of memory attains them), increasing in k, and in a stopping game they
converge to the achievable set. posgmc stops when no support value of the initial state's set
moved by more than ``tolerance`` in an iteration: the result is an **under-approximation**
(every point in it is achievable); how far the limit lies beyond it is not bounded by the method.

The sets are chains of :mod:`posgmc.engines.multi.polygon`; the iteration visits every choice in
Python, so it is meant for small games (:data:`MAX_STATES`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines.multi import polygon
from posgmc.errors import LimitError

__all__ = ["GameFront", "coalition_sets", "MAX_STATES"]

MAX_STATES = 5000
"""The polygon value iteration visits every choice in Python: games up to this many states."""


@dataclass(frozen=True, eq=False)
class GameFront:
    """``chain``: the initial state's achievable set after ``iterations`` rounds (a chain of
    :mod:`~posgmc.engines.multi.polygon`); ``change``: the largest support-value change of its
    last round; ``converged``: ``change <= tolerance``."""

    chain: np.ndarray
    iterations: int
    change: float
    converged: bool


def coalition_sets(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    rewards: np.ndarray,
    coalition_states: np.ndarray,
    terminal: np.ndarray,
    initial: int,
    *,
    tolerance: float = 1e-7,
    max_iterations: int = 10_000,
) -> GameFront:
    """The value iteration of the module docstring.

    Args:
        transitions: csr float64 [C, S], rows grouped by ``row_groups`` (int64[S + 1]).
        rewards: float64[C, 2], each choice's rewards for the two objectives (>= 0).
        coalition_states: bool[S], the states of the coalition's players.
        terminal: bool[S], the terminal states (their sets stay {0}).
        initial: the initial state.

    Raises:
        LimitError: more than :data:`MAX_STATES` states.
    """
    num_states = int(row_groups.size - 1)
    if num_states > MAX_STATES:
        raise LimitError(
            f"multi-objective games are solved for up to {MAX_STATES} states; this one has "
            f"{num_states}"
        )
    zero = polygon.point(np.zeros(2))
    sets = [zero] * num_states
    directions = np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0, np.pi / 2, 17)])
    indptr, indices, data = transitions.indptr, transitions.indices, transitions.data
    change = np.inf
    iteration = 0
    for iteration in range(1, max_iterations + 1):
        new = list(sets)
        for s in np.flatnonzero(~terminal):
            ys = []
            for c in range(row_groups[s], row_groups[s + 1]):
                succ = indices[indptr[c]:indptr[c + 1]]
                probs = data[indptr[c]:indptr[c + 1]]
                ys.append(polygon.weighted_sum([sets[t] for t in succ], probs, rewards[c]))
            if coalition_states[s]:
                new[s] = polygon.hull(np.vstack(ys))
            else:
                new[s] = polygon.intersection(ys)
        before = polygon.support(sets[initial], directions)
        after = polygon.support(new[initial], directions)
        change = float(np.max(np.abs(after - before)))
        # the whole game must have settled, not only the initial state's set
        settled = change <= tolerance and all(
            float(
                np.max(
                    np.abs(
                        polygon.support(new[s], directions) - polygon.support(sets[s], directions)
                    )
                )
            )
            <= tolerance
            for s in range(num_states)
        )
        sets = new
        if settled:
            return GameFront(sets[initial], iteration, change, True)
    return GameFront(sets[initial], iteration, change, False)
