"""Expected rewards on hand-built models; every expected number is derived in a comment."""

from __future__ import annotations

import numpy as np
import pytest

from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.errors import PosgmcError, UnsupportedError
from posgmc.model.explicit import make_model
from posgmc.syntax.ast import Direction, ModelType
from tests.engines.engine_models import game_prism, smg_example

ALL_METHODS = list(Method)
INF = obj.ReachRewardMode.INFINITY
ZERO = obj.ReachRewardMode.ZERO
CUM = obj.ReachRewardMode.CUMULATIVE


def _opts(method: Method) -> SolverOptions:
    return SolverOptions(method=method)


def _close(res, expected, tol=1e-5):  # type: ignore[no-untyped-def]
    expected = np.asarray(expected, dtype=float)
    inf = np.isinf(expected)
    assert np.array_equal(np.isinf(res.values), inf), res.values
    assert np.allclose(res.values[~inf], expected[~inf], atol=tol), res.values
    if res.method is Method.INTERVAL:
        assert np.all(res.lower[~inf] <= expected[~inf] + 1e-9)
        assert np.all(expected[~inf] <= res.upper[~inf] + 1e-9)


# ---------------------------------------------------------------------------------------------
# dtmc
# ---------------------------------------------------------------------------------------------


def _coin_chain():  # type: ignore[no-untyped-def]
    """s0 -> 0.5 goal + 0.5 s0 (reward 1 per step in s0); goal absorbing."""
    return make_model(ModelType.DTMC, [0, 1, 2], np.array([[0.5, 0.5], [0, 1]]))


@pytest.mark.parametrize("method", ALL_METHODS)
def test_expected_steps_of_a_geometric(method: Method) -> None:
    # E[steps until goal] = 1 / 0.5 = 2; the goal's own reward is not collected
    m = _coin_chain()
    goal = np.array([False, True])
    for mode in (INF, CUM):
        res = obj.expected_reach_reward(
            m,
            np.array([1.0, 7.0]),
            goal,
            maximize=np.ones(2, bool),
            mode=mode,
            options=_opts(method),
        )
        _close(res, [2.0, 0.0])


def test_dtmc_reward_modes_differ_when_the_target_may_be_missed() -> None:
    # s0 (reward 1) -> 0.5 goal + 0.5 sink; sink absorbing with reward 3 per step
    m = make_model(ModelType.DTMC, [0, 1, 2, 3], np.array([[0, 0.5, 0.5], [0, 1, 0], [0, 0, 1]]))
    goal = np.array([False, True, False])
    r = np.array([1.0, 0.0, 3.0])
    mx = np.ones(3, bool)
    # F: reached with probability 0.5 < 1 -> infinite (PRISM)
    _close(obj.expected_reach_reward(m, r, goal, maximize=mx, mode=INF), [np.inf, 0, np.inf])
    # Fc: the sink collects 3 forever -> infinite from s0 too
    _close(obj.expected_reach_reward(m, r, goal, maximize=mx, mode=CUM), [np.inf, 0, np.inf])
    # F0: only paths reaching the goal count: 1 * P(reach) = 0.5; the sink never reaches -> 0
    _close(obj.expected_reach_reward(m, r, goal, maximize=mx, mode=ZERO), [0.5, 0, 0])
    # Fc with a reward-free sink: 1 in s0, 0 afterwards
    r0 = np.array([1.0, 0.0, 0.0])
    _close(obj.expected_reach_reward(m, r0, goal, maximize=mx, mode=CUM), [1.0, 0, 0])


def test_zero_mode_on_a_game() -> None:
    # smg_example, reward 1 for each message sent, F0 (h=2 & c=0): p1 maximises. Sending message 2
    # reaches (2,0) with 0.15 after one send (reward 1), else p2 waits in (2,2) forever (nothing
    # collected). Restarting and re-sending from (1,0)... only sending message 2 ever reaches the
    # target, so the value is 0.15 * 1 = 0.15 (one send, the rest of the paths collect 0).
    m = smg_example()
    r = np.zeros(9)
    r[[0, 1]] = 1.0
    t = (m.state_values[:, 0] == 2) & (m.state_values[:, 1] == 0)
    mx = obj.maximize_mask(m, direction=Direction.MAX, coalition=frozenset({0}))
    _close(obj.expected_reach_reward(m, r, t, maximize=mx, mode=ZERO), [0.15, 0.15, 0.0, 0.0, 0.0])


# ---------------------------------------------------------------------------------------------
# mdps with zero-reward end components
# ---------------------------------------------------------------------------------------------


def _zero_loop_mdp():  # type: ignore[no-untyped-def]
    """s0 <-> s1 by zero-reward choices; s0 can leave to the goal for 3, s1 for 2."""
    T = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1], [0, 0, 1]])
    m = make_model(ModelType.MDP, [0, 2, 4, 5], T)
    r = np.array([0.0, 3.0, 0.0, 2.0, 0.0])
    return m, r, np.array([False, False, True])


@pytest.mark.parametrize("method", ALL_METHODS)
def test_rmin_must_leave_a_zero_reward_end_component(method: Method) -> None:
    # R min [F goal]: staying in the zero-reward loop never reaches the goal (infinite under
    # PRISM's F), so the minimiser walks to s1 for free and leaves for 2: V = (2, 2).
    # The least fixpoint of the Bellman operator is (0, 0) -- this is what inflation corrects.
    m, r, goal = _zero_loop_mdp()
    res = obj.expected_reach_reward(
        m, r, goal, maximize=np.zeros(3, bool), mode=INF, options=_opts(method)
    )
    assert res.converged
    _close(res, [2.0, 2.0, 0.0])
    assert res.strategy is not None
    assert res.strategy[1] == 3 and res.strategy[0] == 0  # s1 leaves, s0 walks to s1
    # Fc: paths that never reach collect what they collect (0 here): staying is optimal, V = 0
    _close(
        obj.expected_reach_reward(
            m, r, goal, maximize=np.zeros(3, bool), mode=CUM, options=_opts(method)
        ),
        [0, 0, 0],
    )
    # R max [F goal] = 3 (leave from s0); R max [Fc] = 3 as well
    _close(
        obj.expected_reach_reward(
            m, r, goal, maximize=np.ones(3, bool), mode=INF, options=_opts(method)
        ),
        [np.inf, np.inf, 0],
    )
    _close(
        obj.expected_reach_reward(
            m, r, goal, maximize=np.ones(3, bool), mode=CUM, options=_opts(method)
        ),
        [3, 3, 0],
    )


@pytest.mark.parametrize("method", ALL_METHODS)
def test_game_zero_reward_end_component(method: Method) -> None:
    # s0 (min): a -> s1 (0), b -> goal (5);  s1 (max): a -> s0 (0), b -> goal (2).
    # F: if the minimiser ever plays a, the maximiser loops forever (infinite); so b: V = (5, 5).
    # The least fixpoint x0 = min(5, x1), x1 = max(2, x0) is (2, 2): inflation lifts it.
    # Fc: looping collects 0, so the maximiser leaves for 2 and the minimiser plays a: V = (2, 2).
    T = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1], [0, 0, 1]])
    m = make_model(
        ModelType.SMG, [0, 2, 4, 5], T, state_players=[0, 1, 0], player_names=("mn", "mx")
    )
    r = np.array([0.0, 5.0, 0.0, 2.0, 0.0])
    goal = np.array([False, False, True])
    maximize = np.array([False, True, False])
    res = obj.expected_reach_reward(m, r, goal, maximize=maximize, mode=INF, options=_opts(method))
    assert res.converged
    _close(res, [5.0, 5.0, 0.0])
    assert res.strategy is not None and res.strategy[0] == 1
    _close(
        obj.expected_reach_reward(m, r, goal, maximize=maximize, mode=CUM, options=_opts(method)),
        [2.0, 2.0, 0.0],
    )


def test_total_reward() -> None:
    # s0: a -> s1 (reward 1), b -> s2 (reward 4);  s1: loop with reward 1;  s2: absorbing, 0.
    # R max [C] = inf (loop forever in s1); R min [C] = 4 (s1 would collect forever).
    T = np.array([[0, 1, 0], [0, 0, 1], [0, 1, 0], [0, 0, 1]])
    m = make_model(ModelType.MDP, [0, 2, 3, 4], T)
    r = np.array([1.0, 4.0, 1.0, 0.0])
    _close(obj.total_reward(m, r, maximize=np.ones(3, bool)), [np.inf, np.inf, 0])
    res = obj.total_reward(m, r, maximize=np.zeros(3, bool))
    _close(res, [4.0, np.inf, 0])
    assert res.strategy is not None and res.strategy[0] == 1
    for method in ALL_METHODS:
        _close(
            obj.total_reward(m, r, maximize=np.zeros(3, bool), options=_opts(method)),
            [4.0, np.inf, 0],
        )


def test_total_reward_in_a_game_needs_the_maximiser_to_keep_collecting() -> None:
    # s0 (max): a -> s1 (reward 1), b -> s2 (reward 1);  s1 (min): back to s0 (0) or to s2 (0);
    # s2 absorbing. The minimiser leaves to s2 at once, so the loop is not forced: V(s0) = 1.
    T = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1], [0, 0, 1]])
    m = make_model(ModelType.SMG, [0, 2, 4, 5], T, state_players=[0, 1, 0], player_names=("a", "b"))
    r = np.array([1.0, 1.0, 0.0, 0.0, 0.0])
    _close(obj.total_reward(m, r, maximize=np.array([True, False, True])), [1.0, 0.0, 0.0])
    # if s1 cooperates (both maximise) the loop s0 -> s1 -> s0 collects forever
    _close(obj.total_reward(m, r, maximize=np.ones(3, bool)), [np.inf, np.inf, 0.0])


def test_negative_rewards_are_rejected_for_total_reward() -> None:
    # R[C] with a negative reward stays unsupported (R[F] accepts them when every strategy
    # reaches the target: tests/engines/test_signed_rewards.py)
    m = _coin_chain()
    with pytest.raises(UnsupportedError, match="negative"):
        obj.total_reward(m, np.array([-1.0, 0.0]), maximize=np.ones(2, bool))
    with pytest.raises(PosgmcError, match="one entry per choice"):
        obj.total_reward(m, np.ones(5), maximize=np.ones(2, bool))


# ---------------------------------------------------------------------------------------------
# step-bounded and discounted
# ---------------------------------------------------------------------------------------------


def test_cumulative_and_instantaneous() -> None:
    m = game_prism()
    r = m.reward_models[0].choice_rewards(m.row_groups)  # 1 per step everywhere
    mx = obj.maximize_mask(m, direction=Direction.MAX, coalition=frozenset({0}))
    # C<=k with reward 1 per step is k in every state
    for k in (0, 1, 4):
        assert np.allclose(obj.cumulative_reward(m, r, steps=k, maximize=mx).values, k)
    # I=k: state reward "t" after k steps; from (0,0) p1 stops at once: 0.1 * 1 + 0.9 * 2 = 1.9 for
    # every k >= 1 (t never changes again); advancing first gives p2 the choice to keep t = 0.
    t_reward = np.array([0, 0, 0, 0, 0, 0, 1, 2], dtype=float)
    assert obj.instantaneous_reward(m, t_reward, steps=0, maximize=mx).values[0] == 0.0
    assert obj.instantaneous_reward(m, t_reward, steps=1, maximize=mx).values[0] == pytest.approx(
        1.9
    )
    assert obj.instantaneous_reward(m, t_reward, steps=5, maximize=mx).values[0] == pytest.approx(
        1.9
    )


def test_smg_example_cumulative_minimum() -> None:
    # reward 1 for each message sent (choices send1/send2 of (0,0)); over 3 steps p1 maximising:
    # send at step 1, the message gets lost with 0.15 -> (h,0) -> restart -> send again at step 3:
    # 1 + 0.15 * 1 = 1.15 (if it arrives, p2 keeps the client busy: no more sending)
    m = smg_example()
    r = np.zeros(9)
    r[[0, 1]] = 1.0
    mx = obj.maximize_mask(m, direction=Direction.MAX, coalition=frozenset({0}))
    assert obj.cumulative_reward(m, r, steps=3, maximize=mx).values[0] == pytest.approx(1.15)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_discounted(method: Method) -> None:
    # one state looping with reward 1: sum_t 0.9^t = 10
    m = make_model(ModelType.DTMC, [0, 1], np.array([[1.0]]))
    res = obj.discounted_total_reward(
        m, np.array([1.0]), discount=0.9, maximize=np.ones(1, bool), options=_opts(method)
    )
    assert res.values[0] == pytest.approx(10.0, abs=1e-5)
    if method is Method.INTERVAL:
        assert res.lower[0] <= 10.0 <= res.upper[0]
    # until the goal: s0 (reward 1) -> 0.5 goal + 0.5 s0: x = 1 + 0.9 * 0.5 x  =>  x = 1 / 0.55
    c = _coin_chain()
    res = obj.discounted_reach_reward(
        c,
        np.array([1.0, 5.0]),
        np.array([False, True]),
        discount=0.9,
        maximize=np.ones(2, bool),
        options=_opts(method),
    )
    assert res.values[0] == pytest.approx(1 / 0.55, abs=1e-5) and res.values[1] == 0.0


def test_discount_factor_is_checked() -> None:
    with pytest.raises(PosgmcError, match=r"\[0, 1\)"):
        obj.discounted_total_reward(
            _coin_chain(), np.ones(2), discount=1.0, maximize=np.ones(2, bool)
        )


def test_game_spoiler_strategy_for_infinite_values() -> None:
    # u (max): a -> goal (reward 1), b -> t;  t (min): c1 loop, c2 -> 0.5 goal + 0.5 z;  z loops.
    # R max [F goal]: the minimiser cannot reach the goal almost surely from t (c1 never reaches,
    # c2 fails with 0.5), so t and (via b) u are infinite; the maximiser's strategy must pick b.
    # t is not in the maximiser's attractor of a sure-avoid region (c1 never hits one): the
    # strategy comes from the positive-Büchi analysis.
    T = np.array(
        [[0, 0, 1, 0], [0, 1, 0, 0], [0, 1, 0, 0], [0, 0, 0.5, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]]
    )
    m = make_model(
        ModelType.SMG, [0, 2, 4, 5, 6], T, state_players=[0, 1, 0, 0], player_names=("u", "t")
    )
    r = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    goal = np.array([False, False, True, False])
    maximize = np.array([True, False, True, True])
    res = obj.expected_reach_reward(m, r, goal, maximize=maximize, mode=INF)
    _close(res, [np.inf, np.inf, 0.0, np.inf])
    assert res.strategy is not None and res.strategy[0] == 1
