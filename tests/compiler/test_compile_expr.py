"""Compiled numpy expressions against PRISM's semantics, value by value.

Expected values follow PRISM's ``ExpressionFunc``/``ExpressionBinaryOp`` (quoted in
``posgmc/compiler/compile_expr.py``): ``mod`` never negative, ``/`` always a double, ``floor``/
``ceil``/``round`` ints with ``round(x) = floor(x + 1/2)``, integer ``pow`` needs a non-negative
exponent.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from posgmc.compiler.compile_expr import Columns, EvaluationError, ExprType, compile_expr
from tests.compiler.flatlib import ex

SLOTS = {"x": (0, ExprType.INT), "y": (1, ExprType.INT), "b": (2, ExprType.BOOL)}


def run(
    text: str, x: list[int], y: list[int] | None = None, b: list[bool] | None = None
) -> np.ndarray:
    n = len(x)
    cols = Columns(
        [
            np.array(x, dtype=np.int64),
            np.array(y or [0] * n, dtype=np.int64),
            np.array(b or [False] * n),
        ],
        n,
    )
    return compile_expr(ex(text), SLOTS).evaluate(cols)


def test_mod_is_never_negative() -> None:
    # PRISM: mod(-1, 3) = 2 (adds the divisor to Java's negative remainder)
    assert run("mod(x, 3)", [-4, -1, 0, 2, 5]).tolist() == [2, 2, 0, 2, 2]


def test_mod_by_non_positive_fails_on_the_first_bad_row() -> None:
    with pytest.raises(EvaluationError) as info:
        run("mod(7, y)", [0, 0, 0], [2, 0, -1])
    assert info.value.row == 1 and "non-positive divisor (0)" in info.value.message


def test_division_is_a_double() -> None:
    out = run("x / 2", [1, 3])
    assert out.dtype == np.float64 and out.tolist() == [0.5, 1.5]
    assert compile_expr(ex("1 / 3"), SLOTS).constant == Fraction(1, 3)


def test_floor_ceil_round() -> None:
    assert run("floor(x / 2)", [-3, -1, 3]).tolist() == [-2, -1, 1]
    assert run("ceil(x / 2)", [-3, -1, 3]).tolist() == [-1, 0, 2]
    # Java Math.round: halves go up, also for negative numbers
    assert run("round(x / 2)", [-3, -1, 1, 3]).tolist() == [-1, 0, 1, 2]
    assert run("floor(x)", [4]).dtype == np.int64


def test_floor_of_a_non_finite_value_fails() -> None:
    with pytest.raises(EvaluationError) as info:
        run("floor(1 / x)", [1, 0])
    assert info.value.row == 1


def test_pow() -> None:
    assert run("pow(x, 2)", [-3, 2]).tolist() == [9, 4]
    assert run("pow(2, x)", [0, 10]).dtype == np.int64
    assert run("pow(2.0, x)", [-1, 1]).tolist() == [0.5, 2.0]
    with pytest.raises(EvaluationError):
        run("pow(2, x)", [1, -1])


def test_min_max_are_n_ary_and_typed() -> None:
    assert run("min(x, y, 3)", [1, 5], [4, 4]).tolist() == [1, 3]
    out = run("max(x, 0.5)", [0, 2])
    assert out.dtype == np.float64 and out.tolist() == [0.5, 2.0]


def test_boolean_operators() -> None:
    b = [False, False, True, True]
    x = [0, 1, 0, 1]
    assert run("b and x == 1", x, b=b).tolist() == [False, False, False, True]
    assert run("b or x == 1", x, b=b).tolist() == [False, True, True, True]
    assert run("implies(b, x == 1)", x, b=b).tolist() == [True, True, False, True]
    assert run("iff(b, x == 1)", x, b=b).tolist() == [True, False, False, True]
    assert run("not b", x, b=b).tolist() == [True, True, False, False]


def test_if_then_else_mixes_int_and_double() -> None:
    out = run("0.5 if x > 0 else 1", [0, 1])
    assert out.dtype == np.float64 and out.tolist() == [1.0, 0.5]


def test_lazy_branches_avoid_failures() -> None:
    # the else branch would divide by zero (mod by 0) where x = 0
    assert run("0 if x == 0 else mod(5, x)", [0, 2, 3]).tolist() == [0, 1, 2]
    assert run("x > 0 and mod(4, x) == 0", [0, 2, 3]).tolist() == [False, True, False]
    assert run("x == 0 or mod(4, x) == 0", [0, 2, 3]).tolist() == [True, True, False]
    assert run("implies(x > 0, mod(4, x) == 0)", [0, 2, 3]).tolist() == [True, True, False]


def test_constant_folding_is_exact() -> None:
    c = compile_expr(ex("1 - 0.1 - 0.002"), SLOTS)
    assert c.is_constant and c.constant == Fraction(898, 1000) and c.type is ExprType.DOUBLE
    assert compile_expr(ex("x + (2 * 3)"), SLOTS).source.count("6") == 1
    assert compile_expr(ex("true or x > 1"), SLOTS).constant is True
    assert compile_expr(ex("false and x > 1"), SLOTS).constant is False


def test_constant_failure_is_raised_only_when_evaluated() -> None:
    c = compile_expr(ex("1 if x >= 0 else mod(1, 0)"), SLOTS)
    cols = Columns([np.array([0, 1]), np.array([0, 0]), np.array([False, False])], 2)
    assert c.evaluate(cols).tolist() == [1, 1]
    with pytest.raises(EvaluationError):
        c.evaluate(Columns([np.array([-1]), np.array([0]), np.array([False])], 1))


def test_constant_results_broadcast() -> None:
    out = compile_expr(ex("3"), SLOTS).evaluate(Columns([np.zeros(4, dtype=np.int64)] * 3, 4))
    assert out.tolist() == [3, 3, 3, 3] and out.dtype == np.int64


@given(st.lists(st.integers(-50, 50), min_size=1, max_size=20), st.integers(1, 9))
def test_arithmetic_matches_python(xs: list[int], k: int) -> None:
    out = run(f"mod(x * {k} - 3, {k + 1}) + floor(x / {k})", xs)
    assert out.tolist() == [(x * k - 3) % (k + 1) + math.floor(Fraction(x, k)) for x in xs]
