"""Interval arithmetic over per-state values: how proven bounds travel through PRISM's operators.

A query answers, per state, a reported value and proven bounds ``lower <= exact <= upper``. An
expression over queries (``min(P=? [..], 1)``, ``P=? [..] / R=? [..]``, ``P=? [..] > 0.5``,
``c ? P=? [..] : 0``) must carry those bounds through every operator, so that the bounds it reports
still hold:

* numbers: :class:`Bounds` with float64 ``lower``/``upper``/``value``; a monotone operator maps
  endpoints, ``*`` and ``/`` take the hull of the four endpoint combinations, ``/`` by an interval
  containing 0 is unbounded (``[-inf, inf]``) and undefined (NaN) where 0/0 is possible;
* Booleans: ``lower``/``upper`` are bool arrays ordered ``False < True``: ``lower`` True means
  *proven true*, ``upper`` False *proven false*, otherwise the value is **undecided**. A comparison
  against an interval that straddles the other side is undecided, never guessed; ``? :`` over an
  undecided condition takes the hull of both branches.

Point values (exact arithmetic, no query involved) are evaluated by
:mod:`posgmc.checking.states` with PRISM's rules; this module only combines bounds. ``value`` is the
operator applied to the reported values (IEEE: ``x/0`` is an infinity, ``0/0`` NaN, as in PRISM).
``defined`` is False where the exact result may be undefined (NaN): such bounds are not a proof.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from posgmc.semantics import operators as ops
from posgmc.syntax.ast import BinaryOp, Function, UnaryOp

__all__ = ["Bounds", "binary", "call", "ite", "point", "unary"]


@dataclass(frozen=True, eq=False)
class Bounds:
    """Per-state bounds: numbers (float64) or Booleans (bool, ``False < True``).

    ``value``: the reported value; ``lower``/``upper``: proven bounds on the exact value wherever
    ``defined`` is True (the exact value may be NaN where it is False).
    """

    value: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    defined: np.ndarray

    @property
    def is_bool(self) -> bool:
        return self.value.dtype == np.bool_

    @property
    def decided(self) -> np.ndarray:
        """bool[S]: the bounds pin the value down (always true for a point)."""
        return np.asarray((self.lower == self.upper) & self.defined, dtype=bool)


def point(values: np.ndarray) -> Bounds:
    """An exactly known value (bools stay bools, numbers become float64)."""
    v = values if values.dtype == np.bool_ else values.astype(np.float64)
    defined = np.ones(v.shape, dtype=bool) if v.dtype == np.bool_ else ~np.isnan(v)
    return Bounds(v, v, v, defined)


def _num(lo: np.ndarray, hi: np.ndarray, v: np.ndarray, defined: np.ndarray) -> Bounds:
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    defined = defined & ~np.isnan(lo) & ~np.isnan(hi)
    # an undefined bound proves nothing: widen it to the whole line
    lo = np.where(defined, lo, -np.inf)
    hi = np.where(defined, hi, np.inf)
    return Bounds(v, lo, hi, defined & ~np.isnan(v))


def _boolean(lo: np.ndarray, hi: np.ndarray, v: np.ndarray, defined: np.ndarray) -> Bounds:
    return Bounds(np.asarray(v, bool), np.asarray(lo, bool), np.asarray(hi, bool), defined)


def unary(op: UnaryOp, a: Bounds) -> Bounds:
    """``!a`` or ``-a``: both antitone, so the endpoints swap."""
    if op is UnaryOp.NOT:
        return _boolean(~a.upper, ~a.lower, ~a.value, a.defined)
    return _num(-a.upper, -a.lower, -a.value, a.defined)


def _products(a_lo: np.ndarray, a_hi: np.ndarray, b_lo: np.ndarray, b_hi: np.ndarray):  # type: ignore[no-untyped-def]
    c = np.stack([a_lo * b_lo, a_lo * b_hi, a_hi * b_lo, a_hi * b_hi])
    # 0 * inf at an endpoint: the limit of the products inside the box is 0 (interval arithmetic
    # over the extended reals); it is not a value that is attained as NaN
    c = np.where(np.isnan(c), 0.0, c)
    return c.min(axis=0), c.max(axis=0)


def _divide(a: Bounds, b: Bounds, value: np.ndarray) -> Bounds:
    nonzero = (b.lower > 0) | (b.upper < 0)
    # the four corner quotients, each rounded once: rounding is monotone, so they bracket the
    # rounded quotient of any two points inside (multiplying by a rounded reciprocal would not)
    c = np.stack([a.lower / b.lower, a.lower / b.upper, a.upper / b.lower, a.upper / b.upper])
    c = np.where(np.isnan(c), 0.0, c)  # inf/inf at a corner: only where b is unbounded
    lo, hi = c.min(axis=0), c.max(axis=0)
    # a divisor that is exactly 0: x/0 is +-inf by the sign of x, 0/0 undefined (IEEE, as PRISM)
    zero = (b.lower == 0) & (b.upper == 0)
    pos, neg = a.lower > 0, a.upper < 0
    lo = np.where(nonzero, lo, np.where(zero & pos, np.inf, -np.inf))
    hi = np.where(nonzero, hi, np.where(zero & neg, -np.inf, np.inf))
    may_nan = ~nonzero & (a.lower <= 0) & (a.upper >= 0)
    return _num(lo, hi, value, a.defined & b.defined & ~may_nan)


def _compare(op: BinaryOp, a: Bounds, b: Bounds, value: np.ndarray) -> Bounds:
    defined = a.defined & b.defined
    if op in (BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE):
        if op in (BinaryOp.GT, BinaryOp.GE):
            a, b = b, a
            op = BinaryOp.LT if op is BinaryOp.GT else BinaryOp.LE
        f = np.less if op is BinaryOp.LT else np.less_equal
        # a < b is proven when even a's largest value is below b's smallest, possible when
        # a's smallest is below b's largest
        return _boolean(f(a.upper, b.lower), f(a.lower, b.upper), value, defined)
    if a.is_bool:
        equal_lo = (a.lower & b.lower) | (~a.upper & ~b.upper)
        equal_hi = (a.upper & b.upper) | (~a.lower & ~b.lower)
    else:
        equal_lo = (a.lower == a.upper) & (b.lower == b.upper) & (a.lower == b.lower)
        equal_hi = (a.lower <= b.upper) & (b.lower <= a.upper)
    if op in (BinaryOp.EQ, BinaryOp.IFF):
        return _boolean(equal_lo, equal_hi, value, defined)
    return _boolean(~equal_hi, ~equal_lo, value, defined)


def binary(op: BinaryOp, a: Bounds, b: Bounds) -> Bounds:
    """``a op b`` for every binary operator of the language; the reported value is the operator
    table's (:data:`posgmc.semantics.operators.BINARY`) applied to the reported values."""
    defined = a.defined & b.defined
    value = ops.BINARY[op].vector(a.value, b.value)
    with np.errstate(all="ignore"):
        if op is BinaryOp.AND:
            return _boolean(a.lower & b.lower, a.upper & b.upper, value, defined)
        if op is BinaryOp.OR:
            return _boolean(a.lower | b.lower, a.upper | b.upper, value, defined)
        if op is BinaryOp.IMPLIES:
            return binary(BinaryOp.OR, unary(UnaryOp.NOT, a), b)
        if op in (BinaryOp.IFF, BinaryOp.EQ, BinaryOp.NE, BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE):
            return _compare(op, a, b, value)
        if op is BinaryOp.ADD:
            return _num(a.lower + b.lower, a.upper + b.upper, value, defined)
        if op is BinaryOp.SUB:
            return _num(a.lower - b.upper, a.upper - b.lower, value, defined)
        if op is BinaryOp.MUL:
            lo, hi = _products(a.lower, a.upper, b.lower, b.upper)
            return _num(lo, hi, value, defined)
        return _divide(a, b, value)


def ite(c: Bounds, a: Bounds, b: Bounds) -> Bounds:
    """``c ? a : b``: the chosen branch where ``c`` is decided, the hull of both where not."""
    take_a, take_b = c.lower, ~c.upper
    value = np.where(c.value, a.value, b.value)
    lo = np.where(take_a, a.lower, np.where(take_b, b.lower, np.minimum(a.lower, b.lower)))
    hi = np.where(take_a, a.upper, np.where(take_b, b.upper, np.maximum(a.upper, b.upper)))
    defined = c.defined & np.where(take_a, a.defined, np.where(take_b, b.defined, a.defined & b.defined))
    if a.is_bool:
        return _boolean(lo, hi, value, defined)
    return _num(lo, hi, value, defined)


def _monotone(f: Callable[[np.ndarray], np.ndarray], a: Bounds) -> Bounds:
    return _num(f(a.lower), f(a.upper), f(a.value), a.defined)


def _ln(a: Bounds) -> Bounds:
    lo = np.where(a.lower < 0, np.nan, np.log(np.maximum(a.lower, 0.0)))
    return _num(lo, np.log(a.upper), np.log(a.value), a.defined & (a.lower >= 0))


def _pow(a: Bounds, b: Bounds) -> Bounds:
    value = ops.float_pow(a.value, b.value)
    # for a positive base x^y is monotone in each argument on its own, so its extremes over a box
    # lie at the corners; a base that may be negative gives no useful bound
    corners = np.stack(
        [np.power(a.lower, b.lower), np.power(a.lower, b.upper), np.power(a.upper, b.lower), np.power(a.upper, b.upper)]
    )
    positive = a.lower > 0
    is_point = (a.lower == a.upper) & (b.lower == b.upper)
    lo = np.where(positive | is_point, np.nanmin(corners, axis=0), -np.inf)
    hi = np.where(positive | is_point, np.nanmax(corners, axis=0), np.inf)
    return _num(lo, hi, value, a.defined & b.defined & (positive | is_point))


def call(function: Function, args: Sequence[Bounds]) -> Bounds:
    """A function of the language applied to bounds.

    ``floor``/``ceil``/``round`` of a value that may be non-finite, and ``mod``, are decided by the
    caller on point values (they are errors or integers there); here they map endpoints.
    """
    with np.errstate(all="ignore"):
        if function in (Function.MIN, Function.MAX):
            f = np.minimum if function is Function.MIN else np.maximum
            out = args[0]
            for b in args[1:]:
                out = _num(f(out.lower, b.lower), f(out.upper, b.upper), f(out.value, b.value), out.defined & b.defined)
            return out
        if function is Function.FLOOR:
            return _monotone(np.floor, args[0])
        if function is Function.CEIL:
            return _monotone(np.ceil, args[0])
        if function is Function.ROUND:
            return _monotone(lambda x: np.floor(x + 0.5), args[0])
        if function is Function.POW:
            return _pow(args[0], args[1])
        if function is Function.LOG:
            num, den = _ln(args[0]), _ln(args[1])
            return _divide(num, den, ops.log(args[0].value, args[1].value))
        # MOD: ints only; the type checker keeps query values (doubles) out of it
        a, b = args
        return _num(np.mod(a.lower, b.lower), np.mod(a.upper, b.upper), np.mod(a.value, b.value), a.decided & b.decided)
