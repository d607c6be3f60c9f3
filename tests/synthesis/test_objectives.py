"""Synthesis of co-safe LTL, step-bounded and Cdiscount objectives (issue #9): on the product
with the formula's automaton, whose state the strategies do not observe
(posgmc.synthesis.objectives)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.synthesis.options import SynthesisOptions

ROOT = Path(__file__).resolve().parents[2]
BEACON = ROOT / "models" / "beacon" / "beacon.posg"
ROVER = ROOT / "models" / "rover.posg"


def _run(path: Path, prop: str, tmp_path: Path, *memory: str) -> tuple[dict, dict]:  # type: ignore[type-arg]
    """Synthesise with export, then recheck the exported defence with --strategy."""
    out = tmp_path / "fss"
    args = [
        "check",
        str(path),
        "--prop",
        prop,
        "--timeout",
        "10",
        "--json",
        "--export-strategy",
        str(out),
    ]
    for m in memory:
        args += ["--memory", m]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)["results"][0]  # stdout: the "wrote ..." lines go to stderr
    player = res["memory"] and next(iter(res["memory"]))
    again = CliRunner().invoke(main, ["check", str(path), "--prop", prop, "--strategy",
                                      f"{player}={out / (player + '.json')}", "--json"])
    assert again.exit_code == 0, again.output
    return res, json.loads(again.output)["results"][0]


# F<=12 (7 s) runs with -m slow: a step bound is a co-safe LTL formula whose automaton counts the
# steps (posgmc/synthesis/objectives.py), so the default run keeps the same product, two memory
# nodes and re-checked export in the LTL case here, and step bounds in
# test_step_bound_is_below_the_unbounded_value below (F<=12 on rover.posg, exported, re-checked)
@pytest.mark.parametrize("prop", [pytest.param('<<rover>> Pmax=? [ F<=12 "safe" ]',
                                               marks=pytest.mark.slow),
                                  '<<rover>> Pmax=? [ F ("safe" & X "over") ]'])
def test_step_bound_and_ltl_on_beacon(prop: str, tmp_path: Path) -> None:
    """beacon (models/beacon/README.md): with two nodes the rover guarantees 0.9 of reaching the
    safe exit. Both formulas mean the same here: the jammed rover waits once, reaches its exit
    within 12 steps (L = 3), and the exits are absorbing ("over" holds after "safe"). The full
    observation value is 1. The exported file, a strategy of the game, rechecks to the same
    guaranteed."""
    res, again = _run(BEACON, prop, tmp_path, "rover=2")
    assert res["guaranteed"]["lower"] <= 0.9 + 1e-6 and 0.9 - 1e-6 <= res["guaranteed"]["upper"]
    assert res["full_observation"]["lower"] == pytest.approx(1.0, abs=1e-6)
    assert res["memory"] == {"rover": 2}
    assert again["guaranteed"] == res["guaranteed"]
    assert res["guaranteed"]["lower"] <= res["vs_fss_adversary"]["upper"] + 1e-9
    assert res["vs_fss_adversary"]["lower"] <= res["upper_bound"]["upper"] + 1e-9


def test_step_bound_is_below_the_unbounded_value(tmp_path: Path) -> None:
    """A bounded reachability is at most the unbounded one, for the same strategy: the F<=12
    defence synthesised on rover.posg guarantees no more for F<=12 than for F (checked on the game
    with --strategy), and no more than the full-observation F<=12 value (the goal is 4 moves away,
    every other step the attacker's)."""
    res, _ = _run(ROVER, '<<rover>> Pmax=? [ F<=12 "goal" ]', tmp_path, "1")
    again = CliRunner().invoke(
        main,
        [
            "check",
            str(ROVER),
            "--prop",
            '<<rover>> Pmax=? [ F "goal" ]',
            "--strategy",
            f"rover={tmp_path / 'fss' / 'rover.json'}",
            "--json",
        ],
    )
    unbounded = json.loads(again.output)["results"][0]["guaranteed"]
    assert res["guaranteed"]["lower"] <= unbounded["upper"] + 1e-9
    assert res["guaranteed"]["upper"] <= res["full_observation"]["upper"] + 1e-9
    assert res["guaranteed"]["value"] > 0


def test_discounted_total_reward() -> None:
    """R[Cdiscount=0.9] of the steps reward: the rover collects one per step until the mission
    is over (then nothing), so it is R[Fdiscount=0.9 "over"], whose full-observation optimum
    3.8826229 a memoryless partially observing rover reaches
    (test_synthesis.py::test_discounted_cost_synthesis_reaches_the_full_observation_optimum)."""
    report = api.check(api.load(ROVER), properties=['<<rover>> R{"steps"}min=? [ Cdiscount=0.9 ]'],
                       synthesis=SynthesisOptions(memory=(1,), timeout=10, restarts=1))
    r = report.results[0]
    assert r.guaranteed.lower - 1e-6 <= 3.8826229 <= r.guaranteed.upper + 1e-6
    assert r.full_observation.lower - 1e-6 <= 3.8826229 <= r.full_observation.upper + 1e-6


def test_formula_that_is_not_cosafe_is_refused_with_position() -> None:
    r = CliRunner().invoke(main, ["check", str(ROVER), "--prop", '<<rover>> Pmax=? [ G F "goal" ]',
                                  "--timeout", "5"])
    assert r.exit_code == 2 and "co-safe LTL" in r.output and "1:" in r.output
