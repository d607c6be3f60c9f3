"""A memoryless strategy on PAYNT's POSMG files: posgmc's `guaranteed` against Storm on the model
restricted by hand. Skipped without stormpy; run it in the reference environment:
``$POSGMC_REFERENCE_PYTHON -m pytest tests/strategies/test_storm_strategy.py``
(benchmarks/README.md).

The independent path: the DRN text itself is rewritten here, keeping for each of player 0's states
only the choice the strategy picks (first enabled action of its observation, in file order) and
dropping players and observations, which leaves an MDP for player 1, the minimiser of
``<<0>> Pmax``; Storm checks ``Pmin`` on it with its sound environment.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from posgmc import api
from posgmc.strategies.fss import FiniteStateStrategy
from tests.conftest import BENCHMARKS

stormpy = pytest.importorskip("stormpy")
storm_environments = pytest.importorskip("stormpy.environments")

POSMG = BENCHMARKS / "posmg"
CASES = ["dice-and-coin", "dice-and-coin2", "grid-walls", "test-game", "attacker-one-defender"]

_STATE = re.compile(r"^state (\d+) \{(\d+)\} <(\d+)>(.*)$")


def _first_actions(text: str) -> dict[int, str]:
    """Player 0's strategy: per observation, the first action label its first state offers."""
    chosen: dict[int, str] = {}
    owner = obs = None
    for line in text.splitlines():
        m = _STATE.match(line)
        if m:
            obs, owner = int(m.group(2)), int(m.group(3))
            continue
        if line.startswith("\taction ") and owner == 0 and obs not in chosen:
            chosen[obs] = line.split()[1]
    return chosen


def _restricted_mdp(text: str, chosen: dict[int, str]) -> str:
    """The DRN with player 0 fixed to ``chosen``: an MDP (players and observations dropped)."""
    out: list[str] = []
    keep = True
    owner = obs = None
    in_model = False
    for line in text.splitlines():
        if line.startswith("@type:"):
            out.append("@type: MDP")
            continue
        if line.startswith("@nr_choices"):
            out.append(line)
            continue
        if line.strip() == "@model":
            in_model = True
            out.append(line)
            continue
        if not in_model:
            out.append(line)
            continue
        m = _STATE.match(line)
        if m:
            obs, owner = int(m.group(2)), int(m.group(3))
            out.append(f"state {m.group(1)}{m.group(4)}")
            continue
        if line.startswith("\taction "):
            keep = owner != 0 or line.split()[1] == chosen[obs]
            line = line.replace(" []", "")  # empty reward brackets (no reward models)
        if keep:
            out.append(line)
    text = "\n".join(out) + "\n"
    choices = sum(1 for line in out if line.startswith("\taction "))
    return re.sub(r"@nr_choices\n\d+", f"@nr_choices\n{choices}", text)


@pytest.mark.storm
@pytest.mark.parametrize("name", CASES)
def test_memoryless_strategy_agrees_with_storm(name: str, tmp_path: Path) -> None:
    drn = POSMG / name / "sketch.templ"
    text = drn.read_text()
    prop = (POSMG / name / "sketch.props").read_text().strip().splitlines()[-1].rstrip(";")
    chosen = _first_actions(text)

    session = api.load(drn)
    obs_ids = np.array(sorted(chosen))
    as_label = {a: "" if a == "__NOLABEL__" else a for a in chosen.values()}  # DRN's unlabelled
    labels = tuple(sorted(set(as_label.values())))
    gamma = np.zeros((1, obs_ids.size, len(labels)))
    for i, z in enumerate(obs_ids.tolist()):
        gamma[0, i, labels.index(as_label[chosen[z]])] = 1.0
    fss = FiniteStateStrategy.from_arrays(
        player="0",
        observables=(),
        observation_values=obs_ids[:, None],
        actions=labels,
        action=gamma,
    )
    report = api.check(session, properties=[prop], strategies={"0": fss}, zero_based_players=True)
    assert not report.errors, report.errors[0][1].render()
    g = report.results[0].guaranteed

    restricted = tmp_path / "restricted.drn"
    restricted.write_text(_restricted_mdp(text, chosen))
    storm_model = stormpy.build_model_from_drn(str(restricted))
    opposite = "Pmin" if "Pmax" in prop else "Pmax"
    formula = stormpy.parse_properties(opposite + "=? " + prop.split("=?", 1)[1])
    env = storm_environments.sound()
    result = stormpy.model_checking(storm_model, formula[0], environment=env)
    value = float(result.get_value(storm_model.initial_states[0]))
    assert g.lower - 1e-6 <= value <= g.upper + 1e-6, (name, value, g)
