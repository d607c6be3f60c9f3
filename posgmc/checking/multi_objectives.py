"""The records both multi-objective answers share (the LP answer on mdps in
:mod:`posgmc.checking.multi`, the game answer on smgs in :mod:`posgmc.checking.multi_games`): the
query's kind, a Pareto front, the typed answer, each objective in the LP's maximising sense, and the
product grown objective by objective.

The checker they need is passed in (:class:`~posgmc.checking.protocols.StateFormulaChecker`): this
module evaluates state formulas through it and never constructs one of its own.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from posgmc.checking.protocols import StateFormulaChecker
from posgmc.engines.multi.settle import Condition, ConditionKind
from posgmc.errors import SemanticError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import (
    NO_SPAN,
    ComparisonOp,
    Direction,
    Expr,
    MultiQuery,
    ProbQuery,
    RewardQuery,
    Temporal,
    TemporalOp,
    Unary,
    UnaryOp,
)
from posgmc.syntax.traversal import is_temporal

__all__ = ["MultiKind", "Front", "MultiAnswer", "Objective", "objectives_of", "unary_chain",
           "ProductBuilder"]


class MultiKind(enum.Enum):
    ACHIEVABILITY = "achievability"
    NUMERICAL = "numerical"
    PARETO = "pareto"


@dataclass(frozen=True, eq=False)
class Front:
    """A Pareto front of n >= 2 objectives in the objectives' own units (a minimised one as
    itself).

    ``points``: float64[m, n], achievable vertices (the under-approximation is their convex
    hull, closed towards the worse values); ``corners``: float64[k, n], the vertices of the
    over-approximation (no strategy achieves a point beyond it); ``precision``: the largest
    distance between the two (Euclidean for n = 2; for n >= 3 the largest uniform shift of a
    corner, in every objective at once, into the under-approximation); ``converged``: every
    segment (facet) was closed within the tolerance.
    """

    objectives: tuple[str, ...]
    directions: tuple[Direction, ...]
    points: np.ndarray
    corners: np.ndarray
    precision: float
    solves: int
    converged: bool

    def text(self) -> str:
        """PRISM's form: ``[(x1,y1),(x2,y2)]`` (n numbers per point for n objectives)."""
        return "[" + ",".join("(" + ",".join(f"{v:.10g}" for v in p) + ")"
                              for p in self.points) + "]"

    def to_json(self) -> dict[str, Any]:
        return {
            "objectives": list(self.objectives),
            "directions": [d.value for d in self.directions],
            "points": self.points.tolist(),
            "over_approximation": self.corners.tolist(),
            "precision": self.precision if math.isfinite(self.precision) else None,
            "solves": self.solves,
            "converged": self.converged,
        }


@dataclass(frozen=True, eq=False)
class MultiAnswer:
    """The typed answer to a ``multi(...)`` query.

    ``achievable`` (achievability): the LP's verdict; ``decided``: it holds with the margin
    ``margin`` (> 0: every constraint met with that much room; < 0: some constraint missed by
    that much). ``value`` (numerical): the optimum in the objective's units (NaN: the constraints
    cannot be met). ``front`` (Pareto). ``residual``: the largest violation of the LP's equations
    by the solution reported. ``states``: the size of the LP's MDP (product and unfolding).
    ``proven`` (achievability): ``true`` is proven: the strategy of the LP's solution, re-checked
    by the sound engines on the chain it induces, meets every threshold. ``certified``
    (numerical): a proven bound on the optimum from such a re-checked strategy, a lower bound for
    a maximised objective, an upper bound for a minimised one (``minimised``; NaN: nothing
    proven).
    """

    kind: MultiKind
    objectives: tuple[str, ...]
    achievable: bool | None = None
    decided: bool = True
    margin: float = float("nan")
    value: float = float("nan")
    front: Front | None = None
    residual: float = 0.0
    states: int = 0
    seconds: float = 0.0
    proven: bool = False
    certified: float = float("nan")
    minimised: bool = False


@dataclass(frozen=True)
class Objective:
    query: ProbQuery | RewardQuery
    minimise: bool  # Pmin/Rmin, or an upper bound P<=p / R<=r: enters the LP complemented/negated
    bound: float | None  # the threshold as written (None for =?)

    @property
    def is_probability(self) -> bool:
        return isinstance(self.query, ProbQuery)

    def lp_bound(self) -> float:
        """The threshold in the LP's maximising sense."""
        assert self.bound is not None  # noqa: S101
        if not self.minimise:
            return self.bound
        return 1.0 - self.bound if self.is_probability else -self.bound

    def reported(self, v: float) -> float:
        """An LP value (maximising sense) in the objective's own units."""
        if not self.minimise:
            return v + 0.0
        return 1.0 - v if self.is_probability else 0.0 - v

    @property
    def scale_of_bound(self) -> float:
        return 1.0 if self.is_probability or self.bound is None else max(1.0, abs(self.bound))


def objectives_of(expr: MultiQuery, checker: StateFormulaChecker) -> list[Objective]:
    out = []
    for q in expr.objectives:
        if not isinstance(q, (ProbQuery, RewardQuery)):  # pragma: no cover - semantics reject it
            raise SemanticError("each argument of multi(...) must be a P or R query", q.span)
        if q.threshold is not None:
            minimise = q.threshold.op in (ComparisonOp.LE, ComparisonOp.LT)
            bound = float(checker.scalar(q.threshold.value))
        else:
            if q.direction is None:
                raise SemanticError("=? in multi(...) needs a direction", q.span,
                                    hint="write Pmax=?/Pmin=? or Rmax=?/Rmin=?")
            minimise, bound = q.direction is Direction.MIN, None
        out.append(Objective(q, minimise, bound))
    return out


def unary_chain(path: Expr, outer: TemporalOp, inner: TemporalOp) -> Expr | None:
    """``a`` if ``path`` is ``outer inner a`` (``G F a``, ``F G a``) without bounds."""
    if (
        isinstance(path, Temporal) and path.op is outer and path.bound is None
        and isinstance(path.operands[0], Temporal) and path.operands[0].op is inner
        and path.operands[0].bound is None and not is_temporal(path.operands[0].operands[0])
    ):
        return path.operands[0].operands[0]
    return None


class ProductBuilder:
    """The product MDP grown objective by objective, with each condition's mask kept current."""

    def __init__(self, checker: StateFormulaChecker) -> None:
        self.base = checker
        self.model: ExplicitModel = checker.model
        self.initial = int(checker.model.initial_states[0])
        self.masks: list[tuple[ConditionKind, np.ndarray]] = []

    def _checker(self) -> StateFormulaChecker:
        return self.base.for_model(self.model)

    def _states(self, e: Expr) -> np.ndarray:
        values = self._checker().state_value(e).values
        if values.dtype != np.bool_:
            raise SemanticError("expected a boolean state formula", e.span)
        return values

    def _product(self, path: Expr) -> np.ndarray:
        """Grow the product by the DFA of the co-safe ``path``; its accepting set."""
        from posgmc.engines import ltl

        atoms = ltl.extract_atoms(path)
        dfa = ltl.to_dfa(path, atoms)
        S = self.model.num_states
        values = np.stack([self._states(a) for a in atoms]) if atoms else np.zeros((0, S), bool)
        prod = ltl.product(self.model, dfa, values)
        self.masks = [(k, m[prod.state_of]) for k, m in self.masks]
        self.model = prod.model
        self.initial = int(prod.initial_map[0])
        return prod.accepting

    def add_probability(self, obj: Objective) -> int:
        """Add the condition of a probability objective (in the LP's maximising sense)."""
        from posgmc.engines import ltl

        path = obj.query.path  # type: ignore[union-attr]
        S = self.model.num_states
        if not is_temporal(path):
            holds = bool(self._states(path)[self.initial])
            cond = Condition(ConditionKind.INSIDE, np.full(S, holds))
        elif (a := unary_chain(path, TemporalOp.GLOBALLY, TemporalOp.EVENTUALLY)) is not None:
            cond = Condition(ConditionKind.MEETS, self._states(a))
        elif (a := unary_chain(path, TemporalOp.EVENTUALLY, TemporalOp.GLOBALLY)) is not None:
            cond = Condition(ConditionKind.INSIDE, self._states(a))
        elif ltl.is_cosafe(path):
            cond = Condition(ConditionKind.INSIDE, self._product(path))
        else:
            negated = Unary(UnaryOp.NOT, path, span=path.span)
            if not ltl.is_cosafe(negated):
                raise UnsupportedError(
                    "multi(...) supports co-safe LTL, its negation (safety), G F a and F G a; "
                    "this path formula is none of them",
                    path.span if path.span != NO_SPAN else obj.query.span,
                )
            cond = Condition(ConditionKind.INSIDE, ~self._product(negated))
        if obj.minimise:
            cond = cond.negated()
        self.masks.append((cond.kind, cond.states))
        return len(self.masks) - 1


