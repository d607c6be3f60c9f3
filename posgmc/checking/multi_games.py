"""PRISM-games' multi-objective coalition queries on smgs: ``<<C>> (q1 & q2)``.

posgmc's fragment (checked by :mod:`posgmc.semantics.multi`): one or two objectives the
coalition ``C`` maximises against all other players, each the probability of a co-safe LTL
formula (``P>=p [ F "goal" ]``, ``Pmax=? [...]``; through its DFA product, as a reward of 1 on the
step that first satisfies it) or an expected total reward (``R{"r"}>=v [ C ]``, ``Rmax=? [ C ]``,
non-negative rewards), on a **stopping** game: every strategy profile reaches a terminal state
(one whose every choice loops on it) with probability 1, checked first. The sets of achievable
points are computed by the value iteration of Chen, Forejt, Kwiatkowska, Simaitis and Wiltsche
(MFCS 2013; :mod:`posgmc.engines.multi.games`), an **under-approximation**:

* achievability: ``true`` when the thresholds lie in it (the coalition has a strategy; decided);
  otherwise ``false`` with a note that it is not proven (the limit might still reach them);
* numerical (one ``=?``): the largest value of that objective in it under the other threshold, a
  lower bound on the optimum;
* Pareto (two ``=?``): its vertices; no over-approximation.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from posgmc.checking.multi_objectives import (
    Front,
    MultiAnswer,
    MultiKind,
    ProductBuilder,
    objectives_of,
)
from posgmc.engines.graph import end_components
from posgmc.engines.multi import polygon
from posgmc.engines.multi.games import coalition_sets
from posgmc.engines.multi.settle import ConditionKind
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.semantics.queries import reward_structure
from posgmc.syntax.ast import Direction, MultiQuery, ProbQuery, RewardQuery
from posgmc.syntax.printer import format_expr
from posgmc.syntax.traversal import is_temporal

if TYPE_CHECKING:
    from posgmc.checking.protocols import StateFormulaChecker

__all__ = ["answer_game"]


class _Statistics(TypedDict):
    """What every answer of a coalition query reports about its computation."""

    residual: float
    states: int
    seconds: float


def _terminal(model: ExplicitModel) -> np.ndarray:
    """States whose every choice loops on the state with probability 1."""
    t = model.transitions
    owner = model.choice_states
    single = np.diff(t.indptr) == 1
    loops = np.zeros(model.num_choices, dtype=bool)
    loops[single] = t.indices[t.indptr[:-1][single]] == owner[single]
    out: np.ndarray = (
        np.bincount(owner, weights=(~loops).astype(float), minlength=model.num_states) == 0
    )
    return out


def answer_game(checker: StateFormulaChecker, expr: MultiQuery) -> MultiAnswer:
    """Answer ``<<C>> (q1 & q2)`` on an smg (see the module docstring).

    Raises:
        UnsupportedError: the game is not stopping, an objective is outside the fragment, or the
            model has several initial states.
    """
    from posgmc.engines import ltl

    start = time.perf_counter()
    model = checker.model
    if model.initial_states.size != 1:
        raise UnsupportedError(
            "a multi-objective game query needs a single initial state", expr.span
        )
    objectives = objectives_of(expr, checker)
    texts = tuple(format_expr(o.query) for o in objectives)
    builder = ProductBuilder(checker)
    accepting: dict[int, int] = {}
    for i, o in enumerate(objectives):
        if isinstance(o.query, ProbQuery):
            path = o.query.path
            if not is_temporal(path) or not ltl.is_cosafe(path):
                raise UnsupportedError(
                    "in games multi-objective probabilities are of co-safe LTL formulas "
                    '(F "goal", a U b, ...)',
                    o.query.span,
                )
            acc = builder._product(path)  # replaces builder.masks by the lifted list
            # kept in the builder's list so that later products lift it too (only the set is
            # read below: reaching it is the objective)
            builder.masks.append((ConditionKind.MEETS, acc))
            accepting[i] = len(builder.masks) - 1
    m = builder.model
    rewards = np.zeros((m.num_choices, 2))
    for i, o in enumerate(objectives):
        if i in accepting:
            acc = builder.masks[accepting[i]][1]
            into = m.transitions @ acc.astype(float)
            rewards[:, i] = np.where(acc[m.choice_states], 0.0, into)
        else:
            q = o.query
            assert isinstance(q, RewardQuery)  # noqa: S101
            r = reward_structure(m, q).choice_rewards(m.row_groups)
            if (r < 0).any():
                raise UnsupportedError("multi-objective game rewards must be non-negative", q.span)
            rewards[:, i] = r
    terminal = _terminal(m)
    mec_of, _, _ = end_components(m.transitions, m.choice_states, ~terminal[m.choice_states])
    if (mec_of >= 0).any():
        s = int(np.flatnonzero(mec_of >= 0)[0])
        raise UnsupportedError(
            "the game is not stopping: from some states (e.g. "
            f"{m.describe_state(s)}) the players can keep it away from terminal states forever",
            expr.span,
            hint="posgmc's game fragment needs stopping games (Chen et al. 2013): make every "
            "path end in a state that only loops on itself",
        )
    if (rewards[terminal[m.choice_states]] != 0).any():
        raise UnsupportedError("a terminal state collects reward: the total rewards are infinite",
                               expr.span)
    players = checker.coalition_of(expr.coalition)
    mine = (
        np.isin(m.state_players, sorted(players))
        if players is not None
        else np.ones(m.num_states, bool)
    )
    result = coalition_sets(m.transitions, m.row_groups, rewards, mine, terminal, builder.initial)
    chain = result.chain
    seconds = time.perf_counter() - start
    common = _Statistics(residual=0.0, states=m.num_states, seconds=seconds)
    bounds = [o.bound for o in objectives]
    queries = [i for i, b in enumerate(bounds) if b is None]
    if not queries:
        target = np.zeros(2)
        target[: len(bounds)] = bounds
        inside = polygon.contains(chain, target, tolerance=1e-12)
        margin = _margin(chain, target)
        return MultiAnswer(MultiKind.ACHIEVABILITY, texts, achievable=inside, decided=inside,
                           margin=margin, **common)
    if len(queries) == 1:
        (i,) = queries
        other = 1 - i
        given = bounds[other] if other < len(bounds) else None
        floor = given if given is not None else -math.inf
        return MultiAnswer(MultiKind.NUMERICAL, texts, value=_best(chain, i, floor),
                           **common)
    front = Front((texts[0], texts[1]), (Direction.MAX, Direction.MAX), chain, np.zeros((0, 2)),
                  math.inf, result.iterations, result.converged)
    return MultiAnswer(MultiKind.PARETO, texts, front=front, **common)


def _margin(chain: np.ndarray, target: np.ndarray) -> float:
    """How far inside (> 0) or outside (< 0) the set the target lies, along the worst half-plane."""
    rows = polygon._halfplanes(chain)
    return float(np.min(rows[:, 2] - rows[:, :2] @ target))


def _best(chain: np.ndarray, axis: int, floor: float) -> float:
    """``max v[axis]`` over the set's points with ``v[other] >= floor`` (NaN: none)."""
    other = 1 - axis
    best = -math.inf
    for v in chain:
        if v[other] >= floor:
            best = max(best, float(v[axis]))
    for p, q in zip(chain[:-1], chain[1:]):
        lo, hi = sorted((p[other], q[other]))
        if lo <= floor <= hi and hi > lo:
            t = (floor - p[other]) / (q[other] - p[other])
            best = max(best, float(p[axis] + t * (q[axis] - p[axis])))
    return best if best > -math.inf else math.nan
