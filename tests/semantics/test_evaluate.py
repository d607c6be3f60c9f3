"""Evaluation with PRISM's semantics, substitution and constant folding.

Expected values are hand-derived from PRISM's rules as read in prism-games
``prism/src/parser/ast/ExpressionFunc.java`` (applyMod, applyRound, applyPow, applyLog) and
``ExpressionBinaryOp.java`` (``/`` always a double).
"""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.errors import SemanticError
from posgmc.semantics.evaluate import (
    evaluate,
    evaluate_constant,
    format_value,
    free_names,
    literal,
    simplify,
    substitute,
    value_type,
)
from posgmc.semantics.symbols import Type
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    DoubleLit,
    Expr,
    Function,
    Ident,
    IntLit,
    Ite,
    Unary,
    UnaryOp,
)
from posgmc.syntax.parser import parse_expression


def ev(text: str, **env: object) -> object:
    return evaluate(parse_expression(text), env)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1/3", Fraction(1, 3)),  # exact, and a double even for two ints
        ("4/2", Fraction(2)),
        ("0.1 + 0.2", Fraction(3, 10)),  # exact decimals
        ("7 - 2*3", 1),
        ("mod(-1, 3)", 2),  # PRISM: non-negative for a positive divisor
        ("mod(7, 3)", 1),
        ("mod(-7, 3)", 2),
        ("floor(-2.5)", -3),
        ("ceil(2.1)", 3),
        ("round(2.5)", 3),  # Java Math.round = floor(x + 1/2)
        ("round(-2.5)", -2),
        ("pow(2, 10)", 1024),
        ("pow(2.0, -1)", Fraction(1, 2)),
        ("min(3, 1, 2)", 1),
        ("max(1, 2.5)", Fraction(5, 2)),
        ("true => false", False),
        ("false => false", True),
        ("true <=> true", True),
        ("3 > 2 ? 1 : 0", 1),
        ("!(1 = 1) | 2 != 2", False),
        ("-(3)", -3),
    ],
)
def test_prism_semantics(text: str, expected: object) -> None:
    v = ev(text)
    assert v == expected
    assert type(v) is type(expected)


def test_types_follow_values() -> None:
    # an int-typed result is an int, a double-typed one a Fraction/float, never mixed
    assert value_type(ev("floor(2.7)")) is Type.INT  # type: ignore[arg-type]
    assert value_type(ev("min(1, 2)")) is Type.INT  # type: ignore[arg-type]
    assert value_type(ev("min(1, 2.0)")) is Type.DOUBLE  # type: ignore[arg-type]
    assert value_type(ev("pow(2, 2.0)")) is Type.DOUBLE  # type: ignore[arg-type]
    # the "? :" is a double if either branch is: the int branch is widened
    v = ev("true ? 1 : 0.5")
    assert v == 1 and isinstance(v, Fraction)


def test_log_and_non_integer_pow_use_floating_point() -> None:
    assert ev("log(8, 2)") == pytest.approx(3.0)
    assert isinstance(ev("pow(2, 0.5)"), float)
    assert ev("pow(2, 0.5)") == pytest.approx(math.sqrt(2))
    assert math.isnan(ev("pow(-8, 1/3)"))  # type: ignore[arg-type]  # as Java's Math.pow


def test_evaluate_constant() -> None:
    assert evaluate_constant(parse_expression("1/4 + 1")) == Fraction(5, 4)
    with pytest.raises(SemanticError, match='"k" has no value here'):
        evaluate_constant(parse_expression("k + 1"))


def test_identifiers_from_environment() -> None:
    assert ev("x + N", x=2, N=3) == 5
    assert ev("p * 2", p=Fraction(1, 4)) == Fraction(1, 2)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("mod(3, 0)", "mod() by a non-positive divisor (0)"),
        (
            "pow(2, -1)",
            "negative exponent -1 in pow() of two ints; write pow(2.0, -1) for a double result",
        ),
        ("y + 1", '"y" has no value here'),
    ],
)
def test_evaluation_errors(text: str, message: str) -> None:
    with pytest.raises(SemanticError) as exc:
        ev(text)
    assert exc.value.message == message
    assert exc.value.span is not None and exc.value.span.line == 1


def test_substitute_values_and_expressions() -> None:
    e = parse_expression("x + N")
    out = substitute(e, {"N": 3})
    assert out == Binary(BinaryOp.ADD, Ident("x"), IntLit(3))
    # the literal takes the identifier's span
    assert isinstance(out, Binary) and out.right.span.column == 5
    f = parse_expression("a & b")
    body = parse_expression("y > 2")
    out2 = substitute(f, {"b": body})
    assert out2 == Binary(BinaryOp.AND, Ident("a"), body)
    assert free_names(out2) == {"a", "y"}
    # nothing to replace: the same object comes back
    assert substitute(e, {"zz": 1}) is e


def test_literal_of_values() -> None:
    assert literal(True) == BoolLit(True)
    assert literal(3) == IntLit(3)
    assert literal(Fraction(1, 3)) == DoubleLit(Fraction(1, 3))
    assert literal(0.5) == DoubleLit(Fraction(1, 2))
    with pytest.raises(ValueError):
        literal(math.inf)


def test_simplify_folds_constants_and_units() -> None:
    assert simplify(parse_expression("1 + 2 * 3")) == IntLit(7)
    assert simplify(parse_expression("true & x > 1 + 1")) == parse_expression("x > 2")
    assert simplify(parse_expression("false & x > 1")) == BoolLit(False)
    assert simplify(parse_expression("x > 1 | true")) == BoolLit(True)
    assert simplify(parse_expression("false => x > 1")) == BoolLit(True)
    assert simplify(parse_expression("1 > 2 ? x : x + 1"), variable_types={"x": Type.INT}) == (
        parse_expression("x + 1")
    )
    # an int branch of a double "? :" is widened, not left as an int
    assert simplify(parse_expression("true ? 1 : x / 2"), variable_types={"x": Type.INT}) == (
        DoubleLit(Fraction(1))
    )
    # a failing sub-expression is left for the place that uses it
    assert simplify(parse_expression("x + 1/0")) == parse_expression("x + 1/0")


def test_format_value() -> None:
    assert [
        format_value(v) for v in (True, 3, Fraction(3, 2), Fraction(1, 3), Fraction(-1, 8))
    ] == [
        "true",
        "3",
        "1.5",
        "1/3",
        "-0.125",
    ]


# -- simplify never changes a value (random integer expressions over x) ------------------------


def _int_exprs() -> st.SearchStrategy[Expr]:
    leaves = st.one_of(st.integers(-5, 5).map(IntLit), st.just(Ident("x")))

    def extend(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
        ops = st.sampled_from([BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL])
        cmp = st.sampled_from([BinaryOp.LT, BinaryOp.EQ, BinaryOp.GE])
        cond = st.builds(Binary, cmp, children, children)
        return st.one_of(
            st.builds(Binary, ops, children, children),
            st.builds(Unary, st.just(UnaryOp.NEG), children),
            st.builds(lambda a, b: Call(Function.MIN, (a, b)), children, children),
            st.builds(lambda a: Call(Function.MOD, (a, IntLit(3))), children),
            st.builds(Ite, st.one_of(cond, st.booleans().map(BoolLit)), children, children),
        )

    return st.recursive(leaves, extend, max_leaves=12)


@settings(max_examples=200, deadline=None)
@given(_int_exprs(), st.integers(-4, 4))
def test_simplify_preserves_values(e: Expr, x: int) -> None:
    s = simplify(e, variable_types={"x": Type.INT})
    assert evaluate(s, {"x": x}) == evaluate(e, {"x": x})


def test_division_by_zero_is_ieee_as_in_prism() -> None:
    # PRISM's "/" is Java double division: 1/0 = Infinity, -1/0 = -Infinity, 0/0 = NaN; the
    # exploration code generator and the state-formula evaluator agree (semantics/operators.py)
    assert ev("1/0") == math.inf and ev("-1/0") == -math.inf
    assert math.isnan(ev("0/0"))


def test_double_pow_overflow_is_infinity() -> None:
    # Java: Math.pow(2.0, 2000) = Infinity (no exact 600-digit value, no OverflowError)
    assert ev("pow(2.0, 2000)") == math.inf
    assert ev("pow(-2.0, 2001)") == -math.inf
