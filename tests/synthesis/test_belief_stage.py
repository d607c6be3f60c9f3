"""The decision maker's dynamics with an assumed adversary stage rule composed in
(posgmc.synthesis.belief_stage): on a POMDP the model's own transitions, on a game the mass
carried through the adversary's states to where the decision maker moves next."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from posgmc.synthesis.belief_stage import deterministic_rule, stage_dynamics, uniform_rule
from tests.random_games import random_pomdp, random_posg


def _goal(model) -> np.ndarray:  # type: ignore[no-untyped-def]
    return np.asarray(model.label("goal"), dtype=bool)


def test_a_pomdp_keeps_its_transitions() -> None:
    model = random_pomdp(3)
    target = _goal(model)
    cont = ~target
    d = stage_dynamics(model, 0, cont=cont, gain=target.astype(np.float64), rewards=None,
                       discount=1.0, sign=1.0, rule=None)
    P = sp.csr_matrix(sum(d.P))
    # every continuing state's rows: the continuing mass plus what stops sums to the choices'
    for a, Pa in enumerate(d.P):
        rows = np.flatnonzero(np.asarray(Pa.sum(axis=1)).ravel() + d.stop[a] > 0)
        assert np.allclose(np.asarray(Pa[rows].sum(axis=1)).ravel() + d.stop[a][rows], 1.0)
    assert P.shape == (model.num_states, model.num_states)
    s0 = int(model.initial_states[0])
    assert d.initial[s0] == 1.0 and d.initial.sum() == 1.0


def test_a_game_carries_mass_through_the_adversary() -> None:
    """In a random one-sided game the composed dynamics move mass only to the decision maker's
    continuing states, never more than there is (mass the rule keeps among the adversary's
    states for ever is dropped), under any rule."""
    for seed in range(6):
        model = random_posg(seed)
        target = _goal(model)
        cont = ~target
        mine = model.state_players == 0
        for rule in (uniform_rule(model, 1),
                     deterministic_rule(model, 1, np.full(model.num_states, -1))):
            # a rule sums to 1 over each adversary state's choices
            per_state = np.bincount(model.choice_states, weights=rule,
                                    minlength=model.num_states)
            assert np.allclose(per_state[~mine], 1.0) and np.all(per_state[mine] == 0)
            d = stage_dynamics(model, 0, cont=cont, gain=target.astype(np.float64),
                               rewards=None, discount=1.0, sign=1.0, rule=rule)
            for a, Pa in enumerate(d.P):
                cols = np.unique(Pa.indices)
                assert np.all(mine[cols] & cont[cols])
                rows = np.flatnonzero(np.asarray(Pa.sum(axis=1)).ravel() + d.stop[a] > 0)
                total = np.asarray(Pa[rows].sum(axis=1)).ravel() + d.stop[a][rows]
                assert np.all(total <= 1.0 + 1e-12)
            assert d.initial.sum() <= 1.0 + 1e-12
            assert np.all(mine[np.flatnonzero(d.initial)])
