"""PRISM's partial operators on whole arrays: one definition of their domain and of their message.

``mod``, ``pow`` of two ints, and ``floor``/``ceil``/``round`` are the operators of the language
that can fail (``parser/ast/ExpressionFunc.java``: ``evaluateMod``, ``evaluatePow``,
``evaluateFloor``...). The exploration code generator (:mod:`posgmc.compiler.compile_expr`) and the
state-formula evaluator (:mod:`posgmc.checking.states`) both call the functions below, so a model
and a property give the same value or the same error for the same expression. Each function returns
the result array or raises :class:`DomainFailure` with the message and the first offending position;
the caller turns it into a positioned error naming the state.

* ``mod(i, n)`` needs ``n > 0`` and is never negative (``mod(-1, 3) = 2``);
* ``pow(i, j)`` of two ints needs ``j >= 0`` and a result that fits in 64 bits;
* ``floor``/``ceil``/``round`` need a finite argument; ``round(x) = floor(x + 1/2)``;
* ``/`` is IEEE division (``x/0`` is an infinity, ``0/0`` NaN), as PRISM's doubles.

All functions compute under ``np.errstate(all="ignore")``: IEEE special values are intended and no
numpy warning reaches the user.

Exact mode (PRISM's ``-exact``, :func:`exact_arithmetic`): the scalar functions never fall back to
floating point. A power with a non-integral result, a logarithm and a division by zero have no
rational value and raise :class:`DomainFailure` instead (PRISM: "cannot compute fractional power
exactly"); everything else is already exact on ints and Fractions.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from posgmc.syntax.ast import INT64_MAX, INT64_MIN

__all__ = [
    "DomainFailure",
    "Partial",
    "ceil",
    "floor",
    "round_",
    "divide",
    "exact_arithmetic",
    "exact_only",
    "float_pow",
    "INT64_MAX",
    "INT64_MIN",
    "check_int",
    "int_add",
    "int_mul",
    "int_neg",
    "int_pow",
    "int_sub",
    "log",
    "mod",
    "to_float",
    "to_int",
]

_INT64_MAX = float(np.iinfo(np.int64).max)



def int_overflow_message(text: str, value: int) -> str:
    return f"integer overflow: {text} = {value} is beyond 64-bit integers"


def check_int(value: int, text: str) -> int:
    """``value`` if it is a 64-bit integer. Raises DomainFailure naming ``text`` otherwise."""
    if not INT64_MIN <= value <= INT64_MAX:
        raise DomainFailure(int_overflow_message(text, value), 0)
    return value

_EXACT: contextvars.ContextVar[bool] = contextvars.ContextVar("posgmc_exact", default=False)


@contextlib.contextmanager
def exact_arithmetic() -> Iterator[None]:
    """Within this block the scalar functions compute in rational arithmetic only (exact mode)."""
    token = _EXACT.set(True)
    try:
        yield
    finally:
        _EXACT.reset(token)


def exact_only() -> bool:
    """Whether exact mode (:func:`exact_arithmetic`) is on."""
    return _EXACT.get()


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

    def masked(self, *args: Any) -> tuple[Any, np.ndarray, str | None]:
        """(result, failure mask, message of the first failure or None); never raises."""
        shape = np.broadcast(*[np.asarray(a) for a in args]).shape
        with np.errstate(all="ignore"):
            bad = np.broadcast_to(np.asarray(self.failures(*args), dtype=bool), shape)
            if not np.any(bad):
                return self.compute(*args), bad, None
            i = _first(bad)
            message = self.message(*[_at(np.broadcast_to(a, shape), i) for a in args])
            return self.compute(*args, safe=~bad), bad, message

    def __call__(self, *args: Any) -> Any:
        """The result. Raises DomainFailure at the first failing position."""
        result, bad, message = self.masked(*args)
        if message is not None:
            raise DomainFailure(message, _first(bad))
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
    "mod",
    lambda a, b: np.asarray(b) <= 0,
    lambda a, b: f"mod() by a non-positive divisor ({int(b)})",
    _mod,
)
"""``mod(a, b)`` of ints: needs ``b > 0``; never negative (``mod(-1, 3) = 2``)."""

int_pow = Partial("pow", _pow_overflows, _int_pow_message, _int_pow)
"""``pow(a, b)`` of two ints: needs ``b >= 0`` and a result within 64-bit integers."""

floor = _rounding("floor", np.floor)
ceil = _rounding("ceil", np.ceil)
round_ = _rounding("round", lambda x: np.floor(x + 0.5))
"""``floor``/``ceil``/``round`` of a double: need a finite result within 64-bit integers."""

ROUNDING = {"floor": floor, "ceil": ceil, "round": round_}


def _add_overflows(a: Any, b: Any) -> Any:
    a, b = np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64)
    with np.errstate(all="ignore"):
        r = a + b
    return ((a ^ r) & (b ^ r)) < 0


def _sub_overflows(a: Any, b: Any) -> Any:
    a, b = np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64)
    with np.errstate(all="ignore"):
        r = a - b
    return ((a ^ b) & (a ^ r)) < 0


def _mul_overflows(a: Any, b: Any) -> Any:
    a, b = np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64)
    with np.errstate(all="ignore"):
        r = a * b
        q = np.floor_divide(r, np.where(a == 0, 1, a))
    return ((a != 0) & (q != b)) | ((a == -1) & (b == INT64_MIN)) | ((b == -1) & (a == INT64_MIN))


def _checked(
    name: str, symbol: str, f: Callable[[Any, Any], Any], overflows: Callable[..., Any]
) -> Partial:
    def compute(a: Any, b: Any, safe: Any = None) -> Any:
        return f(_pick(a, safe, 0), _pick(b, safe, 0))

    def message(a: Any, b: Any) -> str:
        exact = {"+": int(a) + int(b), "-": int(a) - int(b), "*": int(a) * int(b)}[symbol]
        return int_overflow_message(f"{int(a)} {symbol} {int(b)}", exact)

    return Partial(name, overflows, message, compute)


int_add = _checked("+", "+", np.add, _add_overflows)
int_sub = _checked("-", "-", np.subtract, _sub_overflows)
int_mul = _checked("*", "*", np.multiply, _mul_overflows)
"""``+ - *`` of int arrays that fail where the exact result leaves 64-bit integers (numpy wraps)."""

int_neg = Partial(
    "-",
    lambda a: np.asarray(a) == INT64_MIN,
    lambda a: int_overflow_message(f"-({int(a)})", -int(a)),
    lambda a, safe=None: np.negative(_pick(a, safe, 0)),
)


def to_int(x: Any, name: str) -> Any:
    """``floor``/``ceil``/``round`` (``name``) of doubles as int64. Raises DomainFailure."""
    return ROUNDING[name](x)


def float_pow(a: Any, b: Any) -> Any:
    """``pow(a, b)`` with a double: IEEE (NaN for a negative base and a fractional exponent)."""
    with np.errstate(all="ignore"):
        return np.power(np.asarray(a, dtype=np.float64), b)


def divide(a: Any, b: Any) -> Any:
    """``a / b``: always a double, IEEE."""
    with np.errstate(all="ignore"):
        return np.true_divide(np.asarray(a, dtype=np.float64), b)


def log(a: Any, b: Any) -> Any:
    """``log(a, b) = ln a / ln b`` (IEEE; no exact value in exact mode)."""
    if _EXACT.get():
        raise DomainFailure("log() cannot be computed exactly", 0)
    with np.errstate(all="ignore"):
        return np.log(np.asarray(a, dtype=np.float64)) / np.log(np.asarray(b, dtype=np.float64))

def to_float(x: int | Fraction | float) -> float:
    """The IEEE double nearest to an exact value: beyond the largest double it is an infinity
    (Java's ``Math.pow(2.0, 2000)`` is ``Infinity``), never an OverflowError."""
    try:
        return float(x)
    except OverflowError:
        return -math.inf if x < 0 else math.inf


# -- exact scalar forms (constant folding and the scalar evaluator) --------------------------------

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
            f"negative exponent {b} in pow() of two ints; "
            f"write pow({a}.0, {b}) for a double result",
            0,
        )
    if a not in (-1, 0, 1) and b * math.log2(abs(a)) >= 63:
        raise DomainFailure("pow() of two ints overflows 64-bit integers", 0)
    r: int = a**b
    if abs(r) > _INT64_MAX:
        raise DomainFailure("pow() of two ints overflows 64-bit integers", 0)
    return r


def scalar_pow(a: Exact, b: Exact) -> Fraction | float:
    """``pow(a, b)`` as a double: exact while the base is exact and the exponent a small integer,
    IEEE otherwise (overflow is an infinity, a negative base with a fractional exponent NaN)."""
    integral = isinstance(b, int) or (isinstance(b, Fraction) and b.denominator == 1)
    if _EXACT.get():
        return _exact_pow(a, b, integral)
    if integral and Fraction(a) == 0 and b < 0:
        return math.inf
    try:
        f = math.pow(to_float(a), to_float(b))
    except ValueError:
        return math.nan
    except OverflowError:
        odd = integral and int(b) % 2 == 1
        return -math.inf if (odd and a < 0) else math.inf
    if (
        integral
        and not isinstance(a, float)
        and abs(int(b)) <= _EXACT_POW_LIMIT
        and math.isfinite(f)
    ):
        return Fraction(a) ** int(b)
    return f


def _exact_pow(a: Exact, b: Exact, integral: bool) -> Fraction:
    """``pow(a, b)`` in exact mode: a rational result or DomainFailure."""
    if isinstance(a, float) or isinstance(b, float):
        raise DomainFailure("pow() of a floating-point value has no exact value", 0)
    base = Fraction(a)
    if integral:
        if base == 0 and b < 0:
            raise DomainFailure("pow(0, negative) has no exact value (division by zero)", 0)
        if abs(int(b)) > 1 << 16:
            raise DomainFailure(f"pow() with exponent {int(b)} is too large to compute exactly", 0)
        return base ** int(b)
    # PRISM's exact engine refuses every fractional exponent, even where the root is rational
    raise DomainFailure(
        f"pow() with the fractional exponent {Fraction(b)} cannot be computed exactly", 0
    )


def scalar_divide(a: Exact, b: Exact) -> Fraction | float:
    """``a / b``: exact while both are exact and ``b != 0``, IEEE otherwise (``x/0`` an infinity,
    ``0/0`` NaN, as PRISM's doubles); in exact mode a division by zero raises DomainFailure."""
    if _EXACT.get() and (b == 0 or isinstance(a, float) or isinstance(b, float)):
        raise DomainFailure(
            "division by zero has no exact value"
            if b == 0
            else "a floating-point value in exact mode",
            0,
        )
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
    """``log(a, b) = ln a / ln b`` (IEEE; no exact value in exact mode)."""
    if _EXACT.get():
        raise DomainFailure("log() cannot be computed exactly", 0)
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
    r = (
        math.floor(x)
        if name == "floor"
        else math.ceil(x)
        if name == "ceil"
        else math.floor(x + Fraction(1, 2))
    )
    if abs(r) > _INT64_MAX:
        raise DomainFailure(f"{name}() of {to_float(x)} overflows 64-bit integers", 0)
    return r
