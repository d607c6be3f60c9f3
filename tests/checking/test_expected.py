"""PRISM's test-mode grading (``prism/src/prism/ResultTesting.java``, ``Property.java``) as
:mod:`posgmc.checking.expected` implements it."""

from __future__ import annotations

import pytest

from posgmc.checking.expected import expected_for, grade
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.errors import SemanticError
from posgmc.syntax.ast import ExpectedResult, Property
from posgmc.syntax.parser import parse_properties


def _result(value: float | bool, lower: float | None = None, upper: float | None = None,
            sound: bool = True) -> PropertyResult:
    kind = ResultKind.BOOLEAN if isinstance(value, bool) else ResultKind.NUMBER
    return PropertyResult(property="p", name=None, kind=kind, value=value, lower=lower,
                          upper=upper, seconds=0.0, method="test", sound=sound)


def _exp(text: str) -> ExpectedResult:
    return ExpectedResult(text)


def test_the_first_matching_line_applies() -> None:
    # PRISM's getExpectedResultString: the first RESULT whose constants all match, not the most
    # specific one; numbers are compared as numbers
    pf = parse_properties("// RESULT: 1\n// RESULT (N=2): 2\nP=? [ F true ]\n")
    prop: Property = pf.properties[0]
    assert expected_for(prop, {"N": "2"}).text == "1"  # type: ignore[union-attr]
    pf = parse_properties("// RESULT (x=0.50): 7\nP=? [ F true ]\n")
    assert expected_for(pf.properties[0], {"x": "1/2"}).text == "7"  # type: ignore[union-attr]
    assert expected_for(pf.properties[0], {"x": "0.4"}) is None


def test_tolerance_is_relative_to_the_result() -> None:
    assert grade(_exp("1.0"), _result(1.0 + 0.9e-5)).passed
    assert not grade(_exp("1.0"), _result(1.0 + 2e-5)).passed
    # near 0 only PRISM's floating-point slack (1e-12) is left
    assert not grade(_exp("0"), _result(1e-10)).passed


def test_proven_bounds_count_as_the_results_accuracy() -> None:
    # bounded-reach-2.pm: value 0.01562525 in [0.015625, 0.0156255], PRISM says 1/64
    assert grade(_exp("0.015625"), _result(0.01562525, 0.015625, 0.0156255)).passed
    # ... but not bounds that are not proven
    assert not grade(_exp("0.015625"), _result(0.01562525, 0.015625, 0.0156255, sound=False)).passed


def test_expected_values_may_be_expressions_over_the_constants() -> None:
    assert grade(_exp("1/N"), _result(0.25), constants={"N": "4"}).passed
    assert grade(_exp("(5-2*p)/(10-10*p)"), _result(0.5), constants={"p": "0"}).passed


def test_errors_need_every_listed_word() -> None:
    err = SemanticError("this is not supported here")
    assert grade(_exp("Error:not,supported"), err).passed
    assert not grade(_exp("Error:not,allowed"), err).passed
    assert grade(_exp("Error"), err).passed
    assert not grade(_exp("Error"), _result(0.5)).passed  # a value where an error is expected


def test_intervals_and_booleans() -> None:
    assert grade(_exp("[0.2,0.4]"), _result(0.3)).passed
    assert not grade(_exp("[0.2,0.4]"), _result(0.5)).passed
    assert grade(_exp("true"), _result(True)).passed
    assert not grade(_exp("true"), _result(1.0)).passed


def test_expression_lines_may_name_only_constants() -> None:
    from posgmc.checking.expected import check_form

    check_form("1/N", ["N"])
    check_form("(5-2*p)/(10-10*p)", ["p"])
    with pytest.raises(ValueError, match="no constant named zero"):
        check_form("zero", ["N"])
