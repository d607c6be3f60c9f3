"""Small hand-built models of every type and a structural equality check for round trips."""

from __future__ import annotations

import numpy as np

from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model
from posgmc.syntax.ast import ModelType

# (file under tests/data/benchmarks/, type, states, choices, transitions): the sizes are
# Storm's, from tests/data/benchmarks/RESULTS.md (section 1 "POSMG", column "states / choices /
# transitions (Storm, DRN)"; section 2 "POMDP", columns "states / choices / trans. / obs").
# The POSMG observation counts are not in RESULTS.md; they are the largest "{z}" + 1 of each file.
BENCHMARK_SIZES = [
    ("posmg/dice-and-coin/sketch.templ", ModelType.POSG, 298, 334, 580),
    ("posmg/dice-and-coin2/sketch.templ", ModelType.POSG, 334, 406, 832),
    ("posmg/grid-walls/sketch.templ", ModelType.POSG, 245, 1050, 1495),
    ("posmg/dodge-6-lines/sketch.templ", ModelType.POSG, 639, 2487, 3033),
    ("posmg/dodge-6-lines-position/sketch.templ", ModelType.POSG, 639, 2487, 3033),
    ("posmg/attacker-one-defender/sketch.templ", ModelType.POSG, 172, 552, 894),
    ("posmg/attacker-defender/sketch.templ", ModelType.POSG, 1179, 4587, 7119),
    ("posmg/test-game/sketch.templ", ModelType.POSG, 8, 14, 21),
    ("posmg/test-game2/sketch.templ", ModelType.POSG, 7, 9, 12),
    ("posmg/mec-test/sketch.templ", ModelType.POSG, 4, 6, 7),
    ("posmg/testing-rewards/sketch.templ", ModelType.POSG, 16, 16, 22),
    ("pomdp/4x3-95/sketch.templ", ModelType.POMDP, 22, 82, 354),
    ("pomdp/query-s2/sketch.templ", ModelType.POMDP, 36, 70, 1506),
]


def choice_action_names(model: ExplicitModel) -> list[str]:
    """The action name of every choice (ids may be numbered differently after a round trip)."""
    return [model.action_names[i] for i in model.choice_actions.tolist()]


def _zeros_if_none(values: np.ndarray | None, size: int) -> np.ndarray:
    return np.zeros(size) if values is None else values


def assert_same_model(a: ExplicitModel, b: ExplicitModel, *, valuations: bool = True) -> None:
    """Every array equal (exactly); reward vectors that are None count as zeros."""
    assert a.model_type is b.model_type
    np.testing.assert_array_equal(a.row_groups, b.row_groups)
    np.testing.assert_array_equal(a.transitions.indptr, b.transitions.indptr)
    np.testing.assert_array_equal(a.transitions.indices, b.transitions.indices)
    np.testing.assert_array_equal(a.transitions.data, b.transitions.data)
    np.testing.assert_array_equal(a.initial_states, b.initial_states)
    assert choice_action_names(a) == choice_action_names(b)
    assert a.action_names[0] == b.action_names[0] == ""
    np.testing.assert_array_equal(a.state_players, b.state_players)
    assert a.player_names == b.player_names
    assert [o.player for o in a.observations] == [o.player for o in b.observations]
    for oa, ob in zip(a.observations, b.observations):
        np.testing.assert_array_equal(oa.state_ids, ob.state_ids)
    nonempty_a = {k for k, v in a.labels.items() if v.any()} | {"init", "deadlock"}
    nonempty_b = {k for k, v in b.labels.items() if v.any()} | {"init", "deadlock"}
    assert nonempty_a == nonempty_b
    for name in nonempty_a:
        np.testing.assert_array_equal(a.labels[name], b.labels[name], err_msg=name)
    assert [r.name for r in a.reward_models] == [r.name for r in b.reward_models]
    for ra, rb in zip(a.reward_models, b.reward_models):
        np.testing.assert_array_equal(
            _zeros_if_none(ra.state, a.num_states), _zeros_if_none(rb.state, b.num_states)
        )
        np.testing.assert_array_equal(
            _zeros_if_none(ra.choice, a.num_choices), _zeros_if_none(rb.choice, b.num_choices)
        )
    np.testing.assert_array_equal(a.deadlocks, b.deadlocks)
    if valuations:
        assert a.variable_names == b.variable_names
        np.testing.assert_array_equal(a.state_values, b.state_values)


def tiny_dtmc() -> ExplicitModel:
    """0 -> {1: 1/2, 2: 1/2}; 1 -> 1 (goal); 2 -> 0 (prob 1/4) or 2 (3/4); state reward 1 in 0."""
    return make_model(
        ModelType.DTMC,
        [0, 1, 2, 3],
        [[0, 0.5, 0.5], [0, 1, 0], [0.25, 0, 0.75]],
        labels={"goal": [False, True, False]},
        reward_models=(RewardModel("steps", state=np.array([1.0, 0, 0])),),
        variable_names=("x",),
        state_values=[[0], [1], [2]],
    )


def tiny_mdp() -> ExplicitModel:
    """State 0: a -> 1 (0.3) / 2 (0.7), b -> 0; states 1 and 2 absorbing (2 a fixed deadlock).

    Rewards "r": action a costs 2.5, state 1 earns 1; "t": unnamed-free second structure.
    """
    return make_model(
        ModelType.MDP,
        [0, 2, 3, 4],
        [[0, 0.3, 0.7], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
        choice_actions=[1, 2, 0, 0],
        action_names=("", "a", "b"),
        labels={"goal": [False, True, False], "two words": [True, False, True]},
        reward_models=(
            RewardModel("r", state=np.array([0, 1.0, 0]), choice=np.array([2.5, 0, 0, 0])),
            RewardModel("t", choice=np.array([0, 0.1, 0, 0])),
        ),
        variable_names=("x", "b"),
        state_values=[[0, 0], [1, 1], [-2, 0]],
        deadlocks=[2],
    )


def tiny_pomdp() -> ExplicitModel:
    """Two look-alike states 1, 2 (observation 1) after a coin flip in 0 (observation 0)."""
    return make_model(
        ModelType.POMDP,
        [0, 1, 3, 5, 6],
        [[0, 0.5, 0.5, 0], [0, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 1]],
        choice_actions=[0, 1, 2, 1, 2, 0],
        action_names=("", "l", "r"),
        observations=(
            Observation(
                0, np.array([0, 1, 1, 2], dtype=np.int32), ("o",), np.array([[0], [1], [2]])
            ),
        ),
        labels={"goal": [False, False, False, True]},
    )


def tiny_smg() -> ExplicitModel:
    """Player p1 owns 0 and 2, p2 owns 1; 0 -a-> 1, 0 -b-> 2; 1 -c-> 2 (1/3) / 0 (2/3)."""
    return make_model(
        ModelType.SMG,
        [0, 2, 3, 4],
        [[0, 1, 0], [0, 0, 1], [2 / 3, 0, 1 / 3], [0, 0, 1]],
        choice_actions=[1, 2, 3, 0],
        action_names=("", "a", "b", "c"),
        state_players=[0, 1, 0],
        player_names=("p1", "p2"),
        labels={"goal": [False, False, True]},
    )


def tiny_posg(*, same_observations: bool = True) -> ExplicitModel:
    """tiny_smg with observations: p1 cannot tell 1 from 2 (it owns 2, p2 owns 1: p1's own states
    with one observation offer the same actions, as every input must); p2 (if not same) sees
    everything."""
    smg = tiny_smg()
    ids1 = np.array([0, 1, 1], dtype=np.int32)
    ids2 = ids1 if same_observations else np.array([0, 1, 2], dtype=np.int32)
    return make_model(
        ModelType.POSG,
        smg.row_groups,
        smg.transitions,
        choice_actions=smg.choice_actions,
        action_names=smg.action_names,
        state_players=smg.state_players,
        player_names=smg.player_names,
        observations=(
            Observation(0, ids1, (), np.zeros((2, 0), dtype=np.int64)),
            Observation(1, ids2, (), np.zeros((int(ids2.max()) + 1, 0), dtype=np.int64)),
        ),
        labels={"goal": [False, False, True]},
    )
