"""The bundled models (models/): they lint clean, build to pinned sizes, and check to known values.

Expected values for models/rover.smg (and rover.posg read with --full-observation):
* sizes: Storm 2.0 builds 60 states, 100 choices, 125 transitions
  (`benchmarks/storm_check.py --model models/rover.smg --full-model`);
* "reach" = "attack": 0.9876561794 by posgmc's exact solve (policy iteration with exact linear
  solves); Storm's (unsound, game) value iteration gives 0.987655977, 2e-7 below;
* "reach_soon": 0.96138333, Storm (step-bounded: exact in both tools);
* "steps": 6.877901292 exact (posgmc), Storm 6.877901890.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from posgmc import api
from posgmc.checking.dispatch import CheckOptions
from posgmc.engines.options import Method, SolverOptions

MODELS = Path(__file__).resolve().parents[1] / "models"
EXPECTED = {
    "reach": 0.9876561794,
    "attack": 0.9876561794,
    "reach_soon": 0.96138333,
    "safe": True,
    "steps": 6.877901292,
}


@pytest.mark.parametrize("name", ["rover.smg", "rover.posg"])
def test_lint_clean(name: str) -> None:
    assert api.lint(MODELS / name, [MODELS / "rover.props"]) == []


@pytest.mark.parametrize("name", ["rover.smg", "rover.posg"])
@pytest.mark.parametrize("method", [Method.INTERVAL, Method.EXACT])
def test_rover_values(name: str, method: Method) -> None:
    session = api.load(MODELS / name)
    built = api.build(session)
    m = built.model
    assert (m.num_states, m.num_choices, m.num_transitions) == (60, 100, 125)
    report = api.check(
        session,
        property_files=[MODELS / "rover.props"],
        built=built,
        full_observation=name.endswith(".posg"),
        options=CheckOptions(solver=SolverOptions(method=method)),
    )
    assert not report.errors
    got = {r.name: r for r in report.results}
    assert set(got) == set(EXPECTED)
    for key, value in EXPECTED.items():
        r = got[key]
        if isinstance(value, bool):
            assert r.value is value
        else:
            assert r.value == pytest.approx(value, abs=1e-6)
            assert r.lower - 1e-9 <= value + 1e-9 and value - 1e-9 <= r.upper + 1e-9


def test_posg_without_options_is_answered_by_synthesis() -> None:
    """Without strategies and without full_observation a posg property is synthesised for; what
    synthesis cannot answer yet is reported per property (here: bounded and reward objectives)."""
    from posgmc.synthesis.search import SynthesisOptions

    report = api.check(api.load(MODELS / "rover.posg"), property_files=[MODELS / "rover.props"],
                       synthesis=SynthesisOptions(memory=(1,), timeout=5, restarts=0, iterations=10))
    by_name = {r.name: r for r in report.results}
    assert by_name["reach"].guaranteed is not None
    # no partially observing rover beats the full-observation value (exact 0.9876561794)
    assert by_name["reach"].guaranteed.lower <= 0.9876561794 + 1e-9
    assert {text for text, _ in report.errors} == {'"reach_soon": <<rover>> Pmax=? [ F<=20 "goal" ]',
                                                   '"steps": <<rover>> R{"steps"}min=? [ F "over" ]'}
