"""``R[F0 target]`` (paths that never reach the target collect nothing) on mdps and games.

Reference values: PRISM-games' ``// RESULT:`` lines (game.prism: 0.4; coins.prism: checked through
the whole pipeline elsewhere), and on random *acyclic* models an independent brute force: without
cycles the history-dependent recursion ``W(s, a) = opt_c sum_t P(c, t) W(t, a + r(c))``
(``W(target, a) = a``, ``W(sink, a) = 0``) over the collected reward ``a`` terminates.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import Direction, ModelType
from tests.engines.engine_models import game_prism

ZERO = obj.ReachRewardMode.ZERO


def test_game_prism_f0() -> None:
    # RESULT: 0.4  <<p1>> Rmax=? [ F0 t=1 ] (game.prism.rewards.props); reward 1 per step
    m = game_prism()
    t1 = np.zeros(8, dtype=bool)
    t1[6] = True
    rew = m.reward_models[0].choice_rewards(m.row_groups)
    mx = obj.maximize_mask(m, direction=Direction.MAX, coalition=frozenset({0}))
    res = obj.expected_reach_reward(m, rew, t1, maximize=mx, mode=ZERO)
    assert res.values[0] == pytest.approx(0.4, abs=1e-6)
    assert res.lower[0] <= 0.4 + 1e-9 <= res.upper[0] + 2e-9
    assert res.strategy is None  # optimal strategies count the collected reward


def test_f0_needs_integer_rewards() -> None:
    m = game_prism()
    with pytest.raises(UnsupportedError, match="integer rewards"):
        obj.expected_reach_reward(
            m, np.full(13, 0.5), np.eye(8, dtype=bool)[6], maximize=np.ones(8, bool), mode=ZERO
        )


@st.composite
def acyclic_games(draw: st.DrawFn) -> tuple[ExplicitModel, np.ndarray, np.ndarray, np.ndarray]:
    """States 0..S-3 move only to higher states; S-2 is the target, S-1 a sink (both loop)."""
    S = draw(st.integers(3, 7))
    rows, counts = [], []
    for s in range(S - 2):
        k = draw(st.integers(1, 3))
        counts.append(k)
        for _ in range(k):
            succ = draw(st.lists(st.integers(s + 1, S - 1), min_size=1, max_size=2, unique=True))
            row = np.zeros(S)
            if len(succ) == 1:
                row[succ[0]] = 1.0
            else:
                q = draw(st.sampled_from([0.25, 0.5, 0.75]))
                row[succ[0]], row[succ[1]] = q, 1 - q
            rows.append(row)
    for s in (S - 2, S - 1):
        row = np.zeros(S)
        row[s] = 1.0
        rows.append(row)
        counts.append(1)
    game = draw(st.booleans())
    players = [draw(st.integers(0, 1)) for _ in range(S)] if game else None
    m = make_model(
        ModelType.SMG if game else ModelType.MDP,
        np.concatenate([[0], np.cumsum(counts)]),
        np.array(rows),
        state_players=players,
        player_names=("a", "b") if game else (),
    )
    rew = np.array(
        draw(
            st.lists(
                st.sampled_from([0.0, 1.0, 2.0, 3.0]),
                min_size=m.num_choices,
                max_size=m.num_choices,
            )
        )
    )
    target = np.zeros(S, dtype=bool)
    target[S - 2] = True
    if game:
        maximize = m.state_players == 0
    else:
        maximize = np.full(S, draw(st.booleans()))
    return m, rew, target, maximize


def _brute_force(
    m: ExplicitModel, rew: np.ndarray, target: np.ndarray, maximize: np.ndarray
) -> np.ndarray:
    S = m.num_states
    T = m.transitions.toarray()

    @cache
    def W(s: int, a: float) -> float:
        if target[s]:
            return a
        if s == S - 1:
            return 0.0
        vals = [
            sum(T[c, t] * W(t, a + rew[c]) for t in np.flatnonzero(T[c]))
            for c in range(int(m.row_groups[s]), int(m.row_groups[s + 1]))
        ]
        return max(vals) if maximize[s] else min(vals)

    return np.array([W(s, 0.0) for s in range(S)])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(acyclic_games())
def test_f0_matches_brute_force_on_acyclic_models(problem: tuple) -> None:
    m, rew, target, maximize = problem
    ref = _brute_force(m, rew, target, maximize)
    res = obj.expected_reach_reward(m, rew, target, maximize=maximize, mode=ZERO)
    assert res.converged
    assert np.allclose(res.values, ref, atol=1e-6), (res.values, ref)
    assert np.all(res.lower <= ref + 1e-7) and np.all(ref <= res.upper + 1e-7)
