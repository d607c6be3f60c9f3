"""PRISM accepts a constant expression as a constant's value (``-const p=1/3``; PRISM's
``functionality/verify/exact/exact-const-1.prism.props.args`` passes ``p=1/1/3``)."""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc.errors import ConstantError
from posgmc.semantics.constants import convert_user_value
from posgmc.syntax.ast import VarType


@pytest.mark.parametrize(
    ("var_type", "text", "expected"),
    [
        (VarType.DOUBLE, "1/3", Fraction(1, 3)),
        (VarType.DOUBLE, "1/1/3", Fraction(1, 3)),
        (VarType.DOUBLE, "2.0^-1", Fraction(1, 2)),
        (VarType.INT, "2*3", 6),
        (VarType.INT, "max(2, 5)", 5),
        (VarType.BOOL, "!false", True),
        (VarType.BOOL, "2 > 3", False),
        (VarType.DOUBLE, "0.25", Fraction(1, 4)),
    ],
)
def test_constant_expressions(var_type: VarType, text: str, expected: object) -> None:
    assert convert_user_value("c", var_type, text) == expected


@pytest.mark.parametrize(
    ("var_type", "text", "words"),
    [
        (VarType.INT, "1/2", "not an integer"),  # 1/2 is a double in PRISM, not an int
        (VarType.DOUBLE, "x+1", "not a number"),  # no names
        (VarType.BOOL, "1", "not true or false"),
    ],
)
def test_what_does_not_fit_is_an_error(var_type: VarType, text: str, words: str) -> None:
    with pytest.raises(ConstantError) as info:
        convert_user_value("c", var_type, text)
    assert words in info.value.message
