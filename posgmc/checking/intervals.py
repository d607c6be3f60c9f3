"""Arithmetic over query values with the bounds that hold: interval arithmetic for every operator.

A :class:`QueryValue` holds, per state, a reported value and proven bounds. For numbers,
``lower <= exact <= upper`` when ``sound``. For Booleans, ``lower`` says "proven true" and
``upper`` "possibly true": the value is decided where they agree and undecided where
``lower < upper`` (the exact value is unknown to the engines' precision).

Each operator maps intervals to an interval that contains every result of exact operands from
their intervals: ``+``/``-`` add endpoints; ``*``, ``/`` and functions that are monotone in each
argument (``min``, ``max``, ``floor``, ``ceil``, ``round``, ``pow`` of a positive base, ``log``)
take the extremes over the corners; a comparison is true where the intervals prove it, false
where they refute it, undecided otherwise; ``? :`` over an undecided condition takes the hull of
its branches. Results follow PRISM's double arithmetic: ``x/0`` is infinite (NaN for ``0/0``);
a NaN bound means that no bound can be given in that state, and a result read there (NaN value
or bound) is not ``sound``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from posgmc.engines.result import EngineResult
from posgmc.syntax.ast import BinaryOp, Function

__all__ = ["QueryValue", "exact", "negate", "logical_not", "binary", "ite", "call"]


@dataclass(frozen=True, eq=False)
class QueryValue:
    """The per-state answer to one query (or sub-expression): values with proven bounds."""

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    engine: EngineResult | None = None
    iterations: int = 0
    converged: bool = True
    sound: bool = True
    method: str = "exact"

    @property
    def is_boolean(self) -> bool:
        return self.values.dtype == np.bool_

    @property
    def decided(self) -> np.ndarray:
        """bool[S]: Booleans whose bounds agree, numbers whose bounds coincide."""
        return np.asarray(self.lower == self.upper)


def exact(values: np.ndarray, *, method: str = "exact") -> QueryValue:
    """A value known exactly (a state formula without queries)."""
    return QueryValue(values, values, values, method=method)


def _join(
    values: np.ndarray, lower: np.ndarray, upper: np.ndarray, *parts: QueryValue
) -> QueryValue:
    """A result's record; a NaN bound (no bound holds there) is judged where it is read."""
    return QueryValue(
        values=values,
        lower=lower,
        upper=upper,
        iterations=sum(p.iterations for p in parts),
        converged=all(p.converged for p in parts),
        sound=all(p.sound for p in parts),
        method=next((p.method for p in parts if p.method != "exact"), "exact"),
    )


def _f(a: np.ndarray) -> np.ndarray:
    return a.astype(np.float64) if a.dtype != np.float64 else a


def negate(q: QueryValue) -> QueryValue:
    return replace(q, values=-q.values, lower=-q.upper, upper=-q.lower)


def logical_not(q: QueryValue) -> QueryValue:
    return replace(q, values=~q.values, lower=~q.upper, upper=~q.lower)


ArrayOp = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""A binary function of arrays, elementwise (a ufunc or a composition of them)."""


def _corners(
    op: ArrayOp, a: QueryValue, b: QueryValue
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value and extremes of a function monotone in each argument, over the corners of the box."""
    cands = np.stack([op(_f(x), _f(y)) for x in (a.lower, a.upper) for y in (b.lower, b.upper)])
    lo, hi = np.min(cands, axis=0), np.max(cands, axis=0)  # NaN anywhere stays NaN: not sound
    return op(_f(a.values), _f(b.values)), lo, hi


def _divide(a: QueryValue, b: QueryValue) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    value = np.true_divide(_f(a.values), _f(b.values))
    v, lo, hi = _corners(np.true_divide, a, b)
    zero_inside = (b.lower <= 0) & (b.upper >= 0) & ~((b.lower == 0) & (b.upper == 0))
    # a divisor interval that contains 0 (but is not exactly 0) allows any magnitude
    lo = np.where(zero_inside, -np.inf, lo)
    hi = np.where(zero_inside, np.inf, hi)
    # a numerator that may be 0 over a divisor that may be 0 may be NaN: no bound holds
    maybe_nan = zero_inside & (a.lower <= 0) & (a.upper >= 0)
    lo = np.where(maybe_nan, np.nan, lo)
    hi = np.where(maybe_nan, np.nan, hi)
    return value, lo, hi


_COMPARE = {
    # op: (proven true, possibly true) from the endpoints
    BinaryOp.LT: lambda a, b: (a.upper < b.lower, a.lower < b.upper),
    BinaryOp.LE: lambda a, b: (a.upper <= b.lower, a.lower <= b.upper),
    BinaryOp.GT: lambda a, b: (a.lower > b.upper, a.upper > b.lower),
    BinaryOp.GE: lambda a, b: (a.lower >= b.upper, a.upper >= b.lower),
    BinaryOp.EQ: lambda a, b: (
        (a.lower == a.upper) & (b.lower == b.upper) & (a.lower == b.lower),
        (a.lower <= b.upper) & (b.lower <= a.upper),
    ),
}

_VALUE_OP = {
    BinaryOp.LT: np.less,
    BinaryOp.LE: np.less_equal,
    BinaryOp.GT: np.greater,
    BinaryOp.GE: np.greater_equal,
    BinaryOp.EQ: np.equal,
    BinaryOp.NE: np.not_equal,
    BinaryOp.IFF: np.equal,
}


def binary(op: BinaryOp, a: QueryValue, b: QueryValue) -> QueryValue:
    """``a op b`` with the bounds that hold."""
    with np.errstate(all="ignore"):
        if op is BinaryOp.ADD:
            return _join(a.values + b.values, a.lower + b.lower, a.upper + b.upper, a, b)
        if op is BinaryOp.SUB:
            return _join(a.values - b.values, a.lower - b.upper, a.upper - b.lower, a, b)
        if op is BinaryOp.MUL:
            return _join(*_corners(np.multiply, a, b), a, b)
        if op is BinaryOp.DIV:
            return _join(*_divide(a, b), a, b)
        if op in (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES):
            al, au = (~a.upper, ~a.lower) if op is BinaryOp.IMPLIES else (a.lower, a.upper)
            av = ~a.values if op is BinaryOp.IMPLIES else a.values
            if op is BinaryOp.AND:
                return _join(av & b.values, al & b.lower, au & b.upper, a, b)
            return _join(av | b.values, al | b.lower, au | b.upper, a, b)
        if a.is_boolean or op is BinaryOp.IFF:  # = and != on Booleans, <=>
            decided = (a.lower == a.upper) & (b.lower == b.upper)
            same = a.lower == b.lower
            value = _VALUE_OP[op](a.values, b.values)
            truth = same if op is not BinaryOp.NE else ~same
            return _join(value, decided & truth, ~decided | truth, a, b)
        negated = op is BinaryOp.NE
        proven, possible = _COMPARE[BinaryOp.EQ if negated else op](a, b)
        if negated:
            proven, possible = ~possible, ~proven
        value = np.where(proven == possible, proven, _VALUE_OP[op](a.values, b.values))
        return _join(value, proven, possible, a, b)


def ite(c: QueryValue, a: QueryValue, b: QueryValue) -> QueryValue:
    """``c ? a : b``: the chosen branch where ``c`` is decided, the hull of both elsewhere."""
    value = np.where(c.values, a.values, b.values)
    if a.is_boolean:
        hull_lo, hull_hi = a.lower & b.lower, a.upper | b.upper
    else:
        hull_lo, hull_hi = np.minimum(a.lower, b.lower), np.maximum(a.upper, b.upper)
    lower = np.where(c.lower, a.lower, np.where(~c.upper, b.lower, hull_lo))
    upper = np.where(c.lower, a.upper, np.where(~c.upper, b.upper, hull_hi))
    return _join(value, lower, upper, c, a, b)


def call(function: Function, args: Sequence[QueryValue]) -> QueryValue:
    """A function of query values. Domain failures (``floor`` of an infinite value, ``mod`` by a
    non-positive number, a negative integer exponent) are the caller's to report: they are decided
    on the reported values, as for state formulas."""
    with np.errstate(all="ignore"):
        if function in (Function.MIN, Function.MAX):
            pick = np.minimum if function is Function.MIN else np.maximum
            v, lo, hi = args[0].values, args[0].lower, args[0].upper
            for q in args[1:]:
                v, lo, hi = pick(v, q.values), pick(lo, q.lower), pick(hi, q.upper)
            return _join(v, lo, hi, *args)
        if function in (Function.FLOOR, Function.CEIL, Function.ROUND):
            rounding: dict[Function, Callable[[np.ndarray], np.ndarray]] = {
                Function.FLOOR: np.floor,
                Function.CEIL: np.ceil,
                Function.ROUND: lambda x: np.floor(x + 0.5),
            }
            f = rounding[function]
            q = args[0]
            return _join(f(_f(q.values)), f(_f(q.lower)), f(_f(q.upper)), q)
        if function is Function.POW:
            base, exp = args
            v, lo, hi = _corners(np.power, base, exp)
            negative = base.lower < 0  # not monotone: no bound unless the value is exact
            point = (base.lower == base.upper) & (exp.lower == exp.upper)
            lo = np.where(negative & ~point, np.nan, lo)
            hi = np.where(negative & ~point, np.nan, hi)
            return _join(v, lo, hi, base, exp)
        if function is Function.MOD:
            a, n = args
            v = np.mod(a.values, np.where(n.values > 0, n.values, 1))
            point = (a.lower == a.upper) & (n.lower == n.upper)
            lo = np.where(point, v, 0)
            hi = np.where(point, v, np.maximum(n.upper - 1, 0))
            return _join(v, lo, hi, a, n)
        if function is Function.LOG:
            x, base = args
            v, lo, hi = _corners(lambda p, q: np.log(p) / np.log(q), x, base)
            return _join(v, lo, hi, x, base)
    raise ValueError(f"unknown function {function}")
