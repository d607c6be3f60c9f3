"""Compile a model expression once into a numpy function over whole arrays of states.

An expression of the :class:`~posgmc.semantics.flat.FlatModel` (constants already literals, every
identifier a state variable) becomes Python source text of numpy operations, compiled with
:func:`compile` once and then applied to a batch of states at a time: ``f(v)`` where ``v[i]`` is
the array of values of variable ``i`` in the batch (int64 for ints, bool for Booleans). Constant
subexpressions are folded exactly first (ints, :class:`~fractions.Fraction` for doubles while
exact), so a guard like ``x < N-1`` costs one comparison per state.

PRISM's semantics (``parser/ast/ExpressionFunc.java``, ``ExpressionBinaryOp.java``):

* ``a / b`` is always a double (IEEE division: ``x/0`` is an infinity at exploration time);
  ``+ - *`` of two ints is an int.
* ``floor``, ``ceil``, ``round`` give ints, ``round(x) = floor(x + 1/2)`` (Java ``Math.round``);
  a non-finite argument is an error.
* ``pow(i, j)`` of two ints is an int and needs ``j >= 0``; otherwise a double.
* ``mod(i, n)`` needs ``n > 0`` and is never negative (Python's ``%`` for ``n > 0``).
* ``log(x, b) = ln x / ln b``; ``min``/``max`` are n-ary.
* ``&``, ``|``, ``=>`` and ``? :`` short-circuit as in PRISM: an operand that can fail (``mod``,
  integer ``pow``, ``floor``/``ceil``/``round`` of a double) is evaluated only on the states where
  its value is needed, so ``x > 0 & mod(y, x) = 0`` never divides by zero.

Runtime failures raise :class:`EvaluationError` with the offending row; the explorer turns it into
a :class:`~posgmc.errors.BuildError` naming the state.
"""

from __future__ import annotations

import dataclasses
import enum
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from posgmc.errors import SourceSpan
from posgmc.semantics import operators as ops
from posgmc.syntax.ast import (
    NO_SPAN,
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
from posgmc.syntax.traversal import children

__all__ = [
    "Columns",
    "CompiledExpr",
    "EvaluationError",
    "ExprType",
    "Scalar",
    "compile_expr",
    "infer_type",
]

Scalar = bool | int | Fraction | float
"""A folded constant: bool, int, exact double (Fraction) or inexact double (float)."""


class ExprType(enum.Enum):
    """The three value types of the PRISM language."""

    BOOL = "bool"
    INT = "int"
    DOUBLE = "double"


class EvaluationError(Exception):
    """An expression failed on one state of a batch (``mod`` by 0, negative int exponent, ...).

    ``row`` indexes the rows of the root :class:`Columns` the evaluation started from.
    """

    def __init__(self, message: str, span: SourceSpan, row: int) -> None:
        super().__init__(message)
        self.message = message
        self.span = span
        self.row = row


class Columns:
    """The variable values of a batch of ``n`` states, one array per variable.

    ``take(rows)`` gives the sub-batch of those rows; its columns are gathered lazily on first
    use, so evaluating a guard of two variables on a subset copies only those two.
    ``origin`` maps local rows to rows of the root batch (None: identity), for error reports.
    """

    __slots__ = ("_arrays", "_parent", "_rows", "n", "origin")

    def __init__(
        self,
        arrays: Sequence[np.ndarray | None],
        n: int,
        *,
        parent: Columns | None = None,
        rows: np.ndarray | None = None,
        origin: np.ndarray | None = None,
    ) -> None:
        self._arrays: list[np.ndarray | None] = list(arrays)
        self._parent = parent
        self._rows = rows
        self.n = n
        self.origin = origin

    def __getitem__(self, i: int) -> np.ndarray:
        a = self._arrays[i]
        if a is None:
            assert self._parent is not None and self._rows is not None
            a = self._parent[i][self._rows]
            self._arrays[i] = a
        return a

    def __len__(self) -> int:
        return len(self._arrays)

    def take(self, rows: np.ndarray) -> Columns:
        """The sub-batch of ``rows`` (int indices into this batch)."""
        origin = rows if self.origin is None else self.origin[rows]
        return Columns(
            [None] * len(self._arrays), int(rows.size), parent=self, rows=rows, origin=origin
        )

    def root_row(self, row: int) -> int:
        return int(row if self.origin is None else self.origin[row])


@dataclass(frozen=True, eq=False)
class CompiledExpr:
    """An expression compiled for batches of states.

    ``type``: its value type. ``constant``: its folded value when it does not depend on the state
    (then ``function`` returns that scalar). ``variables``: indices of the variables it reads.
    ``source``: the generated numpy source, for debugging.
    """

    type: ExprType
    constant: Scalar | None
    variables: frozenset[int]
    source: str
    function: Callable[[Columns], Any] = field(repr=False)
    span: SourceSpan = NO_SPAN

    @property
    def is_constant(self) -> bool:
        return self.constant is not None

    def __call__(self, columns: Columns) -> Any:
        """The raw result: an array of ``columns.n`` values, or a scalar for a constant.

        IEEE special values (``x/0``) are intended: callers evaluate under
        ``np.errstate(all="ignore")`` (the builder sets it once per build).
        """
        return self.function(columns)

    def evaluate(self, columns: Columns) -> np.ndarray:
        """The result as an array of length ``columns.n`` (bool, int64 or float64)."""
        with np.errstate(all="ignore"):
            out = self.function(columns)
        dtype = _DTYPES[self.type]
        if isinstance(out, np.ndarray) and out.shape == (columns.n,):
            return out if out.dtype == dtype else out.astype(dtype)
        return np.full(columns.n, _to_numpy_scalar(out, self.type), dtype=dtype)


_DTYPES = {ExprType.BOOL: np.bool_, ExprType.INT: np.int64, ExprType.DOUBLE: np.float64}


def _to_numpy_scalar(value: Any, type_: ExprType) -> Any:
    if type_ is ExprType.DOUBLE:
        return ops.to_float(value)
    if type_ is ExprType.INT:
        return int(value)
    return bool(value)


# ---------------------------------------------------------------------------------------------
# types
# ---------------------------------------------------------------------------------------------


def infer_type(expr: Expr, variable_types: Mapping[str, ExprType]) -> ExprType:
    """The PRISM type of a (type-checked) model expression.

    Args:
        expr: an expression whose identifiers are all in ``variable_types``.
        variable_types: the type (INT or BOOL) of each state variable.

    Returns:
        BOOL, INT or DOUBLE.

    Raises:
        KeyError: an identifier that is not a variable (the semantic stage rules this out).
    """
    if isinstance(expr, BoolLit):
        return ExprType.BOOL
    if isinstance(expr, IntLit):
        return ExprType.INT
    if isinstance(expr, DoubleLit):
        return ExprType.DOUBLE
    if isinstance(expr, Ident):
        return variable_types[expr.name]
    if isinstance(expr, Unary):
        return ExprType.BOOL if expr.op is UnaryOp.NOT else infer_type(expr.operand, variable_types)
    if isinstance(expr, Binary):
        if expr.op in _BOOL_OPS or expr.op in _COMPARISONS:
            return ExprType.BOOL
        if expr.op is BinaryOp.DIV:
            return ExprType.DOUBLE
        return _join(infer_type(expr.left, variable_types), infer_type(expr.right, variable_types))
    if isinstance(expr, Ite):
        return _join(
            infer_type(expr.then, variable_types), infer_type(expr.otherwise, variable_types)
        )
    if isinstance(expr, Call):
        fn = expr.function
        if fn in (Function.FLOOR, Function.CEIL, Function.ROUND, Function.MOD):
            return ExprType.INT
        if fn is Function.LOG:
            return ExprType.DOUBLE
        types = [infer_type(a, variable_types) for a in expr.args]
        out = types[0]
        for t in types[1:]:
            out = _join(out, t)
        return out
    raise TypeError(f"{type(expr).__name__} is not a model expression")


def _join(a: ExprType, b: ExprType) -> ExprType:
    if a is b:
        return a
    if ExprType.DOUBLE in (a, b):
        return ExprType.DOUBLE
    return a if a is not ExprType.BOOL else b


_BOOL_OPS = {BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF}
_COMPARISONS = {BinaryOp.EQ, BinaryOp.NE, BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE}
_INT_ARITHMETIC: dict[BinaryOp, Callable[[Scalar, Scalar], Scalar]] = {
    BinaryOp.ADD: lambda a, b: a + b,
    BinaryOp.SUB: lambda a, b: a - b,
    BinaryOp.MUL: lambda a, b: a * b,
}
_CHECKED_HELPERS = {BinaryOp.ADD: "_iadd", BinaryOp.SUB: "_isub", BinaryOp.MUL: "_imul"}
_PY_OPS = {
    BinaryOp.EQ: "==",
    BinaryOp.NE: "!=",
    BinaryOp.LT: "<",
    BinaryOp.LE: "<=",
    BinaryOp.GT: ">",
    BinaryOp.GE: ">=",
    BinaryOp.ADD: "+",
    BinaryOp.SUB: "-",
    BinaryOp.MUL: "*",
}


# ---------------------------------------------------------------------------------------------
# constant folding (exact, PRISM semantics)
# ---------------------------------------------------------------------------------------------


class _FoldError(Exception):
    """A constant subexpression fails (``mod(3, 0)``); compiled to a runtime failure instead."""


def _fold_binary(op: BinaryOp, a: Scalar, b: Scalar) -> Scalar:
    if op is BinaryOp.AND:
        return bool(a) and bool(b)
    if op is BinaryOp.OR:
        return bool(a) or bool(b)
    if op is BinaryOp.IMPLIES:
        return (not a) or bool(b)
    if op is BinaryOp.IFF:
        return bool(a) == bool(b)
    if op is BinaryOp.EQ:
        return a == b
    if op is BinaryOp.NE:
        return a != b
    if op is BinaryOp.LT:
        return a < b
    if op is BinaryOp.LE:
        return a <= b
    if op is BinaryOp.GT:
        return a > b
    if op is BinaryOp.GE:
        return a >= b
    if op in _INT_ARITHMETIC:
        r = _INT_ARITHMETIC[op](a, b)
        if type(r) is int:
            try:
                ops.check_int(r, f"{a} {_PY_OPS[op]} {b}")
            except ops.DomainFailure as failure:
                raise _FoldError(failure.message) from None
        return r
    # DIV: a double, exact while both are exact and the divisor is not 0
    return ops.scalar_divide(a, b)


def _fold_call(fn: Function, args: list[Scalar], result_type: ExprType) -> Scalar:
    if fn in (Function.MIN, Function.MAX):
        r = min(args) if fn is Function.MIN else max(args)
        if result_type is ExprType.DOUBLE and not isinstance(r, (float, Fraction)):
            return Fraction(r)
        return r
    try:
        if fn in (Function.FLOOR, Function.CEIL, Function.ROUND):
            return ops.scalar_to_int(args[0], fn.value)
        a, b = args
        if fn is Function.MOD:
            return ops.scalar_mod(int(a), int(b))
        if fn is Function.POW:
            if result_type is ExprType.INT:
                return ops.scalar_int_pow(int(a), int(b))
            return ops.scalar_pow(a, b)
        return ops.scalar_log(a, b)
    except ops.DomainFailure as failure:
        raise _FoldError(failure.message) from None


# ---------------------------------------------------------------------------------------------
# runtime helpers referenced by the generated code
# ---------------------------------------------------------------------------------------------


def _rt(v: Columns, span: SourceSpan, f: Callable[..., Any], *args: Any) -> Any:
    """Apply a partial operator of :mod:`posgmc.semantics.operators`; a domain failure becomes an
    :class:`EvaluationError` naming the root row."""
    try:
        return f(*args)
    except ops.DomainFailure as failure:
        raise EvaluationError(failure.message, span, v.root_row(failure.index)) from None


def _rt_mod(v: Columns, a: Any, b: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.mod, a, b)


def _rt_ipow(v: Columns, a: Any, b: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.int_pow, a, b)


def _rt_iadd(v: Columns, a: Any, b: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.int_add, a, b)


def _rt_isub(v: Columns, a: Any, b: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.int_sub, a, b)


def _rt_imul(v: Columns, a: Any, b: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.int_mul, a, b)


def _rt_ineg(v: Columns, a: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.int_neg, a)


def _rt_floor(v: Columns, x: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.to_int, x, "floor")


def _rt_ceil(v: Columns, x: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.to_int, x, "ceil")


def _rt_round(v: Columns, x: Any, span: SourceSpan) -> Any:
    return _rt(v, span, ops.to_int, x, "round")


def _rt_full(v: Columns, value: Any, dtype: Any) -> np.ndarray:
    return np.full(v.n, value, dtype=dtype)


def _rt_lazy_where(
    v: Columns,
    cond: Any,
    f_then: Callable[[Columns], Any],
    f_else: Callable[[Columns], Any],
    dtype: Any,
) -> np.ndarray:
    """``cond ? then : else`` evaluating each branch only on its own rows."""
    cond = np.broadcast_to(np.asarray(cond, dtype=bool), (v.n,))
    out = np.empty(v.n, dtype=dtype)
    for mask, f in ((cond, f_then), (~cond, f_else)):
        rows = np.flatnonzero(mask)
        if rows.size == v.n:
            out[:] = f(v)
        elif rows.size:
            out[rows] = f(v.take(rows))
    return out


def _rt_lazy_and(v: Columns, left: Any, f_right: Callable[[Columns], Any]) -> np.ndarray:
    left = np.broadcast_to(np.asarray(left, dtype=bool), (v.n,))
    out = np.zeros(v.n, dtype=bool)
    rows = np.flatnonzero(left)
    if rows.size:
        out[rows] = f_right(v.take(rows))
    return out


def _rt_lazy_or(v: Columns, left: Any, f_right: Callable[[Columns], Any]) -> np.ndarray:
    left = np.broadcast_to(np.asarray(left, dtype=bool), (v.n,))
    out = np.ones(v.n, dtype=bool)
    rows = np.flatnonzero(~left)
    if rows.size:
        out[rows] = f_right(v.take(rows))
    return out


_RUNTIME: dict[str, Any] = {
    "_np": np,
    "_mod": _rt_mod,
    "_ipow": _rt_ipow,
    "_fpow": ops.float_pow,
    "_iadd": _rt_iadd,
    "_isub": _rt_isub,
    "_imul": _rt_imul,
    "_ineg": _rt_ineg,
    "_floor": _rt_floor,
    "_ceil": _rt_ceil,
    "_round": _rt_round,
    "_log": ops.log,
    "_full": _rt_full,
    "_lazy_where": _rt_lazy_where,
    "_lazy_and": _rt_lazy_and,
    "_lazy_or": _rt_lazy_or,
    "_bool": np.bool_,
    "_int": np.int64,
    "_float": np.float64,
}


# ---------------------------------------------------------------------------------------------
# code generation
# ---------------------------------------------------------------------------------------------


_MAX_NESTING = 40
"""Deepest bracket nesting of one generated Python expression. Python's own parser refuses more
than 200 nested brackets (and its compiler recurses on nesting), so a deeper subexpression is
hoisted into a local ``_tN = ...`` statement of the function evaluating it."""


@dataclass
class _Code:
    """A generated subexpression: source text, type, folded value, and whether it can fail.

    ``prelude``: statements (temporaries) that must run before ``text`` in the same function;
    ``depth``: the bracket nesting of ``text``.
    """

    text: str
    type: ExprType
    constant: Scalar | None = None
    partial: bool = False
    fold_error: str | None = None  # a constant that fails to evaluate
    prelude: tuple[str, ...] = ()
    depth: int = 0
    bounds: tuple[int, int] | None = None  # an int's proven [min, max] over the states


def _fits(bounds: tuple[int, int] | None) -> bool:
    return bounds is not None and ops.INT64_MIN <= bounds[0] and bounds[1] <= ops.INT64_MAX


def _clip(bounds: tuple[int, int] | None) -> tuple[int, int] | None:
    if bounds is None:
        return None
    return max(bounds[0], ops.INT64_MIN), min(bounds[1], ops.INT64_MAX)


def _int_bounds(op: BinaryOp, a: _Code, b: _Code) -> tuple[int, int] | None:
    """Interval arithmetic on the operands' bounds (None: unknown)."""
    if a.bounds is None or b.bounds is None:
        return None
    (al, ah), (bl, bh) = a.bounds, b.bounds
    if op is BinaryOp.ADD:
        return al + bl, ah + bh
    if op is BinaryOp.SUB:
        return al - bh, ah - bl
    products = (al * bl, al * bh, ah * bl, ah * bh)
    return min(products), max(products)


def _joined(
    text: str, type_: ExprType, *parts: _Code, partial: bool = False, extra: int = 1
) -> _Code:
    """A new code whose text embeds ``parts`` (their preludes run first, in order)."""
    prelude: tuple[str, ...] = ()
    for p in parts:
        prelude += p.prelude
    depth = max((p.depth for p in parts), default=0) + extra
    return _Code(text, type_, partial=partial, prelude=prelude, depth=depth)


class _Generator:
    """Turns one expression tree into source text plus auxiliary functions and span constants."""

    def __init__(
        self,
        slots: Mapping[str, tuple[int, ExprType]],
        ranges: Mapping[str, tuple[int, int]],
    ) -> None:
        self.slots = slots
        self.ranges = ranges
        self.variables: set[int] = set()
        self.aux: list[str] = []
        self.env: dict[str, Any] = {}
        self._counter = itertools.count()

    def fresh(self, prefix: str) -> str:
        return f"{prefix}{next(self._counter)}"

    def span_const(self, span: SourceSpan) -> str:
        name = self.fresh("_span")
        self.env[name] = span
        return name

    def function(self, code: _Code) -> str:
        """Wrap ``code`` into an auxiliary ``def _fN(v)`` and return its name."""
        name = self.fresh("_f")
        self.aux.append(_function_source(name, code.prelude, self.materialize(code)))
        return name

    def hoist(self, code: _Code) -> _Code:
        """``code`` itself, or a temporary holding it when its text nests too deeply."""
        if code.depth <= _MAX_NESTING or code.constant is not None:
            return code
        name = self.fresh("_t")
        return dataclasses.replace(
            code, text=name, prelude=code.prelude + (f"{name} = {code.text}",), depth=0
        )

    def materialize(self, code: _Code) -> str:
        """Source that yields an array of ``v.n`` rows (constants become ``_full``)."""
        if code.constant is not None:
            return f"_full(v, {self.literal(code.constant, code.type)}, {_DTYPE_NAMES[code.type]})"
        return code.text

    def literal(self, value: Scalar, type_: ExprType) -> str:
        if type_ is ExprType.BOOL:
            return "True" if value else "False"
        if type_ is ExprType.INT:
            return repr(int(value))
        f = ops.to_float(value)
        if math.isfinite(f):
            return repr(f)
        name = self.fresh("_c")
        self.env[name] = f
        return name

    def const(self, value: Scalar, type_: ExprType) -> _Code:
        if type_ is ExprType.DOUBLE and isinstance(value, int):
            value = Fraction(value)
        bounds = (int(value), int(value)) if type_ is ExprType.INT else None
        return _Code(self.literal(value, type_), type_, constant=value, bounds=bounds)

    def gen(self, root: Expr) -> _Code:
        """The code of ``root``, built bottom-up with an explicit stack: no recursion, so an
        expression nested thousands deep compiles (its text is cut into temporaries)."""
        out: list[_Code] = []
        stack: list[tuple[Expr, bool]] = [(root, False)]
        while stack:
            e, ready = stack.pop()
            kids = children(e)  # the one traversal of the tree (syntax/traversal.py)
            if not ready and kids:
                stack.append((e, True))
                stack.extend((k, False) for k in reversed(kids))
                continue
            args = out[len(out) - len(kids):] if kids else []
            if kids:
                del out[len(out) - len(kids):]
            out.append(self.hoist(self.node(e, args)))
        assert len(out) == 1
        return out[0]

    def node(self, e: Expr, args: list[_Code]) -> _Code:
        if isinstance(e, BoolLit):
            return self.const(bool(e.value), ExprType.BOOL)
        if isinstance(e, IntLit):
            return self.const(int(e.value), ExprType.INT)
        if isinstance(e, DoubleLit):
            v = e.value
            return self.const(
                v if isinstance(v, (Fraction, float)) else Fraction(v), ExprType.DOUBLE
            )
        if isinstance(e, Ident):
            index, type_ = self.slots[e.name]
            self.variables.add(index)
            bounds = self.ranges.get(e.name) if type_ is ExprType.INT else None
            return _Code(f"v[{index}]", type_, depth=1, bounds=bounds)
        if isinstance(e, Unary):
            return self.unary(e, args[0])
        if isinstance(e, Binary):
            return self.binary(e, args[0], args[1])
        if isinstance(e, Ite):
            return self.ite(e, *args)
        if isinstance(e, Call):
            return self.call(e, args)
        raise TypeError(f"{type(e).__name__} cannot be compiled: not a model expression")

    def unary(self, e: Unary, a: _Code) -> _Code:
        if e.op is UnaryOp.NOT:
            if a.constant is not None:
                return self.const(not a.constant, ExprType.BOOL)
            return _joined(f"(~{a.text})", ExprType.BOOL, a, partial=a.partial)
        if a.constant is not None:
            if a.type is ExprType.INT and not _fits((-int(a.constant), 0)):
                return self.failing(
                    ops.int_overflow_message(f"-({a.constant})", -int(a.constant)), e.span, a.type
                )
            return self.const(-a.constant, a.type)
        if a.type is ExprType.INT:
            bounds = None if a.bounds is None else (-a.bounds[1], -a.bounds[0])
            if not _fits(bounds):
                code = _joined(
                    f"_ineg(v, {a.text}, {self.span_const(e.span)})", a.type, a, partial=True
                )
                code.bounds = _clip(bounds)
                return code
            code = _joined(f"(-{a.text})", a.type, a, partial=a.partial)
            code.bounds = bounds
            return code
        return _joined(f"(-{a.text})", a.type, a, partial=a.partial)

    def binary(self, e: Binary, a: _Code, b: _Code) -> _Code:
        op = e.op
        if op in (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES):
            return self.logical(op, a, b)
        if a.constant is not None and b.constant is not None:
            type_ = (
                ExprType.BOOL
                if op in _COMPARISONS or op is BinaryOp.IFF
                else (ExprType.DOUBLE if op is BinaryOp.DIV else _join(a.type, b.type))
            )
            try:
                return self.const(_fold_binary(op, a.constant, b.constant), type_)
            except _FoldError as err:
                return self.failing(str(err), e.span, type_)
        partial = a.partial or b.partial
        if op is BinaryOp.IFF:
            return _joined(f"({a.text} == {b.text})", ExprType.BOOL, a, b, partial=partial)
        if op is BinaryOp.DIV:
            return _joined(
                f"_np.true_divide({a.text}, {b.text})", ExprType.DOUBLE, a, b, partial=partial
            )
        type_ = ExprType.BOOL if op in _COMPARISONS else _join(a.type, b.type)
        if type_ is ExprType.INT:
            # 64-bit ints: numpy wraps silently, so an operation the ranges do not prove safe is
            # checked and fails with the exact value (docs/language.md)
            bounds = _int_bounds(op, a, b)
            if not _fits(bounds):
                code = _joined(
                    f"{_CHECKED_HELPERS[op]}(v, {a.text}, {b.text}, {self.span_const(e.span)})",
                    type_,
                    a,
                    b,
                    partial=True,
                )
            else:
                code = _joined(f"({a.text} {_PY_OPS[op]} {b.text})", type_, a, b, partial=partial)
            code.bounds = _clip(bounds)
            return code
        return _joined(f"({a.text} {_PY_OPS[op]} {b.text})", type_, a, b, partial=partial)

    def logical(self, op: BinaryOp, a: _Code, b: _Code) -> _Code:
        if a.constant is not None:
            # a constant left operand decides or disappears
            lv = bool(a.constant)
            if op is BinaryOp.IMPLIES:
                lv = not lv
            if (op is BinaryOp.AND and not lv) or (op is not BinaryOp.AND and lv):
                return self.const(op is not BinaryOp.AND, ExprType.BOOL)
            return b
        left = f"(~{a.text})" if op is BinaryOp.IMPLIES else a.text
        if b.constant is not None:
            rv = bool(b.constant)
            if (op is BinaryOp.AND) is not rv:
                return self.const(not rv, ExprType.BOOL)
            return _joined(left, ExprType.BOOL, a, partial=a.partial)
        if b.partial:
            # short-circuit: evaluate the right operand only where it decides the result
            helper = "_lazy_and" if op is BinaryOp.AND else "_lazy_or"
            return _joined(
                f"{helper}(v, {left}, {self.function(b)})", ExprType.BOOL, a, partial=True
            )
        sym = "&" if op is BinaryOp.AND else "|"
        return _joined(f"({left} {sym} {b.text})", ExprType.BOOL, a, b, partial=a.partial)

    def ite(self, e: Ite, c: _Code, a: _Code, b: _Code) -> _Code:
        type_ = _join(a.type, b.type)
        if c.constant is not None:
            chosen = a if c.constant else b
            if chosen.constant is not None:
                return self.const(chosen.constant, type_)
            if chosen.type is not type_:
                return _joined(
                    f"({chosen.text}).astype({_DTYPE_NAMES[type_]})",
                    type_,
                    chosen,
                    partial=chosen.partial,
                )
            return chosen
        if a.partial or b.partial or a.fold_error or b.fold_error:
            return _joined(
                f"_lazy_where(v, {c.text}, {self.function(a)}, {self.function(b)}, "
                f"{_DTYPE_NAMES[type_]})",
                type_,
                c,
                partial=True,
            )
        at = (
            a.text
            if a.type is type_ or a.constant is not None
            else f"({a.text}).astype({_DTYPE_NAMES[type_]})"
        )
        bt = (
            b.text
            if b.type is type_ or b.constant is not None
            else f"({b.text}).astype({_DTYPE_NAMES[type_]})"
        )
        if type_ is ExprType.DOUBLE:
            at = self.literal(a.constant, type_) if a.constant is not None else at
            bt = self.literal(b.constant, type_) if b.constant is not None else bt
        code = _joined(
            f"_np.where({c.text}, {at}, {bt})", type_, c, a, b, partial=c.partial, extra=2
        )
        code.bounds = _union(a.bounds, b.bounds) if type_ is ExprType.INT else None
        return code

    def call(self, e: Call, args: list[_Code]) -> _Code:
        fn = e.function
        if fn in (Function.FLOOR, Function.CEIL, Function.ROUND, Function.MOD):
            type_ = ExprType.INT
        elif fn is Function.LOG:
            type_ = ExprType.DOUBLE
        else:
            type_ = args[0].type
            for a in args[1:]:
                type_ = _join(type_, a.type)
        constants = [a.constant for a in args if a.constant is not None]
        if len(constants) == len(args):
            try:
                return self.const(_fold_call(fn, constants, type_), type_)
            except _FoldError as err:
                # never fold away a failure: it may sit in a branch that is never taken
                code = self.failing(str(err), e.span, type_)
                return code
        partial = any(a.partial for a in args)
        texts = [a.text for a in args]
        if fn in (Function.MIN, Function.MAX):
            np_fn = "_np.minimum" if fn is Function.MIN else "_np.maximum"
            if len(texts) == 2:
                acc = f"{np_fn}({texts[0]}, {texts[1]})"
            else:  # n-ary: one flat reduction, not n nested calls
                operands = ", ".join(texts)
                acc = f"{np_fn}.reduce(_np.broadcast_arrays(_full(v, 0, _int), {operands})[1:])"
            if type_ is ExprType.DOUBLE:
                acc = f"_np.asarray({acc}, dtype=_float)"
            code = _joined(acc, type_, *args, partial=partial, extra=3)
            bounds = [a.bounds for a in args if a.bounds is not None]
            if type_ is ExprType.INT and len(bounds) == len(args):
                pick = min if fn is Function.MIN else max
                code.bounds = (pick(lo for lo, _ in bounds), pick(hi for _, hi in bounds))
            return code
        if fn in (Function.FLOOR, Function.CEIL, Function.ROUND):
            a = args[0]
            if a.type is ExprType.INT:
                return a
            helper = {Function.FLOOR: "_floor", Function.CEIL: "_ceil", Function.ROUND: "_round"}[
                fn
            ]
            return _joined(
                f"{helper}(v, {a.text}, {self.span_const(e.span)})", ExprType.INT, a, partial=True
            )
        if fn is Function.MOD:
            a, b = args
            if b.constant is not None and b.constant > 0:
                code = _joined(f"_np.mod({a.text}, {b.text})", ExprType.INT, a, b, partial=partial)
                code.bounds = (0, int(b.constant) - 1)
                return code
            return _joined(
                f"_mod(v, {a.text}, {b.text}, {self.span_const(e.span)})",
                ExprType.INT,
                a,
                b,
                partial=True,
            )
        if fn is Function.POW:
            a, b = args
            if type_ is ExprType.INT:
                return _joined(
                    f"_ipow(v, {a.text}, {b.text}, {self.span_const(e.span)})",
                    ExprType.INT,
                    a,
                    b,
                    partial=True,
                )
            return _joined(f"_fpow({a.text}, {b.text})", ExprType.DOUBLE, a, b, partial=partial)
        return _joined(
            f"_log({texts[0]}, {texts[1]})", ExprType.DOUBLE, *args, partial=partial
        )

    def failing(self, message: str, span: SourceSpan, type_: ExprType) -> _Code:
        """A constant that fails whenever evaluated (e.g. ``mod(1, 0)`` in a branch)."""
        name = self.fresh("_fail")

        def fail(v: Columns) -> Any:
            raise EvaluationError(message, span, v.root_row(0))

        self.env[name] = fail
        return _Code(f"{name}(v)", type_, partial=True, fold_error=message)


_DTYPE_NAMES = {ExprType.BOOL: "_bool", ExprType.INT: "_int", ExprType.DOUBLE: "_float"}


def _union(a: tuple[int, int] | None, b: tuple[int, int] | None) -> tuple[int, int] | None:
    if a is None or b is None:
        return None
    return min(a[0], b[0]), max(a[1], b[1])


def _function_source(name: str, prelude: Sequence[str], result: str) -> str:
    lines = [f"def {name}(v):\n"] + [f"    {line}\n" for line in prelude]
    return "".join(lines) + f"    return {result}\n"


def _constant_function(value: Any) -> Callable[[Columns], Any]:
    def constant(v: Columns) -> Any:
        return value

    return constant


def compile_expr(
    expr: Expr,
    slots: Mapping[str, tuple[int, ExprType]],
    ranges: Mapping[str, tuple[int, int]] | None = None,
) -> CompiledExpr:
    """Compile ``expr`` into a function of a :class:`Columns` batch.

    Args:
        expr: a model expression (literals, variables, operators, functions).
        slots: for each variable name, its column index and type (INT or BOOL).
        ranges: the declared range of int variables; integer ``+ - *`` that these bounds prove
            within 64 bits compile to plain numpy, any other is checked for overflow.

    Returns:
        The compiled expression; for a constant one, ``constant`` holds the folded value.

    Raises:
        KeyError: an identifier that is not a variable.
    """
    gen = _Generator(slots, ranges or {})
    code = gen.gen(expr)
    if code.constant is not None:
        value = code.constant
        plain = _to_numpy_scalar(value, code.type)  # numpy cannot mix Fractions into arrays
        return CompiledExpr(
            type=code.type,
            constant=value,
            variables=frozenset(),
            source=repr(value),
            function=_constant_function(plain),
            span=expr.span,
        )
    source = "".join(gen.aux) + _function_source("_main", code.prelude, code.text)
    namespace: dict[str, Any] = dict(_RUNTIME)
    namespace.update(gen.env)
    exec(compile(source, f"<posgmc expression {expr.span}>", "exec"), namespace)  # noqa: S102
    return CompiledExpr(
        type=code.type,
        constant=None,
        variables=frozenset(gen.variables),
        source=source,
        function=namespace["_main"],
        span=expr.span,
    )
