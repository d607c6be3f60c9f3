"""A Boolean variable is a Boolean state formula (PRISM's boolean-constant-issue-232: the property
``b`` printed 0.0 instead of false)."""

from __future__ import annotations

import pytest

from posgmc import api

MODEL = (
    "mdp\nconst bool flag;\nmodule m\n  b : bool init flag;\n  [go] !b -> (b'=true);\nendmodule\n"
)


@pytest.mark.parametrize(("flag", "expected"), [(False, False), (True, True)])
def test_boolean_variable_as_property(flag: bool, expected: bool) -> None:
    report = api.check(api.load(text=MODEL, constants={"flag": flag}), properties=["b", "!b"])
    first, negated = report.results
    assert first.value is expected and negated.value is (not expected)
    assert first.to_json()["kind"] == "boolean"


def test_boolean_variable_inside_a_path_formula() -> None:
    report = api.check(api.load(text=MODEL, constants={"flag": False}),
                       properties=["Pmin=? [ F b ]", "Pmax=? [ X !b ]"])
    assert [r.value for r in report.results] == [1.0, 0.0]


def test_products_keep_the_variable_boolean() -> None:
    report = api.check(api.load(text=MODEL, constants={"flag": False}),
                       properties=["Pmin=? [ (X b) & (F b) ]"])
    assert report.results[0].value == 1.0


@pytest.mark.parametrize("flag", [False, True])
def test_boolean_constant_as_property(flag: bool) -> None:
    # a Boolean property prints false/true, never the number 0.0 or 1.0
    report = api.check(api.load(text=MODEL, constants={"flag": flag}), properties=["flag", "!flag"])
    first, negated = report.results
    assert first.value is flag and negated.value is (not flag)
