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

    Operators follow PRISM (and the compiler, :mod:`posgmc.compiler.compile_expr`): ``/`` is real
    division (``1/0`` is infinite, ``0/0`` NaN), ``mod(i, n)`` needs ``n > 0``, ``pow`` of two ints
    needs a non-negative exponent, ``floor``/``ceil``/``round`` need a finite argument. A failure
    counts only where PRISM would evaluate the failing operand: ``&``, ``|``, ``=>`` and ``? :``
    short-circuit, so ``x > 0 & mod(y, x) = 0`` is fine where ``x = 0``.

    Args:
        model: the explicit model (its ``state_values``, ``variable_names`` and ``labels`` are
        used).
        expr: a resolved state expression (constants already replaced by literals).
        queries: callback giving the per-state values of nested ``P``/``R`` queries.

    Returns:
        bool[S], int64[S] or float64[S].

    Raises:
        SemanticError: an identifier that is not a state variable, a label the model lacks, or an
            operator failing in a state (the message names the first such state).
        UnsupportedError: a temporal operator outside a ``P``/``R`` query.
    """
    num_states = model.num_states
    columns = {name: i for i, name in enumerate(model.variable_names)}
    failures: list[tuple[np.ndarray, str, Expr]] = []  # (states, message, node) in order of use

    def full(value: object, dtype: type) -> np.ndarray:
        return np.full(num_states, value, dtype=dtype)

    def fail(where: np.ndarray, message: str, e: Expr) -> np.ndarray:
        """Record a failure in the states ``where``; returns a "failed" mask for propagation."""
        failures.append((where, message, e))
        return where

    def ev(e: Expr, need: np.ndarray) -> np.ndarray:
        """The value of ``e``; failures count only in the states ``need`` (short-circuit)."""
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
            v = ev(e.operand, need)
            return np.logical_not(v) if e.op is UnaryOp.NOT else -v
        if isinstance(e, Binary):
            a = ev(e.left, need)
            if e.op is BinaryOp.AND:
                b = ev(e.right, need & a.astype(bool))
            elif e.op is BinaryOp.OR:
                b = ev(e.right, need & ~a.astype(bool))
            elif e.op is BinaryOp.IMPLIES:
                b = ev(e.right, need & a.astype(bool))
            else:
                b = ev(e.right, need)
            return _binary(e.op, a, b)
        if isinstance(e, Ite):
            c = ev(e.cond, need).astype(bool)
            a, b = ev(e.then, need & c), ev(e.otherwise, need & ~c)
            return np.where(c, a, b)
        if isinstance(e, Call):
            args = [ev(a, need) for a in e.args]
            return _call(e, args, lambda bad, msg: fail(need & bad, msg, e))
        if isinstance(e, (ProbQuery, RewardQuery)):
            if queries is None:
                raise UnsupportedError("a query cannot appear here", e.span)
            return queries(e)
        if isinstance(e, Temporal):
            raise UnsupportedError(
                f"the temporal operator {e.op.value} may only appear inside a P or R operator",
                e.span,
            )
        raise UnsupportedError(f"cannot evaluate {type(e).__name__} over states", e.span)

    with np.errstate(all="ignore"):  # IEEE results (inf, NaN) are the answer, not warnings
        result = ev(expr, np.ones(num_states, dtype=bool))
    for where, message, node in failures:
        if where.any():
            s = int(np.flatnonzero(where)[0])
            raise SemanticError(f"{message} in state {model.describe_state(s)}", node.span)
    if result.shape != (num_states,):
        result = np.broadcast_to(result, (num_states,)).copy()
    return result


def evaluate_call(model: ExplicitModel, e: Call, args: list[np.ndarray]) -> np.ndarray:
    """``e``'s function over given argument values (e.g. the values of nested queries), with the
    same domain rules as :func:`evaluate_states`.

    Raises:
        SemanticError: the function fails in some state (the message names the first).
    """
    failures: list[np.ndarray] = []
    messages: list[str] = []

    def fail(where: np.ndarray, message: str) -> np.ndarray:
        failures.append(where)
        messages.append(message)
        return where

    with np.errstate(all="ignore"):
        out = _call(e, args, fail)
    for where, message in zip(failures, messages):
        if np.any(where):
            s = int(np.flatnonzero(where)[0])
            raise SemanticError(f"{message} in state {model.describe_state(s)}", e.span)
    return out


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
        # PRISM: '/' is always real division; 1/0 = inf and 0/0 = NaN as for doubles (IEEE)
        out: np.ndarray = np.true_divide(_as_float(a), _as_float(b))
        return out
    return _BINARY[op](a, b)


Failure = Callable[[np.ndarray, str], np.ndarray]
"""Records that an operator fails in the given states (bool mask), with a message."""


def _is_int(a: np.ndarray) -> bool:
    return a.dtype.kind in "iub"


def _call(e: Call, args: list[np.ndarray], fail: Failure) -> np.ndarray:
    """PRISM's functions over all states, with the compiler's domain rules."""
    function = e.function
    out: np.ndarray
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
    if function in (Function.FLOOR, Function.CEIL, Function.ROUND):
        x = _as_float(args[0])
        fail(~np.isfinite(x), f"{function.value}() of a non-finite value")
        x = np.where(np.isfinite(x), x, 0.0)
        if function is Function.FLOOR:
            out = np.floor(x).astype(np.int64)
            return out
        if function is Function.CEIL:
            out = np.ceil(x).astype(np.int64)
            return out
        return np.floor(x + 0.5).astype(np.int64)
    if function is Function.POW:
        base, exp = args
        if _is_int(base) and _is_int(exp):
            fail(exp < 0, "negative exponent in pow() of two ints")
            out = np.power(base.astype(np.int64), np.maximum(exp, 0).astype(np.int64))
            return out
        out = np.power(_as_float(base), _as_float(exp))
        return out
    if function is Function.MOD:
        a, n = args
        fail(n <= 0, "mod() by a non-positive divisor")
        out = np.mod(a, np.where(n > 0, n, 1))
        return out
    if function is Function.LOG:
        out = np.log(_as_float(args[0])) / np.log(_as_float(args[1]))
        return out
    raise UnsupportedError(f"unknown function {function.value}", e.span)


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
