"""Policy iteration over the decision maker's *deterministic* k-FSSs, improved per observation
(hole) rather than per state: a start for the search that carries the full-observation
strategy's directed moves into the partially observed game and then lets the value of the
information a move gathers flow back, step by step, to the moves that lead there.

**Why.** Projections of the full-observation optimum (majority vote, QMDP; :mod:`search`) know
nothing of information: with full observation the decision maker never gathers any, so
wherever gathering matters those projections say "act now" or leave the gathering moves tied,
and a gradient search from a nearly uniform walk sees no value in a move whose pay-off shows
only after many more well-chosen moves (and only if the later moves use what was learnt). A
deterministic defence evaluated on the whole state space, however, has a value in every state,
including those it never reaches: one improvement step sees that a move into a state where the
information is known is worth more, the next sees the move before it, and so on.

**The iteration** (on the quotient of :mod:`posgmc.synthesis.deterministic`: states (s, n), a
decision maker's row per option (a, n') of its hole h = (n, z)):

1. Values v: first the quotient's optimum (the decision maker choosing per state, i.e. the
   full-observation values extended by memory), afterwards the current member's values against
   the omniscient adversary, on every state of the quotient (value iteration from below: the
   least fixed point, the right one for probabilities with end components).
2. Each row's one-step value q(c) = r(c) + g Σ_s' P(c, s') v(s'); each hole's score of an option
   o: the mean of q over the hole's states — the belief that every state the hole stands for is
   equally likely (exact where the hidden part is drawn uniformly, an estimate otherwise).
3. The member takes, in every hole, its best-scoring option, and keeps its current one unless
   another scores strictly better (so that ties cause no cycling).
4. Repeat while the member changes and the value improved within ``patience`` rounds.

Unlike policy iteration on an MDP this is not monotone (a hole's states do not share one
optimum), so the best member met is returned, its value by value iteration: a ranking, never
what is reported — the search verifies it like every other candidate. Deterministic: no
randomness; its rounds are counted (the work budget), only the wall-clock cap can cut it short.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from posgmc.synthesis.deterministic import (
    DeterministicResult,
    Quotient,
    _bellman_parts,
    _member_of,
    _solve,
    quotient_of,
)
from posgmc.synthesis.executors import Executor
from posgmc.synthesis.problem import Problem, expired

__all__ = ["improve", "ImprovementJob", "improvement_phase", "hole_scores"]

PATIENCE = 5
"""Rounds without a better member before the iteration stops."""

MAX_ROUNDS = 100
"""Improvement rounds at most."""

_TIE = 1e-12
"""An option replaces a hole's current one only when it scores better by more than this
(relative to the scores' scale)."""


def hole_scores(q: Quotient, values: np.ndarray, problem: Problem) -> np.ndarray:
    """float64[H, O]: each hole's mean over its quotient states of each option's one-step value
    under ``values`` (float64[Q]), on the decision maker's side (negated for a minimiser); -inf
    where the hole does not offer the option or has no state."""
    _, _, base, gamma = _bellman_parts(q, problem)
    own = np.flatnonzero(q.hole >= 0)
    finite = np.isfinite(values)
    big = 10.0 * (float(np.abs(values[finite]).max(initial=0.0)) + 1.0)
    v = np.where(finite, values, np.copysign(big, values))
    row_values = base[own] + gamma * np.asarray(q.model.transitions[own] @ v).ravel()
    H, O = q.num_holes, q.num_options  # noqa: E741 - holes x options, as in bool[H, O]
    key = q.hole[own] * O + q.option[own]
    total = np.bincount(key, weights=row_values, minlength=H * O)
    count = np.bincount(key, minlength=H * O)
    mean = np.divide(total, count, out=np.zeros(H * O), where=count > 0)
    score = problem.sign * mean
    return np.where((count > 0).reshape(H, O) & q.offered, score.reshape(H, O), -np.inf)


def _greedy(score: np.ndarray, current: np.ndarray | None, offered: np.ndarray) -> np.ndarray:
    """int64[H]: each hole's best option; the current one where none is strictly better; a
    hole without a state in the quotient (unreachable) keeps its current option, else takes
    its first offered one."""
    rows = np.arange(score.shape[0])
    best: np.ndarray = score.argmax(axis=1)
    top = score[rows, best]
    fallback = offered.argmax(axis=1) if current is None else current
    best = np.where(np.isfinite(top), best, fallback)
    if current is None:
        return best
    now = score[rows, current]
    scale = np.maximum(1.0, np.abs(np.where(np.isfinite(top), top, 0.0)))
    keep = np.isfinite(now) & (now >= top - _TIE * scale)
    chosen: np.ndarray = np.where(keep, current, best)
    return chosen


def _member(choice: np.ndarray, num_options: int) -> np.ndarray:
    """bool[H, O] of one option per hole."""
    member = np.zeros((choice.size, num_options), dtype=bool)
    member[np.arange(choice.size), choice] = True
    return member


def improve(problem: Problem, memory: int, *, deadline: float | None,
            start: DeterministicResult | None = None,
            max_rounds: int = MAX_ROUNDS) -> DeterministicResult | None:
    """The best deterministic ``memory``-node FSS met by observation-level policy iteration
    (module docstring), from the quotient's optimum or, with ``start`` (at most ``memory``
    nodes, embedded), from that defence's values. None when the model's observations do not suit
    deterministic rules (:func:`~posgmc.synthesis.deterministic.quotient_of`), for undiscounted
    expected rewards (whose values may be infinite), or when ``deadline`` passes before a first
    member is valued. ``max_rounds``: improvement rounds at most (the work budget)."""
    started = time.perf_counter()
    q = quotient_of(problem, memory, deadline=deadline)
    if q is None or (q.rewards is not None and problem.discount >= 1.0):
        return None
    sign = problem.sign
    current: np.ndarray | None = None
    best: tuple[float, np.ndarray] | None = None
    if start is not None and start.memory <= memory:
        member = _member_of(q, start.gamma, start.delta) & q.offered
        current = member.argmax(axis=1)
        solved = _solve(q, member, None, problem, deadline=deadline)
        if solved.cut:
            return None
        values = solved.values
        best = (solved.value, member)
    else:
        solved = _solve(q, q.offered, None, problem, deadline=deadline)
        if solved.cut:
            return None
        values = solved.values
    rounds = since = 0
    while rounds < max_rounds and since < PATIENCE and not expired(deadline):
        choice = _greedy(hole_scores(q, values, problem), current, q.offered)
        if current is not None and np.array_equal(choice, current):
            break  # no hole changes: a fixed point of the improvement
        current = choice
        member = _member(choice, q.num_options) & q.offered
        solved = _solve(q, member, None, problem, deadline=deadline)
        rounds += 1
        if solved.cut:
            break
        values = solved.values
        tol = 1e-9 * max(1.0, abs(best[0])) if best is not None else 0.0
        if best is None or sign * solved.value > sign * best[0] + tol:
            best, since = (solved.value, member), 0
        else:
            since += 1
    if best is None:
        return None
    return DeterministicResult.of_member(q, best[1], value=best[0], exhaustive=False,
                                         families=rounds,
                                         seconds=time.perf_counter() - started)


@dataclass(frozen=True, eq=False)
class ImprovementJob:
    """Observation-level policy iteration for each memory size in turn (a job of
    :mod:`posgmc.synthesis.executors`), each size started from the best smaller defence as well as
    from the quotient's optimum, the better kept; ``deadline``: a ``time.perf_counter()`` value.
    ``run`` returns the best defence with at most k nodes for each size reached."""

    PHASE: ClassVar[str] = "policy iteration (observations)"

    memory: tuple[int, ...]
    deadline: float | None
    rounds: int = MAX_ROUNDS

    def run(self, problem: Problem) -> tuple[DeterministicResult, ...]:
        found: list[DeterministicResult] = []
        best: DeterministicResult | None = None
        sign = problem.sign
        for k in self.memory:
            if expired(self.deadline):
                break
            r = improve(problem, k, deadline=self.deadline, max_rounds=self.rounds)
            if best is not None and k > best.memory and not expired(self.deadline):
                warm = improve(problem, k, deadline=self.deadline, start=best,
                               max_rounds=self.rounds)
                if warm is not None and (r is None or sign * warm.value > sign * r.value):
                    r = warm
            if r is None:
                continue
            if best is not None and sign * best.value >= sign * r.value:
                # the smaller defence is at least as good: keep it, embedded (a k-FSS with the
                # extra nodes never entered guarantees as much)
                q = quotient_of(problem, k)
                if q is None:  # no longer fits in the memory available
                    continue
                r = DeterministicResult.of_member(
                    q, _member_of(q, best.gamma, best.delta) & q.offered, value=best.value,
                    exhaustive=False, families=r.families, seconds=r.seconds)
            found.append(r)
            best = r
        return tuple(found)


def improvement_phase(executor: Executor, memory: tuple[int, ...], deadline: float | None, *,
                      rounds: int = MAX_ROUNDS) -> dict[int, DeterministicResult]:
    """Run :class:`ImprovementJob` over ``memory`` (at most ``rounds`` rounds per size, fewer
    when ``deadline``, the wall-clock cap, passes); the best defence with at most k nodes, by
    k."""
    results = executor.map([ImprovementJob(tuple(memory), deadline, rounds)])[0]
    return {r.memory: r for r in results}
