"""What the checkers answer, as protocols: every checker checks a property (:class:`Checker`: the
plain :class:`~posgmc.checking.property_checker.PropertyChecker`, PRISM's exact mode, the checker
under given strategies and the synthesis checker), and the multi-objective answers ask for state
formulas on the model and its products (:class:`StateFormulaChecker`).

The multi-objective code receives a checker through these protocols instead of importing (and
constructing) the checker it is called from, so imports go one way.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from posgmc.checking.intervals import QueryValue
    from posgmc.checking.results import PropertyResult
    from posgmc.model.explicit import ExplicitModel
    from posgmc.semantics.evaluate import Value
    from posgmc.syntax.ast import Coalition, Expr

__all__ = ["Checker", "StateFormulaChecker"]


class Checker(Protocol):
    """Checks one property on its model and reports the value at the initial states."""

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult: ...


class StateFormulaChecker(Protocol):
    """Evaluates state formulas and constant expressions of one model's queries."""

    model: ExplicitModel
    coalition_of: Callable[[Coalition | None], frozenset[int] | None]
    scalar: Callable[[Expr], Value]

    def state_value(self, expr: Expr) -> QueryValue:
        """The formula's value in every state of :attr:`model`."""
        ...

    def step_bound(self, e: Expr | None) -> int:
        """A step bound's value: a non-negative integer."""
        ...

    def for_model(self, model: ExplicitModel) -> StateFormulaChecker:
        """The same checker on another model (a product of :attr:`model`)."""
        ...
