"""PRISM's ``^`` (power): precedence between ``*`` and unary minus, right associative
(``prism/src/parser/PrismParser.jj``, ``ExpressionPower``), the meaning of ``pow``."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.syntax.ast import Call, Function
from posgmc.syntax.parser import parse_expression


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("2^3", 8),
        ("2^3^2", 512),  # right associative: 2^(3^2), as PRISM
        ("-2^2", 4),  # unary minus binds tighter: (-2)^2, as PRISM's grammar
        ("2*3^2", 18),
        ("2^3*2", 16),
        ("1+2^2", 5),
        ("4^0.5", 2.0),
    ],
)
def test_power_precedence_and_value(text: str, expected: float) -> None:
    model = (
        f"dtmc\nconst double c = {text};\n"
        "module m\n  s : [0..1] init 0;\n  [] true -> true;\nendmodule\n"
    )
    report = api.check(api.load(text=model), properties=["c"])
    assert not report.errors
    assert report.results[0].value == pytest.approx(expected)


def test_power_is_pow() -> None:
    e = parse_expression("x^2", model=True)
    assert isinstance(e, Call) and e.function is Function.POW


def test_power_in_a_property_and_a_guard() -> None:
    # the counter climbs to 2^3 = 8; P(F x=2^3) = 1 and the state count is 9 (x = 0..8)
    model = "dtmc\nmodule m\n  x : [0..20] init 0;\n  [] x<2^3 -> (x'=x+1);\nendmodule\n"
    session = api.load(text=model)
    assert api.build(session).model.num_states == 9
    report = api.check(session, properties=["P=? [ F x=2^3 ]", "P=? [ F x=3^2 ]"])
    assert [r.value for r in report.results] == [1.0, 0.0]
