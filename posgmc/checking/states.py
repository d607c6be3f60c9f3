"""Evaluation of state formulas and state expressions over all states of an explicit model at once.

A state expression may mention state variables (through ``state_values``), labels (``"goal"``),
literals, and queries (``P``/``R`` operators), whose per-state values are supplied by the caller:
this is what lets ``P>=1 [F "a"] & x=1`` or ``(1/2) * <<p1>> Rmax=? [...]`` be evaluated by one
recursive walk over the syntax tree, each node an array operation over every state.
"""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction

import numpy as np

from posgmc.errors import SemanticError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
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
    LabelRef,
    ProbQuery,
    RewardQuery,
    Temporal,
    Unary,
    UnaryOp,
)

QueryEvaluator = Callable[[Expr], np.ndarray]
"""Returns the per-state value (float64[S] or bool[S]) of a ``P``/``R`` query node."""


def _as_float(value: np.ndarray) -> np.ndarray:
    return value.astype(np.float64) if value.dtype != np.float64 else value


def evaluate_states(
    model: ExplicitModel,
    expr: Expr,
    *,
    queries: QueryEvaluator | None = None,
) -> np.ndarray:
    """Evaluate ``expr`` in every state of ``model``.

    Args:
        model: the explicit model (its ``state_values``, ``variable_names`` and ``labels`` are used).
        expr: a resolved state expression (constants already replaced by literals).
        queries: callback giving the per-state values of nested ``P``/``R`` queries.

    Returns:
        An array of length ``num_states``: bool for formulas, int64 or float64 for numbers.

    Raises:
        SemanticError: an identifier that is not a state variable, or a label the model lacks.
        UnsupportedError: a temporal operator outside a ``P``/``R`` query.
    """
    num_states = model.num_states
    columns = {name: i for i, name in enumerate(model.variable_names)}

    def full(value: object, dtype: type) -> np.ndarray:
        return np.full(num_states, value, dtype=dtype)

    def ev(e: Expr) -> np.ndarray:
        if isinstance(e, BoolLit):
            return full(e.value, np.bool_)
        if isinstance(e, IntLit):
            return full(e.value, np.int64)
        if isinstance(e, DoubleLit):
            return full(float(e.value), np.float64)
        if isinstance(e, Ident):
            if e.name in columns:
                column = model.state_values[:, columns[e.name]]
                return column != 0 if e.name in model.boolean_variables else column
            if e.name in model.labels:  # named observables double as labels (PRISM)
                return model.labels[e.name]
            raise SemanticError(f"'{e.name}' is not a state variable of this model", e.span)
        if isinstance(e, LabelRef):
            if e.name not in model.labels:
                raise SemanticError(f'unknown label "{e.name}"', e.span)
            return model.labels[e.name]
        if isinstance(e, Unary):
            v = ev(e.operand)
            return np.logical_not(v) if e.op is UnaryOp.NOT else -v
        if isinstance(e, Binary):
            return _binary(e.op, ev(e.left), ev(e.right))
        if isinstance(e, Ite):
            c, a, b = ev(e.cond), ev(e.then), ev(e.otherwise)
            return np.where(c, a, b)
        if isinstance(e, Call):
            return _call(e.function, [ev(a) for a in e.args])
        if isinstance(e, (ProbQuery, RewardQuery)):
            if queries is None:
                raise UnsupportedError("a query cannot appear here", e.span)
            return queries(e)
        if isinstance(e, Temporal):
            raise UnsupportedError(
                f"the temporal operator {e.op.value} may only appear inside a P or R operator", e.span
            )
        raise UnsupportedError(f"cannot evaluate {type(e).__name__} over states", e.span)

    result = ev(expr)
    if result.shape != (num_states,):
        result = np.broadcast_to(result, (num_states,)).copy()
    return result


_BINARY: dict[BinaryOp, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    BinaryOp.AND: np.logical_and,
    BinaryOp.OR: np.logical_or,
    BinaryOp.IMPLIES: lambda a, b: np.logical_or(np.logical_not(a), b),
    BinaryOp.IFF: np.equal,
    BinaryOp.EQ: np.equal,
    BinaryOp.NE: np.not_equal,
    BinaryOp.LT: np.less,
    BinaryOp.LE: np.less_equal,
    BinaryOp.GT: np.greater,
    BinaryOp.GE: np.greater_equal,
    BinaryOp.ADD: np.add,
    BinaryOp.SUB: np.subtract,
    BinaryOp.MUL: np.multiply,
}


def _binary(op: BinaryOp, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if op is BinaryOp.DIV:
        # PRISM: '/' is always real division; inf * 0 style corner cases follow IEEE.
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.true_divide(_as_float(a), _as_float(b))
    return _BINARY[op](a, b)


def _call(function: Function, args: list[np.ndarray]) -> np.ndarray:
    if function is Function.MIN:
        out = args[0]
        for a in args[1:]:
            out = np.minimum(out, a)
        return out
    if function is Function.MAX:
        out = args[0]
        for a in args[1:]:
            out = np.maximum(out, a)
        return out
    if function is Function.FLOOR:
        return np.floor(args[0]).astype(np.int64)
    if function is Function.CEIL:
        return np.ceil(args[0]).astype(np.int64)
    if function is Function.ROUND:
        return np.floor(_as_float(args[0]) + 0.5).astype(np.int64)
    if function is Function.POW:
        base, exp = args
        if base.dtype.kind in "iu" and exp.dtype.kind in "iu" and np.all(exp >= 0):
            return np.power(base, exp)
        return np.power(_as_float(base), _as_float(exp))
    if function is Function.MOD:
        return np.mod(args[0], args[1])
    if function is Function.LOG:
        return np.log(_as_float(args[0])) / np.log(_as_float(args[1]))
    raise UnsupportedError(f"unknown function {function.value}")


def literal_value(expr: Expr) -> int | float | bool | Fraction:
    """The value of a literal node (after constant substitution); for bounds and thresholds."""
    if isinstance(expr, (IntLit, BoolLit)):
        return expr.value
    if isinstance(expr, DoubleLit):
        return expr.value
    if isinstance(expr, Unary) and expr.op is UnaryOp.NEG:
        inner = literal_value(expr.operand)
        return -inner
    raise SemanticError("expected a constant value here", expr.span)
