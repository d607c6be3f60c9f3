"""The model library (models/<folder>/): every folder's RESULT lines pass through ``posgmc test``,
the command users run in CI, and each model builds to its pinned size.

Where the expected numbers come from is written in each folder's README.md and above each
property: closed forms derived there (tennis, red_and_black, convoy, trap_grid, tiger), PRISM's
RESULT and Storm 2.0's belief unfolding (maze, tiger, trap_grid), Storm 2.0 on the smg twins
(cyber_deception, tennis, red_and_black). Synthesis RESULT lines are ranges between a bound no
sound run can cross (an optimum, or the full-observation value) and what a run reliably proves
within the short budget used here, so they are neither unfailing nor flaky.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main

MODELS = Path(__file__).resolve().parents[1] / "models"

# (folder, model, props, extra arguments, passed, skipped); strategy files are relative to the folder
CASES = [
    ("maze", "maze.pomdp", "full_observation.props", ["--full-observation"], 2, 0),
    ("maze", "maze.pomdp", "maze.props", ["--memory", "2", "--timeout", "4"], 1, 0),
    ("tiger", "tiger.pomdp", "full_observation.props", ["--full-observation"], 2, 0),
    ("tiger", "tiger.pomdp", "tiger.props", ["--memory", "3", "--timeout", "4"], 1, 0),
    ("trap_grid", "trap_grid.pomdp", "full_observation.props", ["--full-observation"], 3, 0),
    ("trap_grid", "trap_grid.pomdp", "trap_grid.props", ["--memory", "2", "--timeout", "3"], 1, 0),
    ("convoy", "convoy.posg", "full_observation.props", ["--full-observation"], 1, 0),
    ("convoy", "convoy.posg", "convoy.props", ["--memory", "1", "--timeout", "2"], 1, 0),
    ("convoy", "convoy.posg", "strategies.props",
     ["--strategy", "convoy=mixed.fss.json", "--strategy", "attacker=ambushA.fss.json"], 2, 0),
    ("convoy", "convoy.posg", "strategies.props",
     ["--strategy", "convoy=mixed.fss.json", "--strategy", "attacker=ambushB.fss.json"], 2, 0),
    ("convoy", "convoy.posg", "attacker_mix.props", ["--strategy", "attacker=ambush_mixed.fss.json"], 1, 0),
    ("cyber_deception", "cyber_deception.posg", "full_observation.props", ["--full-observation"], 3, 0),
    ("cyber_deception", "cyber_deception.posg", "cyber_deception.props", ["--memory", "1", "--timeout", "3"], 2, 0),
    ("tennis", "tennis.smg", "tennis.props", ["--const", "receiver_first=true"], 2, 0),
    ("tennis", "tennis.smg", "tennis.props", ["--const", "receiver_first=false"], 2, 0),
    ("red_and_black", "red_and_black.smg", "red_and_black.props", ["--const", "start=1:7"], 15, 6),
]

# folders whose RESULT lines run elsewhere (tests/test_models.py), with their synthesis budgets
ELSEWHERE = {"secure_autonomy", "beacon"}

SIZES = {  # (states, choices, transitions): posgmc; Storm 2.0 builds the same for the smg files
    ("maze", "maze.pomdp", ()): (12, 21, 30),
    ("tiger", "tiger.pomdp", ()): (19, 31, 38),
    ("trap_grid", "trap_grid.pomdp", ()): (25, 35, 56),
    ("convoy", "convoy.posg", ()): (19, 24, 27),
    ("cyber_deception", "cyber_deception.posg", ()): (65, 140, 198),
    ("tennis", "tennis.smg", (("receiver_first", True),)): (134, 188, 260),
    ("red_and_black", "red_and_black.smg", (("start", 3),)): (32, 55, 78),
}


def _strategy_paths(folder: Path, args: list[str]) -> list[str]:
    out = []
    for i, a in enumerate(args):
        if i > 0 and args[i - 1] == "--strategy":
            player, file = a.split("=", 1)
            a = f"{player}={folder / file}"
        out.append(a)
    return out


def test_every_folder_is_checked() -> None:
    """A new folder with properties must join CASES (or be checked elsewhere)."""
    folders = {p.parent.name for p in MODELS.glob("*/*.props")}
    assert folders == {c[0] for c in CASES} | ELSEWHERE
    for folder in folders - ELSEWHERE:
        props = {p.name for p in (MODELS / folder).glob("*.props")}
        assert props == {c[2] for c in CASES if c[0] == folder}, folder
        assert (MODELS / folder / "README.md").exists(), folder
    index = (MODELS / "README.md").read_text()
    for folder in folders:
        assert f"`{folder}/`" in index, folder


@pytest.mark.parametrize(("folder", "model", "constants"), sorted(SIZES))
def test_sizes(folder: str, model: str, constants: tuple[tuple[str, object], ...]) -> None:
    session = api.load(MODELS / folder / model, constants=dict(constants))
    m = api.build(session).model
    assert (m.num_states, m.num_choices, m.num_transitions) == SIZES[(folder, model, constants)]


@pytest.mark.parametrize(("folder", "model", "props", "args", "passed", "skipped"), CASES,
                         ids=[f"{c[0]}-{c[2]}-{i}" for i, c in enumerate(CASES)])
def test_results_pass(folder: str, model: str, props: str, args: list[str], passed: int, skipped: int) -> None:
    where = MODELS / folder
    r = CliRunner().invoke(main, ["test", str(where / model), str(where / props), *_strategy_paths(where, args)])
    summary = f"{passed} passed, 0 failed" + (f", {skipped} skipped" if skipped else "")
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == summary, r.output
