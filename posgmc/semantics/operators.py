"""PRISM's partial operators on whole arrays: one definition of their domain and of their message.

``mod``, ``pow`` of two ints, and ``floor``/``ceil``/``round`` are the operators of the language
that can fail (``parser/ast/ExpressionFunc.java``: ``evaluateMod``, ``evaluatePow``,
``evaluateFloor``...). The exploration code generator (:mod:`posgmc.build.compile_expr`) and the
state-formula evaluator (:mod:`posgmc.checking.states`) both call the functions below, so a model and
a property give the same value or the same error for the same expression. Each function returns the
result array or raises :class:`DomainFailure` with the message and the first offending position; the
caller turns it into a positioned error naming the state.

* ``mod(i, n)`` needs ``n > 0`` and is never negative (``mod(-1, 3) = 2``);
* ``pow(i, j)`` of two ints needs ``j >= 0`` and a result that fits in 64 bits;
* ``floor``/``ceil``/``round`` need a finite argument; ``round(x) = floor(x + 1/2)``;
* ``/`` is IEEE division (``x/0`` is an infinity, ``0/0`` NaN), as PRISM's doubles.

All functions compute under ``np.errstate(all="ignore")``: IEEE special values are intended and no
numpy warning reaches the user.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from posgmc.semantics.symbols import Type
from posgmc.syntax.ast import BinaryOp, Function

__all__ = [
    "BINARY",
    "BinarySpec",
    "binary_type",
    "call_type",
    "ite_type",
    "DomainFailure",
    "Partial",
    "ceil",
    "floor",
    "round_",
    "divide",
    "float_pow",
    "int_pow",
    "log",
    "mod",
    "to_float",
    "to_int",
]

_INT64_MAX = float(np.iinfo(np.int64).max)


# -- type rules (PRISM: ExpressionBinaryOp/ExpressionFunc.typeCheck) ----------------------------------

_BOOLEAN_RESULT = frozenset(
    {
        BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF,
        BinaryOp.EQ, BinaryOp.NE, BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE,
    }
)


def _join(a: Type, b: Type) -> Type:
    """The type of a value that is ``a`` or ``b`` (int widens to double)."""
    if a is b:
        return a
    if Type.DOUBLE in (a, b):
        return Type.DOUBLE
    return a if a is not Type.BOOL else b


def binary_type(op: BinaryOp, left: Type, right: Type) -> Type:
    """The result type of ``left op right`` for well-typed operands: Boolean for connectives and
    comparisons, double for ``/`` (always), otherwise int unless an operand is a double."""
    if op in _BOOLEAN_RESULT:
        return Type.BOOL
    if op is BinaryOp.DIV:
        return Type.DOUBLE
    return _join(left, right)


def ite_type(then: Type, otherwise: Type) -> Type:
    """The result type of ``c ? then : otherwise`` (an int branch widens to double)."""
    return _join(then, otherwise)


def call_type(function: Function, args: list[Type]) -> Type:
    """The result type of a function call: ``floor``/``ceil``/``round``/``mod`` give ints, ``log``
    a double, ``min``/``max``/``pow`` an int unless an argument is a double."""
    if function in (Function.FLOOR, Function.CEIL, Function.ROUND, Function.MOD):
        return Type.INT
    if function is Function.LOG:
        return Type.DOUBLE
    out = args[0]
    for t in args[1:]:
        out = _join(out, t)
    return out


class DomainFailure(Exception):
    """An operator applied outside its domain; ``index`` is the first offending position (0 for a
    scalar)."""

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.message = message
        self.index = index


def _first(bad: Any) -> int:
    arr = np.asarray(bad)
    return int(np.flatnonzero(arr)[0]) if arr.ndim else 0


def _at(x: Any, i: int) -> Any:
    arr = np.asarray(x)
    return arr.flat[i] if arr.ndim else arr[()]


@dataclass(frozen=True)
class Partial:
    """A partial operator on arrays: where it fails, what it says there, and its value elsewhere.

    ``failures(*args)``: bool mask (broadcast shape) of the positions outside the domain.
    ``message(*args_at_position)``: the error for one failing position (scalar arguments).
    ``compute(*args)``: the result, with failing positions given harmless inputs (their values
    are meaningless and must be masked by the caller).
    """

    name: str
    failures: Callable[..., Any]
    message: Callable[..., str]
    compute: Callable[..., Any]

    def masked(self, *args: Any) -> tuple[Any, np.ndarray, Callable[[int], str] | None]:
        """(result, failure mask, the message at a failing position, or None without failures);
        never raises."""
        shape = np.broadcast(*[np.asarray(a) for a in args]).shape
        with np.errstate(all="ignore"):
            bad = np.broadcast_to(np.asarray(self.failures(*args), dtype=bool), shape)
            if not np.any(bad):
                return self.compute(*args), bad, None

            def message_at(i: int) -> str:
                return self.message(*[_at(np.broadcast_to(a, shape), i) for a in args])

            return self.compute(*args, safe=~bad), bad, message_at

    def __call__(self, *args: Any) -> Any:
        """The result. Raises DomainFailure at the first failing position."""
        result, bad, message_at = self.masked(*args)
        if message_at is not None:
            i = _first(bad)
            raise DomainFailure(message_at(i), i)
        return result


def _pick(x: Any, safe: Any, fallback: Any) -> Any:
    return x if safe is None else np.where(safe, x, fallback)


def _mod(a: Any, b: Any, safe: Any = None) -> Any:
    return np.mod(a, _pick(b, safe, 1))


def _int_pow(a: Any, b: Any, safe: Any = None) -> Any:
    return np.power(_pick(a, safe, 0), _pick(b, safe, 0))


def _pow_overflows(a: Any, b: Any) -> Any:
    with np.errstate(all="ignore"):
        exact = np.power(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    return (np.asarray(b) < 0) | (np.abs(exact) > _INT64_MAX)


def _int_pow_message(a: Any, b: Any) -> str:
    if b < 0:
        return (
            f"negative exponent {int(b)} in pow() of two ints; write pow({int(a)}.0, {int(b)}) "
            "for a double result"
        )
    return "pow() of two ints overflows 64-bit integers"


def _rounding(name: str, f: Callable[[Any], Any]) -> Partial:
    def rounded(x: Any) -> Any:
        return f(np.asarray(x, dtype=np.float64))

    def compute(x: Any, safe: Any = None) -> Any:
        return _pick(rounded(x), safe, 0.0).astype(np.int64)

    return Partial(
        name,
        lambda x: ~np.isfinite(rounded(x)) | (np.abs(rounded(x)) > _INT64_MAX),
        lambda x: f"{name}() of {float(x)} is not an integer",
        compute,
    )


mod = Partial(
    "mod", lambda a, b: np.asarray(b) <= 0, lambda a, b: f"mod() by a non-positive divisor ({int(b)})", _mod
)
"""``mod(a, b)`` of ints: needs ``b > 0``; never negative (``mod(-1, 3) = 2``)."""

int_pow = Partial("pow", _pow_overflows, _int_pow_message, _int_pow)
"""``pow(a, b)`` of two ints: needs ``b >= 0`` and a result within 64-bit integers."""

floor = _rounding("floor", np.floor)
ceil = _rounding("ceil", np.ceil)
round_ = _rounding("round", lambda x: np.floor(x + 0.5))
"""``floor``/``ceil``/``round`` of a double: need a finite result within 64-bit integers."""

ROUNDING = {"floor": floor, "ceil": ceil, "round": round_}


def to_int(x: Any, name: str) -> Any:
    """``floor``/``ceil``/``round`` (``name``) of doubles as int64. Raises DomainFailure."""
    return ROUNDING[name](x)


def float_pow(a: Any, b: Any) -> Any:
    """``pow(a, b)`` with a double: IEEE (NaN for a negative base and a fractional exponent), with
    one zero (see :func:`divide`)."""
    with np.errstate(all="ignore"):
        base = np.asarray(a, dtype=np.float64) + 0.0
        r = np.power(base, b)
        # numpy gives NaN for (-inf) ** y with y not an integer; C99 and Java give +inf (y > 0)
        # or +0 (y < 0), as the exact evaluator (math.pow) does
        fix = np.isneginf(base) & np.isnan(r) & ~np.isnan(b)
        if np.any(fix):
            r = np.where(fix, np.where(np.asarray(b) > 0, np.inf, 0.0), r)
        return r


def divide(a: Any, b: Any) -> Any:
    """``a / b``: always a double, IEEE, with one zero: ``x / -0.0`` is ``x / 0.0``, because exact
    arithmetic (constant folding, the scalar evaluator) has no signed zero and all evaluators must
    agree (``-0.0 + 0.0`` is ``+0.0`` in IEEE)."""
    with np.errstate(all="ignore"):
        return np.true_divide(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64) + 0.0)


def log(a: Any, b: Any) -> Any:
    """``log(a, b) = ln a / ln b`` (IEEE)."""
    with np.errstate(all="ignore"):
        return np.log(np.asarray(a, dtype=np.float64)) / np.log(np.asarray(b, dtype=np.float64))

def to_float(x: int | Fraction | float) -> float:
    """The IEEE double nearest to an exact value: beyond the largest double it is an infinity
    (Java's ``Math.pow(2.0, 2000)`` is ``Infinity``), never an OverflowError."""
    try:
        return float(x)
    except OverflowError:
        return math.copysign(math.inf, x)


# -- exact scalar forms (constant folding and the scalar evaluator) ----------------------------------

Exact = int | Fraction | float
"""A scalar number: int for ints, Fraction for a double while exact, float once inexact."""

_EXACT_POW_LIMIT = 4096  # beyond this exponent an exact power is not worth its size


def scalar_mod(a: int, b: int) -> int:
    """``mod(a, b)``. Raises DomainFailure for ``b <= 0``."""
    if b <= 0:
        raise DomainFailure(f"mod() by a non-positive divisor ({b})", 0)
    return a % b


def scalar_int_pow(a: int, b: int) -> int:
    """``pow(a, b)`` of two ints. Raises DomainFailure for ``b < 0`` or beyond 64-bit integers."""
    if b < 0:
        raise DomainFailure(
            f"negative exponent {b} in pow() of two ints; write pow({a}.0, {b}) for a double result",
            0,
        )
    if a not in (-1, 0, 1) and b * math.log2(abs(a)) >= 63:
        raise DomainFailure("pow() of two ints overflows 64-bit integers", 0)
    r = a**b
    if abs(r) > _INT64_MAX:
        raise DomainFailure("pow() of two ints overflows 64-bit integers", 0)
    return r


def scalar_pow(a: Exact, b: Exact) -> Fraction | float:
    """``pow(a, b)`` as a double: exact while the base is exact and the exponent a small integer,
    IEEE otherwise (overflow is an infinity, a negative base with a fractional exponent NaN)."""
    integral = isinstance(b, int) or (isinstance(b, Fraction) and b.denominator == 1)
    fa, fb = to_float(a), to_float(b)
    if fa == 0 and fb < 0:
        return math.inf  # Java: Math.pow(0.0, y) = Infinity for every y < 0
    try:
        f = math.pow(fa, fb)
    except ValueError:
        return math.nan
    except OverflowError:
        odd = integral and int(b) % 2 == 1
        return -math.inf if (odd and a < 0) else math.inf
    if integral and not isinstance(a, float) and abs(int(b)) <= _EXACT_POW_LIMIT and math.isfinite(f):
        return Fraction(a) ** int(b)
    return f


def scalar_divide(a: Exact, b: Exact) -> Fraction | float:
    """``a / b``: exact while both are exact and ``b != 0``, IEEE otherwise (``x/0`` an infinity,
    ``0/0`` NaN, as PRISM's doubles)."""
    if not isinstance(a, float) and not isinstance(b, float) and b != 0:
        return Fraction(a) / Fraction(b)
    x, y = to_float(a), to_float(b)
    if y == 0:
        if x == 0 or math.isnan(x):
            return math.nan
        return math.copysign(math.inf, x) * math.copysign(1.0, y)
    return x / y


def _ln(x: float) -> float:
    if math.isnan(x) or x < 0:
        return math.nan
    if x == 0:
        return -math.inf
    return math.log(x)


def scalar_log(a: Exact, b: Exact) -> float:
    """``log(a, b) = ln a / ln b`` (IEEE)."""
    return float(scalar_divide(_ln(to_float(a)), _ln(to_float(b))))


def scalar_to_int(x: Exact, name: str) -> int:
    """``floor``/``ceil``/``round`` (``name``); ``round(x) = floor(x + 1/2)``. Raises DomainFailure
    for a non-finite argument or a result beyond 64-bit integers."""
    if isinstance(x, int):
        return x
    if isinstance(x, float):
        if not math.isfinite(x):
            raise DomainFailure(f"{name}() of {x} is not an integer", 0)
        x = Fraction(x)
    r = math.floor(x) if name == "floor" else math.ceil(x) if name == "ceil" else math.floor(x + Fraction(1, 2))
    if abs(r) > _INT64_MAX:
        raise DomainFailure(f"{name}() of {to_float(x)} overflows 64-bit integers", 0)
    return r



# -- the table of binary operators ---------------------------------------------------------------------


@dataclass(frozen=True)
class BinarySpec:
    """What a binary operator means.

    ``scalar``: its value on exact scalars (bool, int, Fraction, float; operands already checked
    for type). ``vector``: its value on numpy arrays (IEEE doubles). ``infix``: the numpy infix
    operator the exploration code generator writes for it, or None when it calls ``vector``.
    Evaluation order and short-circuiting (``&``, ``|``, ``=>``) belong to each evaluator; the
    value of the operator is this table's.
    """

    op: BinaryOp
    scalar: Callable[[Any, Any], Any]
    vector: Callable[[Any, Any], Any]
    infix: str | None


def _vec(f: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
    def apply(a: Any, b: Any) -> Any:
        with np.errstate(all="ignore"):
            return f(a, b)

    return apply


BINARY: dict[BinaryOp, BinarySpec] = {
    spec.op: spec
    for spec in (
        BinarySpec(BinaryOp.AND, lambda a, b: bool(a) and bool(b), np.logical_and, "&"),
        BinarySpec(BinaryOp.OR, lambda a, b: bool(a) or bool(b), np.logical_or, "|"),
        BinarySpec(
            BinaryOp.IMPLIES,
            lambda a, b: (not a) or bool(b),
            lambda a, b: np.logical_or(np.logical_not(a), b),
            None,
        ),
        BinarySpec(BinaryOp.IFF, lambda a, b: bool(a) == bool(b), np.equal, "=="),
        BinarySpec(BinaryOp.EQ, lambda a, b: a == b, _vec(np.equal), "=="),
        BinarySpec(BinaryOp.NE, lambda a, b: a != b, _vec(np.not_equal), "!="),
        BinarySpec(BinaryOp.LT, lambda a, b: a < b, _vec(np.less), "<"),
        BinarySpec(BinaryOp.LE, lambda a, b: a <= b, _vec(np.less_equal), "<="),
        BinarySpec(BinaryOp.GT, lambda a, b: a > b, _vec(np.greater), ">"),
        BinarySpec(BinaryOp.GE, lambda a, b: a >= b, _vec(np.greater_equal), ">="),
        BinarySpec(BinaryOp.ADD, lambda a, b: a + b, _vec(np.add), "+"),
        BinarySpec(BinaryOp.SUB, lambda a, b: a - b, _vec(np.subtract), "-"),
        BinarySpec(BinaryOp.MUL, lambda a, b: a * b, _vec(np.multiply), "*"),
        BinarySpec(BinaryOp.DIV, lambda a, b: scalar_divide(a, b), lambda a, b: divide(a, b), None),
    )
}
"""Every binary operator of the language (``BINARY[op]``)."""
