"""Closing the optimum bracket from the achievable side (posgmc.synthesis.lower_side): under
``--gap`` a belief-based controller replaces a defence whose memory the search was held to, on a
POMDP and on a one-sided game, proven by the ordinary product check and exported like any FSS."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from tests.synthesis.helpers import BLIND

ROOT = Path(__file__).resolve().parents[2]
BEACON = ROOT / "models" / "beacon" / "beacon.posg"
BLIND_COST = 'R{"cost"}min=? [ F s=3 ]'
BEACON_SAFE = '<<rover>> Pmax=? [ F "safe" ]'


def _check(*args: str) -> dict:  # type: ignore[type-arg]
    r = CliRunner().invoke(main, ["check", *args, "--json"])
    assert r.exit_code == 0, r.output
    # "wrote ..." (stderr) for an exported strategy, and the JSON document
    start = r.output.index("{")
    doc: dict = json.JSONDecoder().raw_decode(r.output[start:])[0]  # type: ignore[type-arg]
    return doc


def test_without_gap_the_memory_asked_for_bounds_the_defence() -> None:
    """BLIND (tests/synthesis/helpers.py): a memoryless agent pays 2 at best, the optimum is 3/2
    (its docstring's reasoning), so with ``memory=1`` and no gap the bracket stays open and
    nothing of the lower side runs."""
    r = api.synthesize(api.load(text=BLIND), BLIND_COST, memory=1, effort=0.2)
    assert dict(r.memory) == {"": 1}
    assert r.guaranteed.upper >= 2.0 - 1e-6
    o = r.optimum
    assert o is not None and o.sound
    assert o.lower <= 1.5 <= o.upper
    assert "lower_side" not in r.synthesis["optimum_bound"]
    assert "lower side" not in r.synthesis["phases"]


def test_a_pomdp_gap_is_closed_from_below_and_the_controller_exported(tmp_path: Path) -> None:
    """BLIND with ``memory=1`` and ``--gap 0.01``: the search's memoryless agent (2) is 1/2 above
    the grid's bound 3/2 (the belief unfolding: exact here); the lower side's policy graph
    (backed up at the explored beliefs) proves 3/2, so the bracket closes. Its exported file
    checks again to the printed bounds."""
    model = tmp_path / "blind.pomdp"
    model.write_text(BLIND)
    out = tmp_path / "out"
    doc = _check(str(model), "--prop", BLIND_COST, "--memory", "1", "--effort", "0.2",
                 "--gap", "0.01", "--export-strategy", f"{out}/")
    assert (doc["model"]["states"], doc["model"]["choices"]) == (4, 8)
    r = doc["results"][0]
    assert r["memory"][""] > 1
    assert r["guaranteed"]["lower"] <= 1.5 <= r["guaranteed"]["upper"] <= 1.5 + 1e-5
    o = r["optimum"]
    assert o["lower"] <= 1.5 <= o["upper"] and o["gap"] <= 0.01
    lower = r["optimum_bound"]["lower_side"]
    assert lower["improved"]
    # both candidates reach 3/2 by policy iteration; the policy graph, ranked first, is kept
    assert [(t["kind"], t["adversary_rule"]) for t in lower["tried"]] == [
        ("policy graph", "none"), ("belief controller", "none")]
    assert all(abs(t["ranked"] - 1.5) <= 1e-9 for t in lower["tried"])
    assert r["defence"] == "belief"
    again = _check(str(model), "--prop", BLIND_COST, "--strategy", str(out / "agent.json"))
    assert again["results"][0]["guaranteed"] == r["guaranteed"]


def test_a_one_sided_game_gap_is_closed_from_below(tmp_path: Path) -> None:
    """beacon (models/beacon/README.md): a memoryless rover guarantees 1/2, a two-node one 0.9,
    the optimum; the grid bound is 0.9 (tests/synthesis/test_bracket.py). With the rover held to
    one node the lower side's policy graph, backed up at the beliefs explored assuming the
    jammer's best response to the memoryless rover, proves 0.9 against every jammer; exported
    and checked again."""
    out = tmp_path / "out"
    doc = _check(str(BEACON), "--prop", BEACON_SAFE, "--memory", "rover=1", "--memory",
                 "jammer=1", "--effort", "0.2", "--gap", "0.01", "--export-strategy", f"{out}/")
    assert (doc["model"]["states"], doc["model"]["choices"]) == (61, 81)
    r = doc["results"][0]
    assert r["full_observation"]["lower"] >= 1.0 - 1e-6
    g = r["guaranteed"]
    assert 0.9 - 1e-6 <= g["lower"] <= 0.9 <= g["upper"]
    assert r["memory"]["rover"] > 1
    o = r["optimum"]
    assert o["lower"] == g["lower"] and o["lower"] <= 0.9 <= o["upper"] and o["gap"] <= 0.01
    tried = r["optimum_bound"]["lower_side"]["tried"]
    # the first candidate is within the gap: no other rule is tried, and no belief controller
    # (it would trust the assumed rule)
    assert [(t["kind"], t["adversary_rule"]) for t in tried] == [
        ("policy graph", "best response to the defence")]
    # the old defence's numbers against the enumerated jammers are not carried over
    assert r.get("vs_fss_adversary") is None
    again = _check(str(BEACON), "--prop", BEACON_SAFE, "--strategy",
                   f"rover={out / 'rover.json'}")
    assert again["results"][0]["guaranteed"] == g


def test_the_lower_side_is_deterministic() -> None:
    """The controllers' budgets are counted in belief nodes: two runs give the same numbers."""
    runs = [api.synthesize(api.load(BEACON), BEACON_SAFE, memory={"rover": 1, "jammer": 1},
                           effort=0.2, gap=0.01) for _ in range(2)]
    first, second = (r.synthesis["optimum_bound"]["lower_side"] for r in runs)
    assert first == second
    assert runs[0].guaranteed == runs[1].guaranteed
