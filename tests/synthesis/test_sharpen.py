"""posgmc.synthesis.sharpen: near-0/1 probabilities made exact, unreachable nodes dropped, and the
sharpened defence reported only when its proven number is not strictly worse."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking.results import Bound
from posgmc.cli import main
from posgmc.strategies.files import read_strategy
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.synthesis.sharpen import keeps_original, sharpen

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.posg")
REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'


def _fss(action: np.ndarray, update: np.ndarray, initial: int = 0) -> FiniteStateStrategy:
    k, z = action.shape[:2]
    return FiniteStateStrategy.from_arrays(
        player="p", initial_memory=initial, observables=("x",),
        observation_values=np.arange(z, dtype=np.int64)[:, None],
        actions=tuple(f"a{i}" for i in range(action.shape[2])), action=action, update=update)


def test_near_deterministic_rules_become_deterministic_and_node_2_is_dropped() -> None:
    # 3 nodes, 1 observation, 2 actions; node 0 plays a0 (0.9995) and moves to node 1 (0.9999)
    # or 0; node 1 stays; node 2 is never entered: sharpened, 0 -> 1 -> 1, node 2 dropped
    action = np.array([[[0.9995, 0.0005]], [[0.0002, 0.9998]], [[0.5, 0.5]]])
    update = np.zeros((3, 1, 2, 3))
    update[0, 0, 0] = [0.0001, 0.9999, 0.0]
    update[0, 0, 1] = [1.0, 0.0, 0.0]
    update[1, 0, :, 1] = 1.0
    update[2, 0, :, 2] = 1.0
    s = sharpen(_fss(action, update))
    assert s.changed and s.nodes_dropped == 1
    # moved: action 0.9995, 0.0005, 0.0002, 0.9998; update 0.0001, 0.9999
    assert s.probabilities == 6
    out = s.strategy
    assert out.memory_size == 2 and out.is_deterministic
    assert out.action[0, 0].tolist() == [1.0, 0.0] and out.action[1, 0].tolist() == [0.0, 1.0]
    assert out.update[0, 0, 0].tolist() == [0.0, 1.0]
    assert s.text() == "6 probabilities sharpened to 0 or 1, 1 unreachable memory node dropped"


def test_a_mixed_rule_stays_mixed_and_nothing_changes() -> None:
    action = np.array([[[0.5, 0.5]]])
    update = np.ones((1, 1, 2, 1))
    s = sharpen(_fss(action, update))
    assert not s.changed and s.text() == "" and s.strategy.action[0, 0].tolist() == [0.5, 0.5]


@given(st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=2, max_size=5))
def test_sharpened_rows_are_distributions_close_to_the_original(weights: list[float]) -> None:
    w = np.array(weights) + 1e-12
    row = w / w.sum()
    s = sharpen(_fss(row[None, None, :], np.ones((1, 1, row.size, 1))))
    new = s.strategy.action[0, 0]
    assert abs(new.sum() - 1.0) <= 1e-9
    assert np.all((new == 0) | (new >= 1e-3) | (row == new))
    # each probability moves by at most the mass removed from its row (< A * 1e-3)
    assert np.all(np.abs(new - row) <= row.size * 1e-3 + 1e-12)


def test_the_original_is_kept_only_when_it_proves_strictly_more() -> None:
    original = Bound(0.9000005, 0.8999999999, 0.9000010001)
    overlapping = Bound(0.9, 0.8999995, 0.9000005)
    worse = Bound(0.8, 0.7999995, 0.8000005)
    assert not keeps_original(original, overlapping, maximize=True)
    assert keeps_original(original, worse, maximize=True)
    # a minimiser: lower is better
    assert keeps_original(worse, original, maximize=False)
    assert not keeps_original(original, overlapping, maximize=False)
    unproven = Bound(0.95, 0.0, 1.0, sound=False)
    assert keeps_original(original, unproven, maximize=True)


def test_a_synthesised_defence_is_sharpened_or_says_why_not(tmp_path: Path) -> None:
    """Whatever the search finds for models/rover.posg's memoryless rover: either nothing was
    left to sharpen, or the sharpened defence is reported, or the original proves strictly more
    (its gradient defence holds with probability ~0.9997 and moves with ~0.0003: sharpened it
    never moves). The exported file is the reported defence: re-checking it gives the printed
    guaranteed."""
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["check", ROVER, "--prop", REACH, "--memory", "1", "--timeout",
                                  "3", "--adversaries", "0", "--export-strategy", str(out),
                                  "--json"])
    assert r.exit_code in (0, 1), r.output
    result = json.loads(r.stdout)["results"][0]
    defence = read_strategy(out / "rover.json")
    record = result.get("sharpening")
    if record is None:
        assert not sharpen(defence).changed
    elif record["reported"] == "sharpened":
        assert result["guaranteed"] == record["guaranteed_sharpened"]
        assert not sharpen(defence).changed
    else:
        assert record["guaranteed_sharpened"]["upper"] < record["guaranteed_original"]["lower"]
        assert result["sharpened"] == "not sharpened: the sharpened strategy proves less"
    again = CliRunner().invoke(main, ["check", ROVER, "--prop", REACH, "--strategy",
                                      f"rover={out / 'rover.json'}", "--json"])
    g, g_again = result["guaranteed"], json.loads(again.stdout)["results"][0]["guaranteed"]
    assert g_again["lower"] - 1e-6 <= g["value"] <= g_again["upper"] + 1e-6


def test_sharpening_is_taken_when_it_proves_as_much() -> None:
    """models/rover/forward.fss.json (always forward: guaranteed 0.92156856842, by policy
    iteration on the product, tests/strategies/test_verify.py) made to hold with probability
    1e-4 and given a second memory node it never enters: sharpened, it is the file's strategy
    again, which proves at least as much, so the sharpened one is reported."""
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.strategies.verify import StrategyChecker
    from posgmc.syntax import parser
    from posgmc.synthesis.checker import SynthesisChecker

    model = api.build(api.load(ROVER)).model
    resolver = api._resolver(model, False)
    forward = read_strategy(ROOT / "models" / "rover" / "forward.fss.json")
    actions = forward.actions + ("hold",)
    action = np.zeros((2, forward.num_observations, len(actions)))
    action[:, :, : forward.num_actions] = forward.action[0]
    moving = forward.action[0, :, actions.index("fwd")] == 1.0
    action[:, moving, actions.index("fwd")] = 0.9999
    action[:, moving, actions.index("hold")] = 0.0001
    update = np.zeros(action.shape + (2,))
    update[..., 0] = 1.0  # node 1 is never entered
    near = FiniteStateStrategy.from_arrays(
        player="rover", initial_memory=0, observables=forward.observables,
        observation_values=forward.observation_values, actions=actions, action=action,
        update=update)
    query = parser.parse_property(REACH).expr

    def verified(f: FiniteStateStrategy) -> Bound | None:
        return StrategyChecker(model, {f.player: f}, coalition_of=resolver.coalition_of,
                               scalar=float, options=CheckOptions()).check(
            query, text="t").guaranteed

    g = verified(near)
    assert g is not None
    chosen, g_chosen, record = SynthesisChecker._sharpened(near, g, verified, True)
    assert record is not None and record["reported"] == "sharpened"
    assert record["probabilities"] == 2 * int(moving.sum()) and record["nodes_dropped"] == 1
    assert chosen.memory_size == 1 and chosen.is_deterministic
    assert g_chosen.lower <= 0.92156856842 <= g_chosen.upper
    assert g_chosen.lower >= g.lower
