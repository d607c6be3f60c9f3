"""Helpers shared by the explicit-format readers and writers: exact number formatting and parsing.

Numbers are written so that ``float(text) == value`` holds exactly (the shortest round-trip
representation, integers without a fraction), and read back in bulk with numpy; only the rare
special forms (fractions ``p/q``, DRN placeholders ``$name``) and errors take a per-value path.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import IO, Any

import numpy as np
from numpy.dtypes import StringDType

from posgmc.errors import UnsupportedError

__all__ = [
    "STR",
    "format_values",
    "is_stream",
    "join_columns",
    "parse_number",
    "parse_values",
    "write_to",
]

#: The numpy dtype used for vectorized text building (variable-length UTF-8 strings).
STR = StringDType()

# A decimal number as Storm and PRISM write it; deliberately no "inf", "nan", "0x..", "1_000".
_DECIMAL = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_NUMBER_RE = re.compile(rf"({_DECIMAL})(?:\s*/\s*({_DECIMAL}))?")

# Integral values below this magnitude are written without a fraction ("1" rather than "1.0").
_EXACT_INT_LIMIT = 2.0**53


def is_stream(target: Any) -> bool:
    """True for an open text stream (anything with ``write``), False for a path."""
    return hasattr(target, "write")


def write_to(target: Any, text: str) -> None:
    """Write ``text`` to an open stream, or atomically to the file at path ``target``."""
    if is_stream(target):
        stream: IO[str] = target
        stream.write(text)
        return
    from posgmc.io.atomic import atomic_open

    with atomic_open(target) as handle:
        handle.write(text)


def format_values(values: Any, *, what: str = "value") -> np.ndarray:
    """Format float64 values as StringDType text that reads back to the identical float.

    Args:
        values: array-like of floats.
        what: what the values are, for the error message.

    Returns:
        StringDType[n]: integral values as ``"1"``, others as the shortest round-trip repr.

    Raises:
        UnsupportedError: a value is infinite or NaN (no explicit format can carry it).
    """
    v = np.asarray(values, dtype=np.float64)
    if v.size and not np.all(np.isfinite(v)):
        bad = float(v[~np.isfinite(v)][0])
        raise UnsupportedError(
            f"cannot write the {what} {bad!r}: explicit model files hold finite numbers only",
            hint="make the model's probabilities and rewards finite before exporting it",
        )
    # numpy's float -> string cast yields the shortest repr that round-trips, like repr(float).
    out = v.astype(STR)
    integral = (v == np.trunc(v)) & (np.abs(v) < _EXACT_INT_LIMIT)
    out[integral] = v[integral].astype(np.int64).astype(STR)
    return out


def join_columns(columns: Sequence[np.ndarray], sep: str) -> np.ndarray:
    """Element-wise join of equally long StringDType arrays with ``sep`` (a loop over columns)."""
    acc = columns[0].astype(STR)
    for col in columns[1:]:
        acc = np.strings.add(np.strings.add(acc, sep), col.astype(STR))
    return acc


def parse_number(text: str, placeholders: Mapping[str, float] | None = None) -> float | None:
    """One number: a decimal, a fraction ``p/q`` or a placeholder ``$name``; else None."""
    s = text.strip()
    if s.startswith("$"):
        if placeholders is None:
            return None
        return placeholders.get(s[1:])
    m = _NUMBER_RE.fullmatch(s)
    if m is None:
        return None
    num = float(m.group(1))
    if m.group(2) is None:
        return num
    den = float(m.group(2))
    if den == 0:
        return None
    return num / den


def parse_values(
    texts: np.ndarray,
    *,
    placeholders: Mapping[str, float] | None,
    on_error: Callable[[int, str], Exception],
) -> np.ndarray:
    """Convert stripped StringDType number texts to float64 in bulk.

    Args:
        texts: StringDType[n], each one number (decimal, ``p/q`` or ``$name``), already stripped.
        placeholders: DRN placeholder values, or None when placeholders are not allowed.
        on_error: builds the exception for entry k (with the problem described by the str); raised.

    Returns:
        float64[n], every entry finite.
    """
    n = texts.shape[0]
    out = np.empty(n, dtype=np.float64)
    if n == 0:
        return out
    special = (
        (np.strings.find(texts, "/") >= 0)
        | np.strings.startswith(texts, "$")
        | (np.strings.find(texts, "_") >= 0)
        | (np.strings.str_len(texts) == 0)
    )
    plain = np.flatnonzero(~special)
    try:
        out[plain] = texts[plain].astype(np.float64)
    except ValueError:
        # Error path only: find the first offending entry one by one.
        for k in plain:
            if parse_number(str(texts[k])) is None:
                raise on_error(int(k), "is not a number") from None
        raise  # pragma: no cover - numpy and parse_number disagree
    for k in np.flatnonzero(special):
        text = str(texts[k])
        value = parse_number(text, placeholders)
        if value is None:
            if text.startswith("$"):
                raise on_error(int(k), "is not a defined placeholder")
            raise on_error(int(k), "is not a number")
        out[k] = value
    bad = np.flatnonzero(~np.isfinite(out))
    if bad.size:
        raise on_error(int(bad[0]), "is not a finite number")
    return out
