"""The model library (models/<folder>/): every folder's RESULT lines pass through ``posgmc test``,
the command users run in CI, and each model builds to its pinned size.

Where the expected numbers come from is written in each folder's README.md and above each
property: closed forms derived there (tennis, red_and_black, convoy, trap_grid, tiger), PRISM's
RESULT and Storm 2.0's belief unfolding (maze, tiger, trap_grid), Storm 2.0 on the smg twins
(cyber_deception, tennis, red_and_black). Synthesis RESULT lines are the numbers the commands
print: the synthesis's extent is a work budget counted in its own units, so a run gives the same
numbers on every machine (docs/synthesis.md).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main

MODELS = Path(__file__).resolve().parents[1] / "models"

# (folder, model, props, extra arguments, passed, skipped); strategy files are relative to the
# folder
CASES = [
    ("maze", "maze.pomdp", "full_observation.props", ["--full-observation"], 2, 0),
    ("maze", "maze.pomdp", "maze.props", ["--memory", "2"], 1, 0),
    ("tiger", "tiger.pomdp", "full_observation.props", ["--full-observation"], 2, 0),
    ("tiger", "tiger.pomdp", "tiger.props", ["--memory", "3"], 1, 0),
    ("trap_grid", "trap_grid.pomdp", "full_observation.props", ["--full-observation"], 3, 0),
    ("trap_grid", "trap_grid.pomdp", "trap_grid.props", ["--memory", "2"], 1, 0),
    ("convoy", "convoy.posg", "full_observation.props", ["--full-observation"], 1, 0),
    ("convoy", "convoy.posg", "convoy.props", ["--memory", "1"], 1, 0),
    (
        "convoy",
        "convoy.posg",
        "strategies.props",
        ["--strategy", "convoy=mixed.fss.json", "--strategy", "attacker=ambushA.fss.json"],
        2,
        0,
    ),
    (
        "convoy",
        "convoy.posg",
        "strategies.props",
        ["--strategy", "convoy=mixed.fss.json", "--strategy", "attacker=ambushB.fss.json"],
        2,
        0,
    ),
    (
        "convoy",
        "convoy.posg",
        "attacker_mix.props",
        ["--strategy", "attacker=ambush_mixed.fss.json"],
        1,
        0,
    ),
    (
        "cyber_deception",
        "cyber_deception.posg",
        "full_observation.props",
        ["--full-observation"],
        3,
        0,
    ),
    (
        "cyber_deception",
        "cyber_deception.posg",
        "cyber_deception.props",
        ["--memory", "1", "--effort", "0.2"],
        2,
        0,
    ),
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
def test_results_pass(
    folder: str, model: str, props: str, args: list[str], passed: int, skipped: int
) -> None:
    where = MODELS / folder
    r = CliRunner().invoke(
        main, ["test", str(where / model), str(where / props), *_strategy_paths(where, args)]
    )
    summary = f"{passed} passed, 0 failed" + (f", {skipped} skipped" if skipped else "")
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == summary, r.output


# -- Storm 2.0 agrees (skipped without the reference environment) ---------------------------------

_STORM = r"""
import json, re, sys, tempfile
import stormpy, stormpy.pomdp

out = []
for path, constants, prop, kind in json.loads(sys.argv[1]):
    text = open(path).read()
    if kind == "posg":  # the smg twin: the same game with its observations removed
        text = re.sub(r"^posg$", "smg", text, flags=re.M)
        text = re.sub(r"^\s*observables? .*$", "", text, flags=re.M)
    with tempfile.NamedTemporaryFile("w", suffix=".prism", delete=False) as f:
        f.write(text)
    program = stormpy.parse_prism_program(f.name)
    if constants:
        program = stormpy.io.instantiate_constants(program, constants)[0]
    properties = stormpy.parse_properties(prop, program) if prop else []
    model = stormpy.build_model(program, properties)
    value = None
    if kind == "pomdp":
        result = stormpy.pomdp.verify_with_belief_unfolding(
            model, properties[0], max_exploration_time=60
        )
        value = [result.value, bool(result.completed_exploration)]
    out.append([model.nr_states, model.nr_choices, model.nr_transitions, value])
print(json.dumps(out))
"""

# (the model's key in SIZES, constants for Storm, property for Storm's belief unfolding, optimum)
STORM_CASES = [
    (("maze", "maze.pomdp", ()), "", 'R{"steps"}min=? [ F s=10 ]', 4.3),  # PRISM's RESULT
    (("tiger", "tiger.pomdp", ()), "", 'R{"cost"}min=? [ F "opened" ]', 2391 / 494),  # README.md
    (
        ("trap_grid", "trap_grid.pomdp", ()),
        "",
        'Pmax=? [ F "goal" ]',
        (0.9**4 + 0.9**6) / 2,
    ),  # README.md
    (("convoy", "convoy.posg", ()), "", "", None),
    (("cyber_deception", "cyber_deception.posg", ()), "", "", None),
    (("tennis", "tennis.smg", (("receiver_first", True),)), "receiver_first=true", "", None),
    (("red_and_black", "red_and_black.smg", (("start", 3),)), "start=3", "", None),
]


def test_storm_builds_the_same_models_and_finds_the_pomdp_optima(storm_python: Path) -> None:
    """Storm 2.0 (the reference environment, benchmarks/README.md) builds each model (a posg as its
    smg twin) to our sizes, and its belief unfolding completes at the POMDP optima the READMEs
    derive, which bound the synthesis RESULT ranges. Skipped without the reference environment."""
    import json
    import subprocess

    assert {key for key, *_ in STORM_CASES} == set(SIZES)
    cases = [[str(MODELS / f / m), c, p, m.rsplit(".", 1)[1]] for (f, m, _), c, p, _ in STORM_CASES]
    out = subprocess.run([str(storm_python), "-c", _STORM, json.dumps(cases)], capture_output=True,
                         text=True, check=True, timeout=300)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    for (key, _, _, optimum), (s, c, t, value) in zip(STORM_CASES, got, strict=True):
        assert (s, c, t) == SIZES[key], key
        if optimum is not None:
            assert value[1], f"{key}: Storm's exploration did not complete"
            assert value[0] == pytest.approx(optimum, rel=1e-6), key


@pytest.mark.parametrize(("folder", "model"), sorted({(c[0], c[1]) for c in CASES}))
def test_lint_clean(folder: str, model: str) -> None:
    """The model with every properties file of its folder (what `posgmc lint` and the pre-commit
    hook check)."""
    props = sorted((MODELS / folder).glob("*.props"))
    assert api.lint(MODELS / folder / model, props) == []
