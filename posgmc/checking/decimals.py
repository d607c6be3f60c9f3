"""Numbers as a person reads them: a value with proven bounds is printed as the shortest decimal
inside its bounds (an exact 0.064 whose interval iteration stopped at ``[0.06399999999,
0.06400100001]`` reads ``0.064``, a cost proven in ``[0, 1e-6]`` reads ``0``), never with more
significant digits than the ten posgmc prints everywhere else. Machine-readable output (JSON)
keeps the full double."""

from __future__ import annotations

import math
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal

__all__ = ["MAX_DIGITS", "plain", "shortest_in"]

MAX_DIGITS = 10
"""Significant digits of a printed number (``%.10g``), and the most :func:`shortest_in` uses."""


def plain(value: float) -> str:
    """``value`` with at most :data:`MAX_DIGITS` significant digits (``%.10g``)."""
    return f"{value:.{MAX_DIGITS}g}"


def shortest_in(value: float, lower: float | None, upper: float | None) -> str:
    """The decimal with the fewest digits after the point (hence the fewest significant digits)
    inside ``[lower, upper]``, the one nearest ``value`` among those; :func:`plain` ``(value)``
    when no decimal of at most :data:`MAX_DIGITS` significant digits lies inside, when a bound is
    missing or not finite, or when ``value`` is outside its bounds (then the bounds are not the
    value's proven interval and must not be used to shorten it).

    The comparison is exact (decimal arithmetic on the doubles' exact binary values), so the text
    printed, read back as a decimal, lies inside the proven interval.
    """
    if lower is None or upper is None or not all(map(math.isfinite, (value, lower, upper))):
        return plain(value)
    if not lower <= value <= upper or lower == upper:
        return plain(value)
    lo, hi, v = Decimal(lower), Decimal(upper), Decimal(value)
    top = max(abs(lo), abs(hi))
    # the coarsest step worth trying is 10^(e+1) with 10^e <= top, which contains 0 (if the
    # interval does) as its only multiple; each finer step adds one digit
    exponent = top.adjusted() + 1
    for _ in range(MAX_DIGITS + 2):
        step = Decimal(1).scaleb(exponent)
        first = (lo / step).to_integral_value(rounding=ROUND_CEILING)
        last = (hi / step).to_integral_value(rounding=ROUND_FLOOR)
        if first <= last:
            nearest = min(max((v / step).to_integral_value(), first), last)
            text = _text(nearest * step, exponent)
            if _significant(text) <= MAX_DIGITS:
                return text
            break
        exponent -= 1
    return plain(value)


def _text(number: Decimal, exponent: int) -> str:
    """``number`` (a multiple of 10^exponent) in positional notation, or ``%g``'s exponent form
    where that is how :func:`plain` would write a number of its size."""
    if number == 0:
        return "0"
    text = f"{number:f}" if exponent < 0 else str(int(number))
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    size = number.adjusted()
    if size < -5 or size >= MAX_DIGITS:  # %g switches to exponent notation there
        return f"{float(text):.{MAX_DIGITS}g}"
    return text


def _significant(text: str) -> int:
    """How many significant digits a positional or ``%g`` decimal text has."""
    mantissa = text.lower().split("e")[0].lstrip("-").replace(".", "").lstrip("0")
    return len(mantissa.rstrip("0")) or 1 if mantissa else 1
