"""Storm reads the DRN files posgmc writes, and sees the same model.

Runs only where stormpy is importable in the current interpreter (never imported at module level).
The same comparison was run by hand with the stormpy 2.0.0 reference environment (see
``storm_view``; its output, a JSON-able dict, is what :func:`assert_storm_agrees` compares).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from posgmc.io.drn import read_drn, write_drn
from posgmc.model.explicit import ExplicitModel
from tests.io.helpers import tiny_dtmc, tiny_mdp, tiny_pomdp

pytestmark = pytest.mark.storm

# Storm 2.0 has no DRN reader for games (SMG/POSMG), so only these types are checked.
STORM_READABLE_BENCHMARKS = ("pomdp/4x3-95/sketch.templ", "pomdp/query-s2/sketch.templ")


def storm_view(path: str) -> dict[str, Any]:
    """What stormpy builds from a DRN file, as plain data."""
    import stormpy  # noqa: PLC0415 - optional dependency, imported only when present

    options_class = getattr(stormpy, "DirectEncodingParserOptions", None)
    if options_class is None:  # stormpy 2.0 keeps it here
        from stormpy.core._building import DirectEncodingParserOptions as options_class
    options = options_class()
    for flag in ("build_choice_labeling", "build_choice_labels"):  # 2.0 / older names
        if hasattr(options, flag):
            setattr(options, flag, True)
    m = stormpy.build_model_from_drn(path, options=options)
    matrix = m.transition_matrix
    entries = []
    for row in range(matrix.nr_rows):
        for e in matrix.get_row(row):
            value = e.value() if callable(e.value) else e.value
            entries.append([row, e.column, value])
    labels = {
        name: [s for s in range(m.nr_states) if m.labeling.get_state_has_label(name, s)]
        for name in m.labeling.get_labels()
    }
    rewards = {
        name: {
            "state": list(rm.state_rewards) if rm.has_state_rewards else None,
            "action": list(rm.state_action_rewards) if rm.has_state_action_rewards else None,
        }
        for name, rm in m.reward_models.items()
    }
    choice_labels = None
    if m.has_choice_labeling():
        choice_labels = [
            sorted(m.choice_labeling.get_labels_of_choice(c)) for c in range(matrix.nr_rows)
        ]
    observations = (
        [m.get_observation(s) for s in range(m.nr_states)]
        if hasattr(m, "get_observation")
        else None
    )
    return {
        "states": m.nr_states,
        "choices": m.nr_choices,
        "transitions": m.nr_transitions,
        "entries": entries,
        "row_groups": [matrix.get_row_group_start(s) for s in range(m.nr_states)]
        + [matrix.nr_rows],
        "labels": labels,
        "rewards": rewards,
        "choice_labels": choice_labels,
        "observations": observations,
        "initial": sorted(m.initial_states),
    }


def assert_storm_agrees(model: ExplicitModel, view: dict[str, Any]) -> None:
    """Storm's counts, matrix (exact floats), labels, rewards, actions and observations = ours."""
    assert (view["states"], view["choices"], view["transitions"]) == (
        model.num_states,
        model.num_choices,
        model.num_transitions,
    )
    assert view["row_groups"] == model.row_groups.tolist()
    coo = model.transitions.tocoo()
    ours = sorted(zip(coo.row.tolist(), coo.col.tolist(), coo.data.tolist()))
    assert sorted(tuple(e) for e in view["entries"]) == ours
    assert view["initial"] == model.initial_states.tolist()
    nonempty = {n: np.flatnonzero(v).tolist() for n, v in model.labels.items() if v.any()}
    assert view["labels"] == nonempty
    assert len(view["rewards"]) == len(model.reward_models)
    for rm in model.reward_models:
        theirs = view["rewards"][rm.name or ""]
        state = rm.state if rm.state is not None else np.zeros(model.num_states)
        choice = rm.choice if rm.choice is not None else np.zeros(model.num_choices)
        assert (theirs["state"] or [0.0] * model.num_states) == state.tolist()
        assert (theirs["action"] or [0.0] * model.num_choices) == choice.tolist()
    names = [model.action_names[a] for a in model.choice_actions.tolist()]
    assert view["choice_labels"] == [[n] if n else [] for n in names]
    if model.observations:
        assert view["observations"] == model.observations[0].state_ids.tolist()


def _exported(model: ExplicitModel, tmp_path: Path, name: str) -> str:
    path = tmp_path / f"{name}.drn"
    write_drn(model, path, valuations=True)
    return str(path)


@pytest.mark.parametrize("build", [tiny_dtmc, tiny_mdp, tiny_pomdp], ids=lambda f: f.__name__)
def test_storm_reads_our_drn(build: Any, tmp_path: Path) -> None:
    pytest.importorskip("stormpy")
    model = build()
    path = _exported(model, tmp_path, build.__name__)
    assert_storm_agrees(read_drn(path), storm_view(path))
    assert_storm_agrees(model, storm_view(path))


@pytest.mark.parametrize("relative", STORM_READABLE_BENCHMARKS)
def test_storm_reads_our_export_of_benchmarks(
    relative: str, benchmarks: Path, tmp_path: Path
) -> None:
    pytest.importorskip("stormpy")
    model = read_drn(benchmarks / relative)
    path = _exported(model, tmp_path, "export")
    assert_storm_agrees(model, storm_view(path))
    # And Storm reads the original file as we do.
    assert_storm_agrees(model, storm_view(str(benchmarks / relative)))
