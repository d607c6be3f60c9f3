"""Interval arithmetic encloses every exact result (hypothesis): for points drawn inside the
operands' intervals, the operator's exact value lies in the result's interval, and a decided
comparison agrees with it."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.checking import intervals as iv
from posgmc.syntax.ast import BinaryOp, Function

finite = st.floats(-50, 50, allow_nan=False)


@st.composite
def boxed(draw: st.DrawFn) -> tuple[iv.QueryValue, float]:
    a, b = sorted((draw(finite), draw(finite)))
    t = draw(st.floats(0, 1))
    point = min(max(a + t * (b - a), a), b)  # rounding may leave the interval
    q = iv.QueryValue(np.array([point]), np.array([a]), np.array([b]))
    return q, point


def _inside(q: iv.QueryValue, exact: float) -> bool:
    lo, hi = float(q.lower[0]), float(q.upper[0])
    if math.isnan(lo) or math.isnan(hi):
        return True  # no bound claimed
    if math.isnan(exact):
        return False
    if math.isinf(exact):
        return lo <= exact <= hi
    tol = 1e-9 * max(1.0, abs(exact))
    return lo - tol <= exact <= hi + tol


@settings(max_examples=300, deadline=None)
@given(boxed(), boxed(), st.sampled_from([BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL, BinaryOp.DIV]))
def test_arithmetic_encloses(a: tuple, b: tuple, op: BinaryOp) -> None:
    (qa, x), (qb, y) = a, b
    r = iv.binary(op, qa, qb)
    with np.errstate(all="ignore"):
        exact = {BinaryOp.ADD: x + y, BinaryOp.SUB: x - y, BinaryOp.MUL: x * y,
                 BinaryOp.DIV: float(np.true_divide(x, y))}[op]
    assert _inside(r, exact)


@settings(max_examples=300, deadline=None)
@given(boxed(), boxed(), st.sampled_from([BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE,
                                          BinaryOp.EQ, BinaryOp.NE]))
def test_comparisons_decide_only_what_holds(a: tuple, b: tuple, op: BinaryOp) -> None:
    (qa, x), (qb, y) = a, b
    r = iv.binary(op, qa, qb)
    exact = {BinaryOp.LT: x < y, BinaryOp.LE: x <= y, BinaryOp.GT: x > y, BinaryOp.GE: x >= y,
             BinaryOp.EQ: x == y, BinaryOp.NE: x != y}[op]
    if r.lower[0] == r.upper[0]:
        assert bool(r.lower[0]) == exact
    else:
        assert not r.lower[0] and r.upper[0]


@settings(max_examples=200, deadline=None)
@given(boxed(), boxed(), st.sampled_from([Function.MIN, Function.MAX, Function.FLOOR,
                                          Function.CEIL, Function.ROUND]))
def test_monotone_functions_enclose(a: tuple, b: tuple, fn: Function) -> None:
    (qa, x), (qb, y) = a, b
    args = [qa, qb] if fn in (Function.MIN, Function.MAX) else [qa]
    r = iv.call(fn, args)
    exact = {Function.MIN: min(x, y), Function.MAX: max(x, y), Function.FLOOR: math.floor(x),
             Function.CEIL: math.ceil(x), Function.ROUND: math.floor(x + 0.5)}[fn]
    assert _inside(r, exact)


@settings(max_examples=200, deadline=None)
@given(boxed(), boxed(), boxed())
def test_ite_over_an_undecided_condition_takes_the_hull(c: tuple, a: tuple, b: tuple) -> None:
    (qc, z), (qa, x), (qb, y) = c, a, b
    cond = iv.binary(BinaryOp.GT, qc, iv.exact(np.array([0.0])))
    r = iv.ite(cond, qa, qb)
    assert _inside(r, x if z > 0 else y)
