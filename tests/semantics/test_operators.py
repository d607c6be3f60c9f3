"""One meaning for PRISM's operators: every evaluator agrees on every expression.

The four evaluators of expressions — the scalar evaluator (``semantics/evaluate.py``), constant
folding (``simplify``), the exploration code generator (``build/compile_expr.py``) and the
state-formula evaluator (``checking/states.py``) — are run on random well-typed expressions over two
int variables in every state of a 7x7 grid; they must give identical values, or fail in the same
states with the same message. Doubles are drawn so that comparisons and rounding only see dyadic
values (exact in binary floating point), since the folder keeps decimals exact while the runtime
uses IEEE doubles: the test is about the operators, not about decimal rounding.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.build.compile_expr import Columns, EvaluationError, ExprType, compile_expr
from posgmc.checking.states import evaluate_states
from posgmc.errors import SemanticError
from posgmc.model.explicit import make_model
from posgmc.semantics import operators as ops
from posgmc.semantics.evaluate import evaluate, is_literal, literal_value, simplify, substitute
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
    ModelType,
    Unary,
    UnaryOp,
)

GRID = [(x, y) for x in range(-3, 4) for y in range(-3, 4)]
NUM_STATES = len(GRID)
MODEL = make_model(
    ModelType.DTMC,
    np.arange(NUM_STATES + 1),
    np.eye(NUM_STATES),
    variable_names=("x", "y"),
    state_values=np.array(GRID, dtype=np.int64),
)
SLOTS = {"x": (0, ExprType.INT), "y": (1, ExprType.INT)}

_var = st.sampled_from([Ident("x"), Ident("y")])
_small_int = st.integers(-3, 3).map(IntLit)
_dyadic_lit = st.sampled_from(["0", "0.5", "-0.25", "1.5", "2", "-3"]).map(
    lambda t: DoubleLit(Fraction(t))
)


def _ints(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    atom = st.one_of(_small_int, _var)
    return st.one_of(
        st.builds(Unary, st.just(UnaryOp.NEG), children),
        st.builds(Binary, st.sampled_from([BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL]), children, children),
        st.builds(lambda f, a, b: Call(f, (a, b)), st.sampled_from([Function.MIN, Function.MAX]), children, children),
        st.builds(lambda a, b: Call(Function.MOD, (a, b)), children, children),
        st.builds(lambda a, b: Call(Function.POW, (a, b)), atom, atom),
    )


ints = st.recursive(st.one_of(_small_int, _var), _ints, max_leaves=6)


def _dyadics(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    return st.one_of(
        st.builds(Unary, st.just(UnaryOp.NEG), children),
        st.builds(Binary, st.sampled_from([BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL]), children, st.one_of(children, ints)),
        st.builds(lambda f, a, b: Call(f, (a, b)), st.sampled_from([Function.MIN, Function.MAX]), children, ints),
        st.builds(lambda a, b: Call(Function.POW, (a, b)), _dyadic_lit, st.integers(0, 3).map(IntLit)),
    )


dyadics = st.recursive(_dyadic_lit, _dyadics, max_leaves=5)
rounded = st.builds(
    lambda f, a: Call(f, (a,)), st.sampled_from([Function.FLOOR, Function.CEIL, Function.ROUND]), dyadics
)
numbers = st.one_of(ints, dyadics, rounded)


def _doubles(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    return st.one_of(
        st.builds(Binary, st.sampled_from([BinaryOp.ADD, BinaryOp.MUL, BinaryOp.DIV]), children, children),
        st.builds(lambda a, b: Call(Function.LOG, (a, b)), children, children),
        # exponents >= 0: a zero base with a negative exponent is +-inf by the sign of the zero,
        # which exact arithmetic does not have (see test_zero_base_negative_exponent)
        st.builds(lambda a, b: Call(Function.POW, (a, b)), children, _nonnegative_lit),
    )


_nonnegative_lit = st.sampled_from(["0", "0.5", "1.5", "2"]).map(lambda t: DoubleLit(Fraction(t)))


doubles = st.recursive(st.one_of(dyadics, ints.map(lambda e: Binary(BinaryOp.DIV, e, IntLit(2)))), _doubles, max_leaves=5)


def _bools(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    comparisons = [BinaryOp.EQ, BinaryOp.NE, BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE]
    return st.one_of(
        st.builds(Unary, st.just(UnaryOp.NOT), children),
        st.builds(
            Binary,
            st.sampled_from([BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF]),
            children,
            children,
        ),
        st.builds(Ite, children, children, children),
    )


_comparison = st.builds(
    Binary,
    st.sampled_from([BinaryOp.EQ, BinaryOp.NE, BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE]),
    numbers,
    numbers,
)
bools = st.recursive(st.one_of(st.sampled_from([BoolLit(True), BoolLit(False)]), _comparison), _bools, max_leaves=5)
guarded = st.builds(Ite, bools, numbers, numbers)
expressions = st.one_of(ints, dyadics, rounded, doubles, bools, guarded)


def _scalar(expr: Expr) -> list[object]:
    """Per state: the value, or ("error", message)."""
    out: list[object] = []
    for x, y in GRID:
        try:
            out.append(evaluate(expr, {"x": x, "y": y}))
        except SemanticError as e:
            out.append(("error", e.message))
    return out


def _same(a: object, b: object) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return bool(a) == bool(b) and isinstance(a, (bool, np.bool_)) and isinstance(b, (bool, np.bool_))
    fa, fb = ops.to_float(a), ops.to_float(b)  # type: ignore[arg-type]
    if math.isnan(fa) or math.isnan(fb):
        return math.isnan(fa) and math.isnan(fb)
    return fa == fb or math.isclose(fa, fb, rel_tol=1e-12)


@settings(max_examples=400, deadline=None)
@given(expressions)
def test_all_evaluators_agree(expr: Expr) -> None:
    scalar = _scalar(expr)
    failing = [i for i, v in enumerate(scalar) if isinstance(v, tuple)]

    # exploration code generator (numpy over all states at once)
    compiled = compile_expr(expr, SLOTS)
    try:
        runtime = compiled.evaluate(Columns([MODEL.state_values[:, 0], MODEL.state_values[:, 1]], NUM_STATES))
        runtime_error = None
    except EvaluationError as e:
        runtime, runtime_error = None, e

    # state-formula evaluator (properties)
    try:
        states = evaluate_states(MODEL, expr)
        states_error = None
    except SemanticError as e:
        states, states_error = None, e

    if failing:
        assert runtime_error is not None and states_error is not None, expr
        assert runtime_error.row in failing
        assert scalar[runtime_error.row] == ("error", runtime_error.message)
        first = failing[0]
        x, y = GRID[first]
        assert states_error.message == f"{scalar[first][1]} in state {first} (x={x}, y={y})"  # type: ignore[index]
    else:
        assert runtime_error is None and states_error is None, (expr, runtime_error, states_error)
        for i, v in enumerate(scalar):
            assert _same(v, runtime[i]), (expr, GRID[i], v, runtime[i])  # type: ignore[index]
            assert _same(v, states[i]), (expr, GRID[i], v, states[i])  # type: ignore[index]

    # constant folding: with the variables substituted, the folded tree means the same (a literal
    # where the value is finite and every operand folds; failures are left unfolded so that the
    # error surfaces where the expression is used)
    for i in range(0, NUM_STATES, 8):
        x, y = GRID[i]
        folded = simplify(substitute(expr, {"x": x, "y": y}))
        try:
            again: object = evaluate(folded, {})
        except SemanticError as e:
            again = ("error", e.message)
        if isinstance(scalar[i], tuple):
            assert again == scalar[i] and not is_literal(folded), (expr, GRID[i], folded)
        else:
            assert not isinstance(again, tuple) and _same(again, scalar[i]), (expr, GRID[i], folded)
            if is_literal(folded):
                assert _same(literal_value(folded), scalar[i])


@pytest.mark.parametrize(
    ("expr", "message"),
    [
        (Call(Function.MOD, (IntLit(3), Ident("x"))), "mod() by a non-positive divisor (-3)"),
        (Call(Function.POW, (IntLit(2), Ident("x"))), "negative exponent -3 in pow() of two ints"),
    ],
)
def test_failures_name_the_first_state(expr: Expr, message: str) -> None:
    with pytest.raises(SemanticError) as info:
        evaluate_states(MODEL, expr)
    assert info.value.message.startswith(message) and "in state 0 (x=-3, y=-3)" in info.value.message


def test_zero_base_negative_exponent() -> None:
    # Java: Math.pow(0.0, -0.25) = Infinity; the same in every evaluator (an unsigned zero)
    expr = Call(Function.POW, (Binary(BinaryOp.MUL, DoubleLit(Fraction(0)), Ident("x")), DoubleLit(Fraction(-1, 4))))
    assert evaluate(expr, {"x": 1, "y": 0}) == math.inf
    assert np.all(evaluate_states(MODEL, expr)[np.array(GRID)[:, 0] > 0] == math.inf)
