"""Evaluation of state formulas and state expressions over all states of an explicit model at once.

A state expression may mention state variables (through ``state_values``), labels (``"goal"``),
literals, and queries (``P``/``R`` operators), whose per-state values are supplied by the caller:
this is what lets ``P>=1 [F "a"] & x=1`` or ``(1/2) * <<p1>> Rmax=? [...]`` be evaluated by one
recursive walk over the syntax tree, each node an array operation over every state.

Operators mean what they mean in a model (:mod:`posgmc.semantics.operators`): ``/`` is IEEE,
``mod``/``pow``/``floor``/... fail outside their domain with a positioned error naming the first
state where their value is needed (``&``, ``|``, ``=>`` and ``? :`` short-circuit as in PRISM, so
``x > 0 & mod(3, x) = 0`` never fails), and no numpy warning reaches the user.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from posgmc.errors import SemanticError, SourceSpan, UnsupportedError
from posgmc.semantics import operators as ops
from posgmc.semantics.symbols import span_or_none
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


@dataclass
class _Failures:
    """Where partial operators failed, restricted to the states whose value needs them (PRISM
    short-circuits ``&``, ``|``, ``=>`` and ``? :``): one (mask, message, span) per failing node."""

    items: list[tuple[np.ndarray, Callable[[int], str], SourceSpan]] = field(default_factory=list)

    def add(self, bad: np.ndarray, message: Callable[[int], str] | None, span: SourceSpan) -> None:
        if message is not None and bool(np.any(bad)):
            self.items.append((bad, message, span))

    def only(self, keep: np.ndarray) -> _Failures:
        """The failures at the states of ``keep`` only."""
        out = _Failures()
        for bad, message, span in self.items:
            out.add(bad & keep, message, span)
        return out

    def merge(self, *others: _Failures) -> _Failures:
        return _Failures(self.items + [x for o in others for x in o.items])


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
    everywhere = np.ones(num_states, dtype=bool)

    def full(value: object, dtype: type) -> np.ndarray:
        return np.full(num_states, value, dtype=dtype)

    def ev(e: Expr) -> tuple[np.ndarray, _Failures]:
        """The value in every state, and where a partial operator failed."""
        none = _Failures()
        if isinstance(e, BoolLit):
            return full(e.value, np.bool_), none
        if isinstance(e, IntLit):
            return full(e.value, np.int64), none
        if isinstance(e, DoubleLit):
            return full(ops.to_float(e.value), np.float64), none
        if isinstance(e, Ident):
            if e.name in columns:
                return model.state_values[:, columns[e.name]], none
            if e.name in model.labels:  # named observables double as labels (PRISM)
                return model.labels[e.name], none
            raise SemanticError(f"'{e.name}' is not a state variable of this model", e.span)
        if isinstance(e, LabelRef):
            if e.name not in model.labels:
                raise SemanticError(f'unknown label "{e.name}"', e.span)
            return model.labels[e.name], none
        if isinstance(e, Unary):
            v, f = ev(e.operand)
            return (np.logical_not(v) if e.op is UnaryOp.NOT else -v), f
        if isinstance(e, Binary):
            (a, fa), (b, fb) = ev(e.left), ev(e.right)
            if e.op is BinaryOp.AND:  # the right operand matters only where the left is true
                fb = fb.only(np.broadcast_to(a.astype(bool), (num_states,)))
            elif e.op is BinaryOp.OR:
                fb = fb.only(~np.broadcast_to(a.astype(bool), (num_states,)))
            elif e.op is BinaryOp.IMPLIES:
                fb = fb.only(np.broadcast_to(a.astype(bool), (num_states,)))
            return _binary(e.op, a, b), fa.merge(fb)
        if isinstance(e, Ite):
            (c, fc), (a, fa), (b, fb) = ev(e.cond), ev(e.then), ev(e.otherwise)
            cb = np.broadcast_to(c.astype(bool), (num_states,))
            if a.dtype != b.dtype and np.float64 in (a.dtype, b.dtype):
                a, b = _as_float(a), _as_float(b)
            return np.where(cb, a, b), fc.merge(fa.only(cb), fb.only(~cb))
        if isinstance(e, Call):
            parts = [ev(x) for x in e.args]
            value, bad, message = _call(e.function, [p[0] for p in parts])
            out = _Failures().merge(*[p[1] for p in parts])
            out.add(bad, message, e.span)
            return value, out
        if isinstance(e, (ProbQuery, RewardQuery)):
            if queries is None:
                raise UnsupportedError("a query cannot appear here", e.span)
            return queries(e), none
        if isinstance(e, Temporal):
            raise UnsupportedError(
                f"the temporal operator {e.op.value} may only appear inside a P or R operator", e.span
            )
        raise UnsupportedError(f"cannot evaluate {type(e).__name__} over states", e.span)

    result, failures = ev(expr)
    if failures.items:
        # the first state where some operator fails, and that operator's message (PRISM's rule,
        # the one exploration applies: semantics/operators.py)
        first = min(int(np.flatnonzero(bad & everywhere)[0]) for bad, _, _ in failures.items)
        for bad, message, span in failures.items:
            if bad[first]:
                raise SemanticError(
                    f"{message(first)} in {_state_text(model, first)}", span_or_none(span)
                )
    if result.shape != (num_states,):
        result = np.broadcast_to(result, (num_states,)).copy()
    return result


def _state_text(model: ExplicitModel, s: int) -> str:
    """``state 3 (x=1, y=0)``."""
    names = model.variable_names
    if names and model.state_values.shape == (model.num_states, len(names)):
        row = model.state_values[s]
        return f"state {s} (" + ", ".join(f"{n}={int(v)}" for n, v in zip(names, row)) + ")"
    return f"state {s}"


def _binary(op: BinaryOp, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return ops.BINARY[op].vector(a, b)  # type: ignore[no-any-return]


def _call(
    function: Function, args: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, Callable[[int], str] | None]:
    """(value, failure mask, message at a failing state) of a function over all states."""
    ok = np.zeros(args[0].shape, dtype=bool)
    if function in (Function.MIN, Function.MAX):
        f = np.minimum if function is Function.MIN else np.maximum
        out = args[0]
        for a in args[1:]:
            out = f(out, a)
        return out, ok, None
    if function in (Function.FLOOR, Function.CEIL, Function.ROUND):
        if args[0].dtype.kind in "iu":
            return args[0], ok, None
        return ops.ROUNDING[function.value].masked(args[0])
    if function is Function.POW:
        base, exp = args
        if base.dtype.kind in "iu" and exp.dtype.kind in "iu":
            return ops.int_pow.masked(base, exp)
        return ops.float_pow(base, _as_float(exp)), ok, None
    if function is Function.MOD:
        return ops.mod.masked(args[0], args[1])
    if function is Function.LOG:
        return ops.log(args[0], args[1]), ok, None
    raise UnsupportedError(f"unknown function {function.value}")
