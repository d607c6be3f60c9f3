"""PRISM's test convention: ``// RESULT: v`` above a property, graded as PRISM's ``-test`` does.

A RESULT line holds a number (``0.85``, ``19/15``, ``1e-3``), an interval ``[lo,hi]``, ``true`` or
``false``, ``Infinity``/``-Infinity``, ``NaN``, ``Error`` or ``Error:substring`` (the property must
fail, with that text in its message), a Pareto front ``[(x,y),...]`` (multi-objective queries), or
``?`` (not checked). ``// RESULT (N=4): v`` applies when the constant N is 4; ``// RESULT
(guaranteed): v`` compares the named number of the result (``guaranteed``, ``vs_fss_adversary``,
``upper_bound``, ``full_observation``) instead of its value. Numbers pass within a relative
tolerance of the result (PRISM: ``1e-5·|v| + 1e-12``) or within the result's proven bounds (PRISM
grades with a result's own accuracy when it has one), an interval when the value ± that tolerance
(or the bounds) meets it; ``~v`` asks only for closeness in exact mode; an expected value may be an
expression over the constants (``RESULT: 1/N``), as PRISM allows. ``Error:a,b`` passes when the
message contains every comma-separated word. In exact mode the fraction must be equal. The rules are
PRISM's (``prism/src/prism/ResultTesting.java``), and the applicable line is the first whose
constants all match (``Property.getExpectedResultString``).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING

from posgmc.checking.results import Bound, PropertyResult
from posgmc.errors import PosgmcError
from posgmc.syntax.ast import ExpectedResult, Property

if TYPE_CHECKING:
    from posgmc.checking.multi_objectives import Front

__all__ = ["Verdict", "check_form", "expected_for", "grade", "DEFAULT_TOLERANCE"]

DEFAULT_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Verdict:
    """``passed``: True, False, or None when the line asks not to check (``?``)."""

    passed: bool | None
    expected: str
    actual: str


def expected_for(prop: Property, constants: Mapping[str, str]) -> ExpectedResult | None:
    """The RESULT line that applies under these constant values: as PRISM, the first one whose
    constants all have these values (numbers compared as numbers, so ``x=0.50`` matches 0.5)."""
    for exp in prop.expected:
        if all(_same_constant(constants.get(k), v) for k, v in exp.constants):
            return exp
    return None


def _same_constant(given: str | None, written: str) -> bool:
    if given is None:
        return False
    if given == written:
        return True
    try:
        return Fraction(given) == Fraction(written)
    except (ValueError, ZeroDivisionError):
        return False


class _OutOfRange(ValueError):
    """A RESULT number beyond the range of a double (``1e999``)."""


def _number(text: str) -> float:
    t = text.strip()
    low = t.lower()
    if low in ("infinity", "inf", "+infinity"):
        return math.inf
    if low in ("-infinity", "-inf"):
        return -math.inf
    if low == "nan":
        return math.nan
    try:
        return float(Fraction(t))
    except OverflowError:
        raise _OutOfRange(f"RESULT value {t!r} is beyond the range of a double (about "
                          "1.8e308); write Infinity for an infinite value") from None


_FLOATING_POINT_ERROR = 1e-12  # PRISM's Accuracy.FLOATING_POINT_ERROR


def _slack(value: float, tolerance: float) -> float:
    """PRISM's error bound around a result: relative to the result, plus floating-point error."""
    return tolerance * abs(value) + _FLOATING_POINT_ERROR


def _close(value: float, expected: float, tolerance: float) -> bool:
    if math.isnan(expected) or math.isnan(value):
        return math.isnan(value) and math.isnan(expected)
    if math.isinf(expected) or math.isinf(value):
        return value == expected
    return abs(value - expected) <= _slack(value, tolerance)


def _expected_number(text: str, constants: Mapping[str, str] | None) -> float:
    """A number, a fraction, Infinity/NaN, or (as PRISM) an expression over the constants."""
    try:
        return _number(text)
    except _OutOfRange:
        raise
    except (ValueError, ZeroDivisionError):
        pass
    from posgmc.semantics.evaluate import evaluate
    from posgmc.syntax.parser import parse_expression

    try:
        expr = parse_expression(text)
        env = {k: _constant_value(v) for k, v in (constants or {}).items()}
        return float(evaluate(expr, env))
    except (PosgmcError, ValueError, TypeError, KeyError, ZeroDivisionError, OverflowError):
        raise ValueError(f"RESULT value {text!r} is not a number, interval, true/false, "
                         "Infinity, NaN, Error, ? or an expression over the constants") from None


def _constant_value(text: str) -> int | Fraction | bool:
    """A constant's value as given on the command line (``4``, ``0.5``, ``1/3``, ``true``)."""
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    value = Fraction(text)
    return int(value) if value.denominator == 1 and "." not in text else value


def _show(value: object, bounds: tuple[float, float] | None = None) -> str:
    """A result as ``test`` prints it: a number with proven ``bounds`` as the shortest decimal
    inside them (:mod:`posgmc.checking.decimals`)."""
    if isinstance(value, float) and bounds is not None and math.isfinite(value):
        from posgmc.checking.decimals import shortest_in

        return shortest_in(value, *bounds)
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "unknown"
    if isinstance(value, float):
        return (
            "Infinity"
            if value == math.inf
            else "-Infinity"
            if value == -math.inf
            else f"{value:.10g}"
        )
    return str(value)


_FORMS = ("a number, an interval [lo, hi], a Pareto front [(x,y),...], true/false, Infinity, "
          "NaN, Error, ? or an expression over the constants")


def _interval(text: str) -> tuple[float, float]:
    """The bounds of ``[lo, hi]``; ValueError unless two numbers with lo <= hi."""
    parts = text[1:-1].split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = (_number(x) for x in parts)
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"RESULT interval {text!r} is not [lo, hi] with two numbers") from None
    if not lo <= hi:
        raise ValueError(f"RESULT interval {text!r} is empty: its lower end exceeds its upper end")
    return lo, hi


def check_form(text: str, names: Collection[str] | None = None) -> None:
    """ValueError unless ``text`` is one of the RESULT forms (see the module docstring); an
    expression may name only ``names`` (the constants), when given."""
    if text.strip() == "?":
        return
    low = text.lower()
    if low in ("true", "false") or low == "error" or low.startswith("error:"):
        return
    body = text[1:] if text.startswith("~") else text
    if body.startswith("[(") and body.endswith("]"):
        _points(body)  # a Pareto front: [(x,y),...]
        return
    if body.startswith("[") and body.endswith("]"):
        _interval(body)
        return
    try:
        _number(body)
    except _OutOfRange:
        raise
    except (ValueError, ZeroDivisionError):
        from posgmc.semantics.evaluate import free_names
        from posgmc.syntax.parser import parse_expression

        try:  # PRISM: an expression over the constants, evaluated when graded
            unknown = free_names(parse_expression(body)) - set(names if names is not None else ())
        except PosgmcError:
            raise ValueError(f"RESULT value {text!r} is not {_FORMS}") from None
        if names is not None and unknown:
            raise ValueError(f"RESULT value {text!r} is not {_FORMS} (no constant named "
                             f"{', '.join(sorted(unknown))})") from None


def grade(
    expected: ExpectedResult,
    outcome: PropertyResult | PosgmcError,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    constants: Mapping[str, str] | None = None,
) -> Verdict:
    """Whether ``outcome`` matches ``expected`` (``constants``: the values an expected expression
    such as ``1/N`` may name).

    Raises:
        ValueError: the RESULT text is not one of the forms above (the caller reports it with the
            line's position).
    """
    text = expected.text.strip()
    if text == "?":
        return Verdict(None, text, "-")
    check_form(text)  # a malformed line is an input error whatever the outcome
    if isinstance(outcome, PosgmcError):
        actual = f"Error: {outcome.message}"
        if text.lower().startswith("error"):
            words = text.split(":", 1)[1].split(",") if ":" in text else []
            message = outcome.message.lower()
            found = all(w.strip().strip('"').lower() in message for w in words)
            return Verdict(found, text, actual)
        return Verdict(False, text, actual)
    if text.lower().startswith("error"):
        return Verdict(False, text, _show(outcome.value))
    front = getattr(outcome, "front", None)
    if front is not None or text.startswith("[("):
        return _grade_front(text, front, tolerance)
    value: float | bool | None = outcome.value
    if expected.number is not None:
        number = getattr(outcome, expected.number, None)
        if number is None:
            return Verdict(False, text, f"the result has no {expected.number} number")
        value = number.value
    if text.lower() in ("true", "false"):
        return Verdict(value is (text.lower() == "true"), text, _show(value))
    if isinstance(value, bool) or value is None:
        return Verdict(False, text, _show(value))
    approximate = text.startswith("~")
    body = text[1:] if approximate else text
    exact = getattr(outcome, "exact", None) if expected.number is None else None
    if exact is not None and not body.startswith("["):
        # exact mode (PRISM's -exact test rule): the fraction must be equal; "~v" only close
        try:
            wanted = Fraction(body)
        except (ValueError, ZeroDivisionError):
            wanted = None
        if wanted is not None and (exact == wanted or not approximate):
            return Verdict(exact == wanted, text, str(exact))
    v = float(value)
    proven = _proven_bounds(outcome) if expected.number is None else None
    shown = proven if expected.number is None else _number_bounds(number)
    if body.startswith("[") and body.endswith("]"):
        lo, hi = _interval(body)
        if math.isnan(v):
            return Verdict(False, text, _show(v))
        slack = _slack(v, tolerance) if math.isfinite(v) else 0.0
        meets = v - slack <= hi and lo <= v + slack
        if proven is not None:
            meets |= (
                proven[0] - _FLOATING_POINT_ERROR <= hi and lo <= proven[1] + _FLOATING_POINT_ERROR
            )
        return Verdict(meets, text, _show(v, shown))
    e = _expected_number(body, constants)
    close = _close(v, e, tolerance)
    if proven is not None and math.isfinite(e):
        # PRISM grades with the result's own accuracy when it has one (ResultTesting's
        # getTestingAccuracy): posgmc's proven bounds are that accuracy
        close |= proven[0] - _FLOATING_POINT_ERROR <= e <= proven[1] + _FLOATING_POINT_ERROR
    return Verdict(close, text, _show(v, shown))


def _number_bounds(number: Bound | None) -> tuple[float, float] | None:
    """A strategy number's proven bounds, when they hold and are finite."""
    if number is None or not number.sound:
        return None
    lower, upper = float(number.lower), float(number.upper)
    return (lower, upper) if math.isfinite(lower) and math.isfinite(upper) else None


def _proven_bounds(outcome: PropertyResult) -> tuple[float, float] | None:
    """The result's proven bounds, when it has finite ones that hold."""
    lower, upper = getattr(outcome, "lower", None), getattr(outcome, "upper", None)
    if not getattr(outcome, "sound", False) or lower is None or upper is None:
        return None
    if not (math.isfinite(lower) and math.isfinite(upper)):
        return None
    return float(lower), float(upper)


def _points(text: str) -> list[tuple[float, ...]]:
    """``[(1,0),(0.6,0.4)]`` (PRISM's Pareto RESULT; stray parentheses tolerated) as tuples."""
    import re

    groups = re.findall(r"\(([^()]*)\)", text)
    if not groups:
        raise ValueError(f"RESULT value {text!r} is not a list of points [(x,y),...]")
    return [tuple(_number(x) for x in g.split(",")) for g in groups]


def _grade_front(text: str, front: Front | None, tolerance: float) -> Verdict:
    """A Pareto RESULT passes when the same vertices were found: every expected point is close to
    a vertex of the computed front and every vertex close to an expected point (relative
    ``tolerance``, absolute 1e-6 near 0)."""
    if front is None:
        return Verdict(False, text, "not a Pareto front")
    if not text.startswith("[("):
        return Verdict(False, text, front.text())
    wanted = _points(text)
    got = [tuple(float(v) for v in p) for p in front.points]
    actual = front.text()

    def near(p: tuple[float, ...], q: tuple[float, ...]) -> bool:
        return len(p) == len(q) and all(
            abs(a - b) <= max(tolerance * abs(b), 1e-6) for a, b in zip(p, q)
        )

    ok = all(any(near(g, w) for g in got) for w in wanted) and all(
        any(near(g, w) for w in wanted) for g in got
    )
    return Verdict(ok, text, actual)
