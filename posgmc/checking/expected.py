"""PRISM's test convention: ``// RESULT: v`` above a property, graded as PRISM's ``-test`` does.

A RESULT line holds a number (``0.85``, ``19/15``, ``1e-3``), an interval ``[lo,hi]``, ``true`` or
``false``, ``Infinity``/``-Infinity``, ``NaN``, ``Error`` or ``Error:substring`` (the property must
fail, with that text in its message), or ``?`` (not checked). ``// RESULT (N=4): v`` applies when
the constant N is 4; ``// RESULT (guaranteed): v`` compares the named number of the result
(``guaranteed``, ``vs_fss_adversary``, ``upper_bound``, ``full_observation``) instead of its value.
Numbers pass within a relative tolerance (PRISM: 1e-5; absolute near 0), and an interval when
the value lies in it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from posgmc.checking.results import PropertyResult
from posgmc.errors import PosgmcError
from posgmc.syntax.ast import ExpectedResult, Property

__all__ = ["Verdict", "check_form", "expected_for", "grade", "DEFAULT_TOLERANCE"]

DEFAULT_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Verdict:
    """``passed``: True, False, or None when the line asks not to check (``?``)."""

    passed: bool | None
    expected: str
    actual: str


def expected_for(prop: Property, constants: Mapping[str, str]) -> ExpectedResult | None:
    """The RESULT line that applies under these constant values (the most specific one)."""
    best: ExpectedResult | None = None
    for exp in prop.expected:
        if all(constants.get(k) == v for k, v in exp.constants):
            if best is None or len(exp.constants) > len(best.constants):
                best = exp
    return best


def _number(text: str) -> float:
    t = text.strip()
    low = t.lower()
    if low in ("infinity", "inf", "+infinity"):
        return math.inf
    if low in ("-infinity", "-inf"):
        return -math.inf
    if low == "nan":
        return math.nan
    return float(Fraction(t))


def _close(value: float, expected: float, tolerance: float) -> bool:
    if math.isnan(expected):
        return math.isnan(value)
    if math.isinf(expected):
        return value == expected
    return abs(value - expected) <= max(tolerance * abs(expected), 1e-10)  # absolute near 0


def _show(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "unknown"
    if isinstance(value, float):
        return "Infinity" if value == math.inf else "-Infinity" if value == -math.inf else f"{value:.10g}"
    return str(value)


_FORMS = ("a number, an interval [lo, hi], a Pareto front [(x,y),...], true/false, Infinity, "
          "NaN, Error or ?")


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


def check_form(text: str) -> None:
    """ValueError unless ``text`` is one of the RESULT forms (see the module docstring)."""
    if text.strip() == "?":
        return
    low = text.lower()
    if low in ("true", "false") or low == "error" or low.startswith("error:"):
        return
    if text.startswith("[(") and text.endswith("]"):
        _points(text)  # a Pareto front: [(x,y),...]
        return
    if text.startswith("[") and text.endswith("]"):
        _interval(text)
        return
    try:
        _number(text)
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"RESULT value {text!r} is not {_FORMS}") from None


def grade(expected: ExpectedResult, outcome: PropertyResult | PosgmcError, *,
          tolerance: float = DEFAULT_TOLERANCE) -> Verdict:
    """Whether ``outcome`` matches ``expected``.

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
            wanted = text.split(":", 1)[1].strip().strip('"') if ":" in text else ""
            return Verdict(wanted.lower() in outcome.message.lower(), text, actual)
        return Verdict(False, text, actual)
    if text.lower().startswith("error"):
        return Verdict(False, text, _show(outcome.value))
    front = getattr(outcome, "front", None)
    if front is not None or text.startswith("[("):
        return _grade_front(text, front, tolerance)
    value: object = outcome.value
    if expected.number is not None:
        number = getattr(outcome, expected.number, None)
        if number is None:
            return Verdict(False, text, f"the result has no {expected.number} number")
        value = number.value
    if text.lower() in ("true", "false"):
        return Verdict(value is (text.lower() == "true"), text, _show(value))
    if isinstance(value, bool) or value is None:
        return Verdict(False, text, _show(value))
    exact = getattr(outcome, "exact", None) if expected.number is None else None
    if exact is not None and not text.startswith("["):
        # exact mode (PRISM's -exact test rule): the fraction must be equal, not close
        fraction: Fraction | None
        try:
            fraction = Fraction(text)
        except (ValueError, ZeroDivisionError):
            fraction = None
        if fraction is not None:
            return Verdict(exact == fraction, text, str(exact))
    v = float(value)  # type: ignore[arg-type]
    if text.startswith("[") and text.endswith("]"):
        lo, hi = _interval(text)
        return Verdict(lo - tolerance * abs(lo) <= v <= hi + tolerance * abs(hi), text, _show(v))
    try:
        e = _number(text)
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"RESULT value {text!r} is not a number, interval, true/false, "
                         "Infinity, NaN, Error or ?") from None
    return Verdict(_close(v, e, tolerance), text, _show(v))


def _points(text: str) -> list[tuple[float, ...]]:
    """``[(1,0),(0.6,0.4)]`` (PRISM's Pareto RESULT; stray parentheses tolerated) as tuples."""
    import re

    groups = re.findall(r"\(([^()]*)\)", text)
    if not groups:
        raise ValueError(f"RESULT value {text!r} is not a list of points [(x,y),...]")
    return [tuple(_number(x) for x in g.split(",")) for g in groups]


def _grade_front(text: str, front: object, tolerance: float) -> Verdict:
    """A Pareto RESULT passes when the same vertices were found: every expected point is close to
    a vertex of the computed front and every vertex close to an expected point (relative
    ``tolerance``, absolute 1e-6 near 0)."""
    if front is None:
        return Verdict(False, text, "not a Pareto front")
    if not text.startswith("[("):
        return Verdict(False, text, front.text())  # type: ignore[attr-defined]
    wanted = _points(text)
    got = [tuple(float(v) for v in p) for p in front.points]  # type: ignore[attr-defined]
    actual = front.text()  # type: ignore[attr-defined]

    def near(p: tuple[float, ...], q: tuple[float, ...]) -> bool:
        return len(p) == len(q) and all(
            abs(a - b) <= max(tolerance * abs(b), 1e-6) for a, b in zip(p, q)
        )

    ok = all(any(near(g, w) for g in got) for w in wanted) and all(
        any(near(g, w) for w in wanted) for g in got
    )
    return Verdict(ok, text, actual)
