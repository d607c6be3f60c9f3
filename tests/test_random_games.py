"""The random test games (:mod:`tests.random_games`): the games that tests pin by seed stay the
same games, and every shape draws valid games.

The fingerprints below were computed with the three generators this module replaced (the
synthesis tests' ``random_posg``, the MILP tests' ``looping_posg`` and the strategy tests'
hypothesis ``games``) and are reproduced exactly by the parametrised one; seed 2827 is the MILP
tests' regression example."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.fss import FiniteStateStrategy
from tests.random_games import (
    LOOPING,
    REACHING,
    STRATEGY_GAMES,
    GameShape,
    drawn_game,
    looping_posg,
    random_game,
    random_posg,
)


def _digest(arrays: list[np.ndarray]) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _fingerprint(model: ExplicitModel) -> str:
    """The game's arrays: choices by state, transitions, actions, owners, player 0's observation
    and the costs."""
    return _digest([model.row_groups, model.transitions.toarray(), model.choice_actions,
                    model.state_players, *(o.state_ids for o in model.observations),
                    *(np.asarray(r.choice) for r in model.reward_models)])


def _strategy_fingerprint(fss: FiniteStateStrategy) -> str:
    return _digest([fss.action, fss.update])


@pytest.mark.parametrize(("seed", "states", "choices", "fingerprint"), [
    (0, 10, 25, "4e58e61c061ed10d"),
    (2, 10, 24, "c405557a38309bfb"),
    (15, 10, 23, "189e6861dc73ea32"),
])
def test_reaching_games_by_seed(seed: int, states: int, choices: int, fingerprint: str) -> None:
    model = random_posg(seed)
    assert (model.num_states, model.num_choices) == (states, choices)
    assert _fingerprint(model) == fingerprint


@pytest.mark.parametrize(("seed", "full_observation", "states", "choices", "fingerprint"), [
    (0, False, 7, 13, "76d9c3b366c49937"),
    (0, True, 7, 13, "0d28cc6340303614"),
    (2827, False, 6, 10, "3150997b43e6440d"),
    (2827, True, 6, 10, "bbdec68cd036c4be"),
])
def test_looping_games_by_seed(seed: int, full_observation: bool, states: int, choices: int,
                               fingerprint: str) -> None:
    model = looping_posg(seed, full_observation=full_observation)
    assert (model.num_states, model.num_choices) == (states, choices)
    assert len(model.observations) == (0 if full_observation else 1)
    assert _fingerprint(model) == fingerprint


@pytest.mark.parametrize(("seed", "states", "choices", "fingerprints"), [
    (0, 7, 8, ("4ad261ea5cb213bd", "61c359cd325d7282", "7bf157fa429ebde5")),
    (3, 5, 6, ("066d62383fe87298", "919faa670ce86535", "0275e142df0f58aa")),
])
def test_games_with_strategies_by_seed(seed: int, states: int, choices: int,
                                       fingerprints: tuple[str, str, str]) -> None:
    model, p0, p1 = drawn_game(seed)
    assert (model.num_states, model.num_choices) == (states, choices)
    assert (_fingerprint(model), _strategy_fingerprint(p0),
            _strategy_fingerprint(p1)) == fingerprints


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), shape=st.sampled_from([REACHING, LOOPING, STRATEGY_GAMES]),
       full_observation=st.booleans())
def test_every_shape_draws_valid_games(seed: int, shape: GameShape,
                                       full_observation: bool) -> None:
    """Rows stochastic, the goal (and the sink) absorbing and the adversary's, state 0 player 0's
    where the shape says so, the state count in the shape's range."""
    model = random_game(np.random.default_rng(seed), shape, full_observation=full_observation)
    S = model.num_states
    added = 2 if shape.with_sink else 0
    assert shape.states[0] + added <= S < shape.states[1] + added
    rows = model.transitions.toarray()
    assert np.allclose(rows.sum(axis=1), 1.0)
    goal = int(np.flatnonzero(model.labels["goal"])[0])
    absorbing = [goal, S - 1] if shape.with_sink else [goal]
    for s in absorbing:
        c = int(model.row_groups[s])
        assert model.row_groups[s + 1] - c == 1 and rows[c, s] == 1.0
        assert model.state_players[s] == 1
    if shape.first_is_player0:
        assert model.state_players[0] == 0
    assert len(model.reward_models) == (1 if shape.costs else 0)
