"""The time budget of synthesis (issue #9, "--timeout bounds the whole run"): the first
synthesised property's budget counts from ``SynthesisOptions.started`` (the run's start, set by
the CLI before loading and by ``api.check`` on entry), later properties from their own start."""

from __future__ import annotations

import dataclasses
import time

import pytest

from posgmc import api
from posgmc.syntax import parser
from posgmc.synthesis.checker import SynthesisChecker
from tests.synthesis.helpers import POSMG, PROP, SMALL, random_posg


def _checker(model, options):  # type: ignore[no-untyped-def]
    return SynthesisChecker(model, coalition_of=api._resolver(model, False).coalition_of,
                            scalar=api._scalar, synthesis=options)


def test_a_spent_budget_is_partial_for_the_first_property_only() -> None:
    """With the run's clock started long ago, the first property's budget is already spent:
    its result says partial (its numbers still proven); the second property gets its own budget
    (SMALL finishes far within it on 3-7 states), so it is not."""
    model = random_posg(0)
    options = dataclasses.replace(SMALL, timeout=60.0, started=time.perf_counter() - 120.0)
    checker = _checker(model, options)
    expr = parser.parse_property(PROP).expr
    first = checker.check(expr, text=PROP)
    second = checker.check(expr, text=PROP)
    assert first.synthesis is not None and second.synthesis is not None
    assert first.synthesis["partial"] is True
    assert second.synthesis["partial"] is False
    # both verified by the sound engines: lower <= upper, proven
    for r in (first, second):
        assert r.guaranteed is not None and r.guaranteed.sound
        assert r.guaranteed.lower <= r.guaranteed.upper


def test_api_check_starts_the_clock_on_entry() -> None:
    """api.check sets ``started`` when the caller did not: the options it passes on carry it."""
    model = random_posg(1)
    before = time.perf_counter()
    report = api.check(model, properties=[PROP], synthesis=dataclasses.replace(SMALL, timeout=60))
    result = report.results[0]
    assert result.synthesis is not None and result.synthesis["partial"] is False
    assert time.perf_counter() - before < 60


@pytest.mark.slow
def test_dodge_ends_within_the_budget() -> None:
    """dodge-6-lines (PAYNT's POSMG, 639 states, vendored): loading, building, synthesis and
    verification end within the budget plus a few seconds (the step running at a deadline; a
    loaded machine)."""
    started = time.perf_counter()
    session = api.load(POSMG / "dodge-6-lines" / "sketch.templ")
    report = api.check(session, properties=['<<0>> Pmax=? [F "goal"]'], zero_based_players=True,
                       synthesis=dataclasses.replace(SMALL, timeout=15.0, restarts=3,
                                                     iterations=60, adversaries=10,
                                                     started=started))
    elapsed = time.perf_counter() - started
    assert report.results[0].guaranteed is not None
    assert elapsed < 15.0 + 5.0
