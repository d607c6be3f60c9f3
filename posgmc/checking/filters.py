"""PRISM's filters, ``filter(op, prop, states)``, over per-state values with proven bounds.

The meaning is PRISM's (``prism/src/explicit/StateModelChecker.java``, ``checkExpressionFilter``;
``ExpressionFilter.apply*``): ``op`` combines the operand's values in the states satisfying
``states`` (all states when none is given; none at all is an error) into one value, the same in
every state; ``argmin``/``argmax`` give the set of those states where the value is (close to) the
minimum/maximum; ``print``/``printall`` leave the values as they are (posgmc prints nothing: the
per-state values are on the result); ``state`` needs exactly one state; ``first`` takes the lowest
numbered one.

Bounds carry through: each operator is monotone in every operand value, so it maps the lower and
the upper bounds to bounds of the result (``count`` of Booleans counts the proven and the
possibly true states).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from posgmc.checking.intervals import QueryValue
from posgmc.errors import SemanticError, SourceSpan, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import FilterOp

__all__ = ["CLOSE_RELATIVE", "apply_filter"]

CLOSE_RELATIVE = 1e-5
"""How close to the optimum a value must be to count for ``argmin``/``argmax`` (PRISM's
``getBitSetFromCloseValue`` uses its default relative termination epsilon)."""


def apply_filter(
    model: ExplicitModel,
    op: FilterOp,
    q: QueryValue,
    states: np.ndarray,
    *,
    span: SourceSpan | None,
    states_text: str,
) -> QueryValue:
    """The filter's value in every state.

    Args:
        model: the model (for its number of states and for naming states in messages).
        op: the filter operator.
        q: the operand's per-state values and bounds.
        states: bool[S], the states the filter ranges over.
        span: where the filter is written (for errors).
        states_text: the states formula as written (for errors).

    Raises:
        SemanticError: no state satisfies ``states``; ``state`` over more than one state.
        UnsupportedError: ``range`` (PRISM reports an interval of values, which is not one value).
    """
    where = np.flatnonzero(states)
    if where.size == 0:
        raise SemanticError("filter satisfies no states", span,
                            hint=f"no state satisfies {states_text}")
    if op in (FilterOp.PRINT, FilterOp.PRINTALL):
        return q
    if op is FilterOp.RANGE:
        raise UnsupportedError(
            "filter range: PRISM reports an interval of values, which posgmc does not", span,
            hint="ask for filter(min, ...) and filter(max, ...) separately")
    if op is FilterOp.STATE and where.size != 1:
        raise SemanticError(
            f"filter should be satisfied in exactly 1 state (but {states_text} is true in "
            f"{where.size} states)", span)
    if op in (FilterOp.STATE, FilterOp.FIRST):
        s = int(where[0])
        return _constant(model, q, q.values[s], q.lower[s], q.upper[s])
    values, lower, upper = q.values[where], q.lower[where], q.upper[where]
    if op in (FilterOp.ARGMIN, FilterOp.ARGMAX):
        return _arg(model, op, q, where)
    if op is FilterOp.MIN:
        return _constant(model, q, values.min(), lower.min(), upper.min())
    if op is FilterOp.MAX:
        return _constant(model, q, values.max(), lower.max(), upper.max())
    if op is FilterOp.SUM:
        return _constant(model, q, values.sum(), lower.sum(), upper.sum())
    if op is FilterOp.AVG:
        n = float(where.size)
        return _constant(model, q, values.sum() / n, lower.sum() / n, upper.sum() / n)
    if op is FilterOp.COUNT:
        return _constant(model, q, np.int64(values.sum()), np.int64(lower.sum()),
                         np.int64(upper.sum()))
    if op is FilterOp.FORALL:
        return _constant(model, q, values.all(), lower.all(), upper.all())
    if op is FilterOp.EXISTS:
        return _constant(model, q, values.any(), lower.any(), upper.any())
    raise UnsupportedError(f"filter {op.value} is not supported", span)


def _constant(model: ExplicitModel, q: QueryValue, value: object, lower: object,
              upper: object) -> QueryValue:
    """One value in every state, with the operand's provenance."""
    n = model.num_states

    def full(x: object) -> np.ndarray:
        return np.full(n, x, dtype=np.asarray(x).dtype)

    return replace(q, values=full(value), lower=full(lower), upper=full(upper))


def _arg(model: ExplicitModel, op: FilterOp, q: QueryValue, where: np.ndarray) -> QueryValue:
    """``argmin``/``argmax``: the states of ``where`` whose value is close to the optimum;
    proven where the state's bounds show it optimal, possible where they allow it."""
    sign = 1.0 if op is FilterOp.ARGMIN else -1.0
    values = sign * q.values[where].astype(np.float64)
    # for argmax the bounds swap with the sign
    lower = sign * (q.lower if sign > 0 else q.upper)[where].astype(np.float64)
    upper = sign * (q.upper if sign > 0 else q.lower)[where].astype(np.float64)
    best = values.min()
    close = np.abs(values - best) <= CLOSE_RELATIVE * np.abs(best)
    proven = upper <= lower.min()
    possible = lower <= upper.min() + CLOSE_RELATIVE * np.abs(upper.min())
    out = np.zeros(model.num_states, dtype=np.bool_)
    lo, hi = out.copy(), out.copy()
    out[where], lo[where], hi[where] = close, proven, possible | close
    return replace(q, values=out, lower=lo & out, upper=hi | out)
