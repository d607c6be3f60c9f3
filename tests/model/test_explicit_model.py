"""The compiled model record: make_model's normalisation, validate's invariants, statistics."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import scipy.sparse as sp

from posgmc.errors import PosgmcError
from posgmc.model.explicit import (
    ExplicitModel,
    ModelInvariantError,
    Observation,
    RewardModel,
    make_model,
)
from posgmc.syntax.ast import ModelType

# A two-state MDP used throughout: state 0 has choices a (-> 0 or 1, 1/2 each) and b (-> 1);
# state 1 has one unlabelled self-loop.
ROW_GROUPS = [0, 2, 3]
MATRIX = [[0.5, 0.5], [0, 1], [0, 1]]


def mdp(**kwargs: Any) -> ExplicitModel:
    options: dict[str, Any] = {"choice_actions": [1, 2, 0], "action_names": ("", "a", "b")}
    options.update(kwargs)
    return make_model(ModelType.MDP, ROW_GROUPS, MATRIX, **options)


def test_defaults() -> None:
    model = make_model(ModelType.MDP, ROW_GROUPS, MATRIX)
    assert (model.num_states, model.num_choices, model.num_transitions) == (2, 3, 4)
    assert model.initial_states.tolist() == [0]
    assert model.choice_actions.tolist() == [0, 0, 0] and model.choice_actions.dtype == np.int32
    assert model.action_names == ("",)
    assert model.state_players.tolist() == [0, 0] and model.state_players.dtype == np.int32
    assert model.player_names == () and model.observations == () and model.reward_models == ()
    assert model.state_values.shape == (2, 0) and model.state_values.dtype == np.int64
    assert model.deadlocks.tolist() == []
    # "init" and "deadlock" are always there.
    assert model.label("init").tolist() == [True, False]
    assert model.label("deadlock").tolist() == [False, False]
    assert model.choice_states.tolist() == [0, 0, 1]


def test_labels_from_initial_states_and_deadlocks() -> None:
    model = mdp(initial_states=[1, 0, 1], deadlocks=[1], labels={"goal": [0, 1]})
    assert model.initial_states.tolist() == [0, 1]  # sorted and distinct
    assert model.label("init").tolist() == [True, True]
    assert model.label("deadlock").tolist() == [False, True]
    assert model.label("goal").dtype == np.bool_
    # Given labels win over the derived ones.
    given = mdp(labels={"init": [False, True]})
    assert given.label("init").tolist() == [False, True]
    assert given.initial_states.tolist() == [0]


def test_transitions_are_normalised() -> None:
    # Unsorted COO input with a repeated entry and an explicit zero.
    coo = sp.coo_matrix(
        ([0.25, 0.5, 0.25, 0.0, 1.0, 1.0], ([0, 0, 0, 1, 1, 2], [1, 0, 1, 0, 1, 1])), shape=(3, 2)
    )
    model = make_model(ModelType.MDP, ROW_GROUPS, coo)
    T = model.transitions
    assert isinstance(T, sp.csr_matrix)
    assert T.has_sorted_indices
    assert T.nnz == 4
    assert T.toarray().tolist() == MATRIX


def test_label_and_reward_lookup() -> None:
    r1 = RewardModel("steps", state=np.array([1.0, 0]))
    r2 = RewardModel(None, choice=np.array([0, 2.0, 0]))
    model = mdp(reward_models=(r1, r2))
    assert model.reward_model(None) is r1
    assert model.reward_model("steps") is r1
    assert model.reward_model(2) is r2
    with pytest.raises(PosgmcError, match='no reward structure "cost"'):
        model.reward_model("cost")
    with pytest.raises(PosgmcError, match="no reward structure number 3"):
        model.reward_model(3)
    with pytest.raises(PosgmcError, match='no label "goal"'):
        model.label("goal")
    with pytest.raises(PosgmcError, match="no reward structure"):
        mdp().reward_model(None)


def test_choice_rewards_add_state_and_action_rewards() -> None:
    rm = RewardModel("r", state=np.array([1.0, 10.0]), choice=np.array([0.5, 0, 2]))
    # choice c earns state reward of its state + its action reward: [1 + .5, 1 + 0, 10 + 2]
    assert rm.choice_rewards(np.array(ROW_GROUPS)).tolist() == [1.5, 1.0, 12.0]
    assert RewardModel("zero").choice_rewards(np.array(ROW_GROUPS)).tolist() == [0, 0, 0]


def test_observation_of() -> None:
    obs = Observation(1, np.array([0, 0], dtype=np.int32), ("o",), np.array([[3]]))
    game = make_model(
        ModelType.POSG,
        ROW_GROUPS,
        MATRIX,
        state_players=[0, 1],
        player_names=("p1", "p2"),
        observations=(obs,),
    )
    assert game.observation_of(1) is obs
    assert game.observation_of(0) is None
    assert obs.num_observations == 1


def test_statistics() -> None:
    obs = Observation(0, np.array([0, 1], dtype=np.int32), (), np.zeros((2, 0), dtype=np.int64))
    game = make_model(
        ModelType.POSG,
        ROW_GROUPS,
        MATRIX,
        state_players=[0, 1],
        player_names=("p1", "p2"),
        observations=(obs,),
        labels={"goal": [False, True]},
        reward_models=(RewardModel("r"),),
        deadlocks=[1],
    )
    assert game.statistics() == {
        "type": "posg",
        "states": 2,
        "choices": 3,
        "transitions": 4,
        "initial_states": 1,
        "deadlocks": 1,
        "labels": ["deadlock", "goal", "init"],
        "reward_models": ["r"],
        "players": {"p1": 1, "p2": 1},
        "observations": {"p1": 2},
    }
    pomdp = make_model(ModelType.POMDP, ROW_GROUPS, MATRIX, observations=(obs,))
    assert pomdp.statistics()["observations"] == {"agent": 2}
    assert "players" not in mdp().statistics()


# ---------------------------------------------------------------------------------------------
# validate: one test per invariant it checks
# ---------------------------------------------------------------------------------------------

INVALID = [
    (
        "no-choice",
        dict(row_groups=[0, 2, 2], matrix=[[0.5, 0.5], [0, 1]]),
        "give every state >= 1 choice",
    ),
    (
        "shape",
        dict(matrix=[[0.5, 0.5, 0], [0, 1, 0], [0, 1, 0]]),
        "transitions has shape (3, 3), expected (3, 2)",
    ),
    (
        "sum",
        dict(matrix=[[0.5, 0.5], [0, 0.5], [0, 1]]),
        "choice 1 has probabilities summing to 0.5",
    ),
    (
        "negative",
        dict(matrix=[[1.5, -0.5], [0, 1], [0, 1]]),
        "transition probabilities must be positive",
    ),
    ("negative-init", dict(initial_states=[-1]), "initial states must be non-empty"),
    ("actions-shape", dict(choice_actions=[0, 0]), "choice_actions must have one entry per choice"),
    ("players-shape", dict(state_players=[0, 0, 0]), "state_players must have one entry per state"),
    (
        "players-range",
        dict(model_type=ModelType.SMG, state_players=[0, 2], player_names=("a", "b")),
        "state_players must index player_names",
    ),
    ("dtmc", dict(model_type=ModelType.DTMC), "a dtmc has exactly one choice per state"),
    (
        "observation-shape",
        dict(observations=(Observation(0, np.zeros(3, dtype=np.int32), (), np.zeros((1, 0))),)),
        "an observation needs one id per state",
    ),
    ("label-shape", dict(labels={"goal": [True]}), 'label "goal" must be bool[num_states]'),
    (
        "state-reward-shape",
        dict(reward_models=(RewardModel("r", state=np.zeros(3)),)),
        "reward model 'r': state rewards need shape (2,)",
    ),
    (
        "choice-reward-shape",
        dict(reward_models=(RewardModel("r", choice=np.zeros(2)),)),
        "reward model 'r': choice rewards need shape (3,)",
    ),
]


@pytest.mark.parametrize(
    ("changes", "fragment"), [c[1:] for c in INVALID], ids=[c[0] for c in INVALID]
)
def test_validate_rejects(changes: dict[str, Any], fragment: str) -> None:
    args = dict(changes)
    model_type = args.pop("model_type", ModelType.MDP)
    row_groups = args.pop("row_groups", ROW_GROUPS)
    matrix = args.pop("matrix", MATRIX)
    with pytest.raises(ModelInvariantError) as info:
        make_model(model_type, row_groups, matrix, **args)
    assert fragment in info.value.message


def test_validate_tolerance() -> None:
    near = [[0.5, 0.5 + 1e-12], [0, 1], [0, 1]]
    assert make_model(ModelType.MDP, ROW_GROUPS, near).num_transitions == 4
    with pytest.raises(ModelInvariantError):
        make_model(ModelType.MDP, ROW_GROUPS, [[0.5, 0.5 + 1e-6], [0, 1], [0, 1]])


# Invariants of the module docstring checked at construction (out-of-range indices must be model
# errors, never an IndexError from numpy).
GAPS = [
    ("initial-out-of-range", dict(initial_states=[5])),
    ("deadlock-out-of-range", dict(deadlocks=[7])),
    ("action-id-out-of-range", dict(choice_actions=[3, 0, 0], action_names=("",))),
    ("action-names-0-not-empty", dict(choice_actions=[0, 0, 0], action_names=("a",))),
    (
        "observation-id-out-of-range",
        dict(
            observations=(
                Observation(
                    0, np.array([0, 5], dtype=np.int32), (), np.zeros((1, 0), dtype=np.int64)
                ),
            )
        ),
    ),
    ("state-values-shape", dict(variable_names=("x",), state_values=[[1, 2], [3, 4]])),
]


@pytest.mark.parametrize("changes", [g[1] for g in GAPS], ids=[g[0] for g in GAPS])
def test_validate_gaps(changes: dict[str, Any]) -> None:
    with pytest.raises(ModelInvariantError):
        make_model(ModelType.MDP, ROW_GROUPS, MATRIX, **changes)


# ---------------------------------------------------------------------------------------------
# The invariants make_model establishes by normalising, checked by validate() on a model built
# directly (as an importer or the assembler does), and read-only arrays.
# ---------------------------------------------------------------------------------------------


def _direct(**changes: Any) -> ExplicitModel:
    """A valid 2-state mdp built field by field (no normalisation), with ``changes`` applied."""
    base = mdp()
    fields = {f: getattr(base, f) for f in (
        "model_type", "initial_states", "row_groups", "transitions", "choice_actions",
        "action_names", "state_players", "player_names", "observations", "labels",
        "reward_models", "variable_names", "state_values", "deadlocks", "boolean_variables",
    )}
    fields.update(changes)
    return ExplicitModel(**fields)


def _unsorted_transitions() -> sp.csr_matrix:
    # Row 0 lists column 1 before column 0 (as a careless importer might).
    return sp.csr_matrix(
        (np.array([0.5, 0.5, 1.0, 1.0]), np.array([1, 0, 1, 1], dtype=np.int32),
         np.array([0, 2, 3, 4], dtype=np.int32)), shape=(3, 2),
    )


DIRECT_INVALID = [
    (
        "unsorted-initial",
        dict(initial_states=np.array([1, 0], dtype=np.int64)),
        "initial states must be sorted and distinct",
    ),
    (
        "repeated-initial",
        dict(initial_states=np.array([0, 0], dtype=np.int64)),
        "initial states must be sorted and distinct",
    ),
    (
        "unsorted-columns",
        dict(transitions=_unsorted_transitions()),
        "choice 0 has unsorted or repeated column indices",
    ),
    (
        "row-groups-dtype",
        dict(row_groups=np.array([0, 2, 3], dtype=np.int32)),
        "row_groups has dtype int32, expected int64",
    ),
    (
        "actions-dtype",
        dict(choice_actions=np.zeros(3, dtype=np.int64)),
        "choice_actions has dtype int64, expected int32",
    ),
    (
        "no-init-label",
        dict(labels={"deadlock": np.zeros(2, dtype=bool)}),
        'the label "init" is missing',
    ),
    (
        "no-deadlock-label",
        dict(labels={"init": np.array([True, False])}),
        'the label "deadlock" is missing',
    ),
    (
        "observation-width",
        dict(
            model_type=ModelType.POMDP,
            observations=(
                Observation(
                    0, np.zeros(2, dtype=np.int32), ("x",), np.zeros((1, 2), dtype=np.int64)
                ),
            ),
        ),
        "expected one column per observable (1)",
    ),
    (
        "observation-player",
        dict(
            model_type=ModelType.POMDP,
            observations=(
                Observation(3, np.zeros(2, dtype=np.int32), (), np.zeros((1, 0), dtype=np.int64)),
            ),
        ),
        "an observation names player 3",
    ),
]


@pytest.mark.parametrize(
    ("changes", "fragment"), [c[1:] for c in DIRECT_INVALID], ids=[c[0] for c in DIRECT_INVALID]
)
def test_validate_checks_every_documented_invariant(changes: dict[str, Any], fragment: str) -> None:
    assert _direct().validate().num_states == 2  # the unchanged record is valid
    with pytest.raises(ModelInvariantError) as info:
        _direct(**changes).validate()
    assert fragment in info.value.message


def test_exact_probabilities_checked_per_row() -> None:
    from fractions import Fraction

    good = np.array([Fraction(1, 2), Fraction(1, 2), Fraction(1), Fraction(1)], dtype=object)
    assert _direct(exact_probabilities=good).validate().num_choices == 3
    bad = np.array([Fraction(1, 2), Fraction(1, 3), Fraction(1), Fraction(1)], dtype=object)
    with pytest.raises(ModelInvariantError, match="choice 0 has exact probabilities"):
        _direct(exact_probabilities=bad).validate()


def test_arrays_are_read_only() -> None:
    model = mdp(reward_models=(RewardModel("r", state=np.zeros(2)),))
    for array in (model.row_groups, model.transitions.data, model.transitions.indices,
                  model.choice_actions, model.initial_states, model.label("init"),
                  model.reward_models[0].state):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = array[0]


def test_the_model_package_needs_no_front_end() -> None:
    """posgmc.model needs nothing but numpy, scipy and its own enums (docs/architecture.md)."""
    import subprocess
    import sys

    code = ("import sys, posgmc.model.explicit; "
            "print(sorted(m for m in sys.modules if m.startswith(('posgmc.syntax', "
            "'posgmc.semantics', 'posgmc.compiler', 'posgmc.engines'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    from posgmc.model.types import ModelType as Compiled
    from posgmc.syntax.ast import ModelType as Written

    assert Compiled is Written  # one enum, named by both


def test_a_model_pickles_with_its_labels() -> None:
    """A built model pickles (its labels are a read-only mapping view, which does not): how it
    reaches a Ray worker (posgmc/synthesis/ray_pool.py). Every field survives, arrays stay
    read-only."""
    import pickle

    model = mdp(labels={"goal": np.array([False, True])})
    again = pickle.loads(pickle.dumps(model))
    assert (again.num_states, again.num_choices) == (2, 3)
    assert again.labels.keys() == model.labels.keys() and "goal" in again.labels
    assert np.array_equal(again.label("goal"), [False, True])
    assert (again.transitions != model.transitions).nnz == 0
    assert again.action_names == model.action_names
    assert not again.row_groups.flags.writeable
    with pytest.raises(TypeError):
        again.labels["other"] = np.array([True, True])  # type: ignore[index]
