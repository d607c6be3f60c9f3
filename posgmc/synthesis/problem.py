"""One synthesis problem as every phase and every worker sees it: the model, the property, the
objective's arrays and who decides; the check options candidates are ranked with; the deadline test.

A :class:`Problem` is picklable and depends on nothing but its fields, so the jobs of
:mod:`posgmc.synthesis.executors` can run on it in any process.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from posgmc.checking.property_checker import CheckOptions
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import Coalition, Direction, ProbQuery, RewardQuery
from posgmc.synthesis import budget

__all__ = ["Problem", "POLICY", "expired"]

POLICY = CheckOptions(solver=SolverOptions(method=Method.POLICY, prove=False))
"""Exact linear solves (policy iteration): how candidates are ranked, never what is reported."""


@dataclass(frozen=True, eq=False)
class Problem:
    """One synthesis problem. ``query``: the bare query with its direction set; ``player``: the
    decision maker; ``adversary``: the other player (None for a pomdp); ``coalition``: the
    players the query's coalition names; ``target``/``remain``: bool[S] (where ``b`` and ``a`` of
    ``a U b`` hold); ``rewards``: float64[C] per choice (None for a probability); ``discount``:
    1 unless the objective is discounted; ``scalar``: a picklable constant evaluator."""

    model: ExplicitModel
    query: ProbQuery | RewardQuery
    player: int
    adversary: int | None
    coalition: frozenset[int]
    target: np.ndarray
    remain: np.ndarray
    rewards: np.ndarray | None
    discount: float
    scalar: Callable[[Any], Any]

    @property
    def maximize(self) -> bool:
        return self.query.direction is Direction.MAX

    @property
    def sign(self) -> float:
        """+1 when the decision maker maximises, -1 when it minimises."""
        return 1.0 if self.maximize else -1.0

    def coalition_of(self, coalition: Coalition | None) -> frozenset[int] | None:
        """The coalition resolver of this problem's one query."""
        return None if coalition is None else self.coalition


def expired(deadline: float | None) -> bool:
    """Whether ``deadline`` (a ``time.perf_counter()`` value: CLOCK_MONOTONIC on Linux, the same
    clock in every process of the machine; the wall-clock cap) has passed, or a stop was
    requested (Ctrl-C: :func:`posgmc.synthesis.budget.expired`)."""
    return budget.expired(deadline)
