"""posgmc.checking.decimals: a value reads as the shortest decimal inside its proven interval."""

from __future__ import annotations

from decimal import Decimal

from hypothesis import given
from hypothesis import strategies as st

from posgmc.checking.decimals import MAX_DIGITS, plain, shortest_in


def test_an_exact_value_stopped_short_reads_as_itself() -> None:
    # red_and_black's bold play from start=1: exactly 0.064 (models/red_and_black/README.md), as
    # interval iteration proves it at precision 1e-6
    assert shortest_in(0.0640005, 0.06399999999, 0.06400100001) == "0.064"


def test_a_zero_cost_reads_zero() -> None:
    # tiger's full-observation cost: exactly 0, interval iteration's midpoint of [0, 1e-6]
    assert shortest_in(5.000000001e-07, 0.0, 1e-6) == "0"


def test_the_nearest_of_the_shortest_is_taken() -> None:
    assert shortest_in(0.9000005, 0.8999999999, 0.9000010001) == "0.9"
    assert shortest_in(0.17, 0.1, 0.2) == "0.2"  # 0.1 and 0.2 both inside: 0.2 is nearer
    assert shortest_in(1235.0, 1234.5, 1240.0) == "1240"
    assert shortest_in(-0.5, -0.51, -0.49) == "-0.5"


def test_no_interval_or_a_point_prints_ten_digits() -> None:
    assert shortest_in(1 / 3, 1 / 3, 1 / 3) == plain(1 / 3) == "0.3333333333"
    assert shortest_in(1 / 3, None, None) == "0.3333333333"
    # a value outside its bounds: the bounds are not its interval, nothing is shortened
    assert shortest_in(0.5, 0.6, 0.7) == "0.5"
    assert shortest_in(float("inf"), 0.0, float("inf")) == "inf"


def test_tiny_and_huge_numbers_keep_the_exponent_form() -> None:
    assert shortest_in(1.5e-8, 1e-8, 2e-8) == "2e-08"
    assert shortest_in(123456789012.5, 123456789012.0, 123456789013.0) == "1.23456789e+11"


finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False)


@given(finite, finite, st.floats(min_value=0, max_value=1))
def test_the_printed_number_lies_in_the_proven_interval(a: float, b: float, t: float) -> None:
    lo, hi = min(a, b), max(a, b)
    value = min(max(lo + t * (hi - lo), lo), hi)
    text = shortest_in(value, lo, hi)
    if text == plain(value):
        return  # the plain form is today's 10 digits (the interval holds no shorter decimal)
    assert Decimal(lo) <= Decimal(text) <= Decimal(hi)
    digits = text.lower().split("e")[0].lstrip("-").replace(".", "").strip("0")
    assert len(digits) <= MAX_DIGITS
