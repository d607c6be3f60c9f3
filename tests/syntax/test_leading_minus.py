"""A property may start with unary minus where nothing can continue the previous property (PRISM:
``"neg_p1": -P=? [ F s=5 ]``; ``-7;`` in ``functionality/testing/testing.prism.props``)."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.errors import ParseError
from posgmc.syntax.parser import parse_properties, parse_property
from posgmc.syntax.printer import format_expr

MODEL = (
    "dtmc\nmodule m\n  s : [0..1] init 0;\n"
    "  [] s=0 -> 0.25:(s'=1) + 0.75:(s'=0);\n  [] s=1 -> true;\nendmodule\n"
)


def test_minus_binds_to_the_leftmost_operand() -> None:
    assert format_expr(parse_property("-P=? [ F s=1 ] + 1").expr) == "-P=? [ F (s = 1) ] + 1"
    # (-2)*3 and -(2*3) agree; (-1) + 2 and -(1 + 2) do not: PRISM's is the first
    report = api.check(
        api.load(text=MODEL), properties=["-1 + 2", "-2 * 3 - 1", '"neg": -P=? [ X s=1 ]']
    )
    assert [r.value for r in report.results] == [1, -7, -0.25]


def test_after_a_semicolon_at_the_start_and_after_a_name() -> None:
    pf = parse_properties('-7;\nP=? [ F s=1 ];\n-0.5;\n"n": -P=? [ F s=1 ];\n')
    assert [format_expr(p.expr) for p in pf.properties] == ["-7", "P=? [ F (s = 1) ]", "-0.5",
                                                           "-P=? [ F (s = 1) ]"]


def test_without_a_semicolon_minus_continues_the_previous_property() -> None:
    # as in PRISM, whose parser reads on greedily: one property, a subtraction
    pf = parse_properties("P=? [ F s=1 ]\n-0.5\n")
    assert [format_expr(p.expr) for p in pf.properties] == ["P=? [ F (s = 1) ] - 0.5"]


def test_a_lone_minus_is_still_an_error() -> None:
    with pytest.raises(ParseError):
        parse_property("-")
