"""The work budget of synthesis and what may cut it short (posgmc/synthesis/budget.py): every
phase's extent is a count scaled by ``effort``, so runs are reproducible; the wall-clock cap
(``timeout``) counts, for the first synthesised property, from ``SynthesisOptions.started`` (the
run's start, set by the CLI before loading and by ``api.check`` on entry), for later properties
from their own start, and the result names it when it binds; a stop request (Ctrl-C) winds the
phases down and the best defence is still verified."""

from __future__ import annotations

import dataclasses
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from posgmc import api
from posgmc.syntax import parser
from posgmc.synthesis import budget
from posgmc.synthesis.checker import SynthesisChecker
from tests.random_games import random_posg
from tests.synthesis.helpers import POSMG, PROP, SMALL


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
    assert first.synthesis["partial"] is True and first.synthesis["cut"] == "timeout"
    assert second.synthesis["partial"] is False and second.synthesis["cut"] is None
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


@given(st.integers(min_value=0, max_value=10_000), st.floats(min_value=1e-3, max_value=100.0),
       st.floats(min_value=1e-3, max_value=100.0))
def test_effort_scales_every_count_monotonically(base: int, a: float, b: float) -> None:
    """A count of 0 (a phase switched off) stays 0; any other keeps at least one unit, and a
    larger effort never gives fewer units."""
    lo, hi = sorted((a, b))
    small, large = budget.Effort(lo).units(base), budget.Effort(hi).units(base)
    assert (small == 0) == (base == 0) and (large == 0) == (base == 0)
    assert small <= large
    assert budget.Effort(1.0).units(base) == base


def _numbers(result):  # type: ignore[no-untyped-def]
    """Every number a synthesis result reports (bounds of each, the strategy's probabilities)."""
    out = []
    for key in ("guaranteed", "vs_fss_adversary", "upper_bound", "full_observation"):
        b = getattr(result, key)
        out.append(None if b is None else (b.value, b.lower, b.upper, b.sound))
    fss = result.strategies[0]
    return out, fss.action.tolist(), fss.update.tolist()


@pytest.mark.parametrize("seed", [0, 3])
def test_runs_without_a_cap_are_reproducible(seed: int) -> None:
    """No timeout: the same options give the same numbers and the same defence, whatever the
    clock says (here: a clock started long ago, which under a cap would have cut the run)."""
    model = random_posg(seed)
    options = dataclasses.replace(SMALL, timeout=None, memory=(1, 2))
    expr = parser.parse_property(PROP).expr
    a = _checker(model, options).check(expr, text=PROP)
    b = _checker(model, dataclasses.replace(options, started=time.perf_counter() - 1e6)).check(
        expr, text=PROP)
    assert a.synthesis is not None and a.synthesis["cut"] is None
    assert a.synthesis["partial"] is False
    assert _numbers(a) == _numbers(b)


def test_a_larger_effort_never_proves_less_on_the_search() -> None:
    """Effort scales the counts; the result records it. (Its numbers may differ from effort 1's:
    another budget is another search.)"""
    model = random_posg(2)
    expr = parser.parse_property(PROP).expr
    options = dataclasses.replace(SMALL, timeout=None, effort=2.0)
    r = _checker(model, options).check(expr, text=PROP)
    assert r.synthesis is not None and r.synthesis["effort"] == 2.0
    assert r.guaranteed is not None and r.guaranteed.sound


def test_a_stop_request_reports_the_best_verified_defence() -> None:
    """A stop requested (as Ctrl-C does) before the run: every phase sees an expired deadline,
    yet the first candidate is verified soundly and the result says it was interrupted."""
    model = random_posg(4)
    expr = parser.parse_property(PROP).expr
    budget.request_stop("interrupt")
    try:
        r = _checker(model, dataclasses.replace(SMALL, timeout=None)).check(expr, text=PROP)
    finally:
        budget.clear_stop()
    assert r.synthesis is not None and r.synthesis["cut"] == "interrupt"
    assert r.synthesis["partial"] is True
    assert r.guaranteed is not None and r.guaranteed.sound
    assert r.guaranteed.lower <= r.guaranteed.upper
    # the same defence checked again gives the same proven bounds
    again = api.check(model, properties=[PROP],
                      strategies={r.strategies[0].player: r.strategies[0]}).results[0]
    assert again.guaranteed is not None
    assert (again.guaranteed.lower, again.guaranteed.upper) == (r.guaranteed.lower,
                                                                r.guaranteed.upper)


_BURN = "import time\nend = time.monotonic() + 600\nwhile time.monotonic() < end:\n    pass\n"


def _rover_numbers(*extra: str) -> list[object]:
    """Every number of the README's headline synthesis (models/rover.posg), by the CLI."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run(
        [sys.executable, "-m", "posgmc", "check", str(root / "models" / "rover.posg"), "--prop",
         '<<rover>> Pmax=? [ !"crash" U "goal" ]', "--json", "--quiet", *extra],
        capture_output=True, text=True, check=True, cwd=root, timeout=900)
    r = json.loads(out.stdout)["results"][0]
    assert r["cut"] is None and r["partial"] is False
    return [r[k] for k in ("guaranteed", "vs_fss_adversary", "upper_bound", "full_observation",
                           "rounds", "deterministic", "adversaries_enumerated",
                           "adversaries_ranked", "composed_value", "oracle")
            if k in r] + [[x["value_policy_iteration"] for x in r["rounds"]]]


def _without_seconds(numbers: list[object]) -> list[object]:
    """The numbers without the wall times some entries carry."""
    def strip(x: object) -> object:
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "seconds"}
        if isinstance(x, list):
            return [strip(v) for v in x]
        return x
    return [strip(n) for n in numbers]


@pytest.mark.slow
def test_the_same_numbers_on_an_idle_and_a_loaded_machine() -> None:
    """The README's headline command prints the same numbers alone, with two CPU burners beside
    it (on a 2-core machine: half the CPU or less), and with --jobs 2 under that load: its
    extent is counted, not timed, and no cap is set, so nothing cuts it short."""
    import subprocess
    import sys

    idle = _without_seconds(_rover_numbers())
    burners = [subprocess.Popen([sys.executable, "-c", _BURN]) for _ in range(2)]
    try:
        loaded = _without_seconds(_rover_numbers())
        pooled = _without_seconds(_rover_numbers("--jobs", "2"))
    finally:
        for b in burners:
            b.kill()
            b.wait()
    assert loaded == idle
    assert pooled == idle
