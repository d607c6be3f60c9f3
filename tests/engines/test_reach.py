"""Reachability on hand-built models: values, bounds, strategies, methods, end components."""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np
import pytest

from posgmc.engines import objectives as obj
from posgmc.engines.graph import structure_of
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.system import bellman, build_system
from posgmc.errors import PosgmcError
from posgmc.model.explicit import make_model
from posgmc.syntax.ast import Direction, ModelType
from tests.engines.engine_models import game_prism, smg_example

ALL_METHODS = list(Method)
P1, P2 = frozenset({0}), frozenset({1})


def _mask(model, direction: Direction, coalition):  # type: ignore[no-untyped-def]
    return obj.maximize_mask(model, direction=direction, coalition=coalition)


# ---------------------------------------------------------------------------------------------
# smg_example (PRISM-games prism-tests/functionality/verify/smgs/smg_example.prism)
# ---------------------------------------------------------------------------------------------


def test_smg_example_size() -> None:
    m = smg_example()
    assert (m.num_states, m.num_choices, m.num_transitions) == (5, 9, 11)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_smg_example_p1_pmax_eventually_c2(method: Method) -> None:
    # RESULT: 1.0  <<1>> Pmax=? [ F c=2 ]  -- p1 sends message 2 until it gets through.
    m = smg_example()
    c2 = m.state_values[:, 1] == 2
    res = obj.reach_probability(
        m, c2, maximize=_mask(m, Direction.MAX, P1), options=SolverOptions(method=method)
    )
    assert res.values[0] == pytest.approx(1.0, abs=1e-6)
    assert res.lower[0] == 1.0  # qualitative: exact by graph analysis
    # p1's strategy in (0,0) is send2 (choice 1); p2 waits in (1,1) (choice 5) to block
    assert res.strategy is not None and res.strategy[0] == 1


@pytest.mark.parametrize("method", ALL_METHODS)
def test_smg_example_p2_pmin_reach_h2_c0(method: Method) -> None:
    # RESULT: 0.15  <<2>> Pmin=? [ F (h=2 & c=0) ]: p1 (maximising) sends message 2; with
    # probability 0.15 it is lost and (2,0) is reached at once, otherwise p2 waits in (2,2) forever.
    m = smg_example()
    t = (m.state_values[:, 0] == 2) & (m.state_values[:, 1] == 0)
    res = obj.reach_probability(
        m, t, maximize=_mask(m, Direction.MIN, P2), options=SolverOptions(method=method)
    )
    assert res.values[0] == pytest.approx(0.15, abs=1e-6)
    assert res.lower[0] <= 0.15 <= res.upper[0]
    assert res.strategy is not None
    assert res.strategy[4] == 8  # p2 waits in (2,2)


def test_smg_example_complements() -> None:
    m = smg_example()
    t = (m.state_values[:, 0] == 2) & (m.state_values[:, 1] == 0)
    c2 = m.state_values[:, 1] == 2
    # RESULT: 0.85  <<1>> Pmin=? [ G !(h=2&c=0) ] = 1 - <<1>> Pmax [ F (h=2&c=0) ]
    pmax = obj.reach_probability(m, t, maximize=_mask(m, Direction.MAX, P1))
    assert 1 - pmax.values[0] == pytest.approx(0.85, abs=1e-6)
    # RESULT: 0.15 <<1>> Pmax=? [F (h=2&c=0)];  RESULT: 0.0 <<1>> Pmin=? [F (h=2&c=0)]
    assert pmax.values[0] == pytest.approx(0.15, abs=1e-6)
    pmin = obj.reach_probability(m, t, maximize=_mask(m, Direction.MIN, P1))
    assert pmin.values[0] == 0.0
    # RESULT: 1.0  <<1,2>> Pmax=? [ F (h=2&c=0) ] and <<*>>: both players cooperate
    both = obj.reach_probability(m, t, maximize=_mask(m, Direction.MAX, frozenset({0, 1})))
    assert both.values[0] == pytest.approx(1.0, abs=1e-6)
    # RESULT: 0.0  <<1>> Pmin=? [ F c=2 ]: p1 restarts forever
    assert obj.reach_probability(m, c2, maximize=_mask(m, Direction.MIN, P1)).values[0] == 0.0


@pytest.mark.parametrize(
    "k,expected",
    # RESULT (k=0..5) of <<1>> Pmax=? [ F<=k c=2 ]: 0.15^j * 0.85 added every two steps
    [(0, 0.0), (1, 0.85), (2, 0.85), (3, 0.9775), (4, 0.9775), (5, 0.996625)],
)
def test_smg_example_bounded(k: int, expected: float) -> None:
    m = smg_example()
    c2 = m.state_values[:, 1] == 2
    res = obj.bounded_reach_probability(m, c2, steps=k, maximize=_mask(m, Direction.MAX, P1))
    assert res.values[0] == pytest.approx(expected, abs=1e-12)
    assert res.strategy is None


def test_smg_example_bounded_min_and_globally() -> None:
    m = smg_example()
    c2 = m.state_values[:, 1] == 2
    # RESULT: 0.0  <<1>> Pmin=? [ F<=3 c=2 ]
    assert (
        obj.bounded_reach_probability(m, c2, steps=3, maximize=_mask(m, Direction.MIN, P1)).values[
            0
        ]
        == 0.0
    )
    # RESULT: 1.0  <<2>> Pmin=? [ G<=3 c!=2 ] = 1 - <<2>> Pmax [ F<=3 c=2 ] (p1 restarts forever)
    r = obj.bounded_reach_probability(m, c2, steps=3, maximize=_mask(m, Direction.MAX, P2))
    assert 1 - r.values[0] == 1.0


def test_exact_rational_smg_example() -> None:
    m = smg_example()
    t = (m.state_values[:, 0] == 2) & (m.state_values[:, 1] == 0)
    vals = obj.exact_rational_reach(m, t, maximize=_mask(m, Direction.MIN, P2))
    # (0,0) and (1,0) lead back to (0,0): 3/20 = 0.15 (hand derivation above); (2,0) is the target
    assert vals == [Fraction(3, 20), Fraction(3, 20), Fraction(0), Fraction(1), Fraction(0)]


# ---------------------------------------------------------------------------------------------
# game.prism (PRISM-games prism-tests/functionality/verify/smgs/game.prism)
# ---------------------------------------------------------------------------------------------


def test_game_prism() -> None:
    m = game_prism()
    assert (m.num_states, m.num_choices, m.num_transitions) == (8, 13, 18)
    t1 = np.zeros(8, dtype=bool)
    t1[6] = True
    p1max = _mask(m, Direction.MAX, P1)
    # RESULT: 0.2  <<p1>> Pmax=? [ F t=1 ]: backwards 1, 1, 0.4 (p2 stops), 0.4, 0.2 (p2 stops), 0.2
    res = obj.reach_probability(m, t1, maximize=p1max)
    assert res.values[0] == pytest.approx(0.2, abs=1e-6)
    assert np.allclose(res.values[:6], [0.2, 0.2, 0.4, 0.4, 1.0, 1.0], atol=1e-6)
    # RESULT: 0.1  <<p1>> Pmax=? [ X t=1 ]
    assert obj.next_probability(m, t1, maximize=p1max).values[0] == pytest.approx(0.1)
    # RESULTs of F<=k: k=1: 0.1, k=2: 0.1, k=3: 0.2, k=6: 0.2; <<p2,p1>> F<=2: 0.2
    for k, expected in [(1, 0.1), (2, 0.1), (3, 0.2), (6, 0.2)]:
        got = obj.bounded_reach_probability(m, t1, steps=k, maximize=p1max).values[0]
        assert got == pytest.approx(expected, abs=1e-12), k
    both = _mask(m, Direction.MAX, frozenset({0, 1}))
    assert obj.bounded_reach_probability(m, t1, steps=2, maximize=both).values[0] == pytest.approx(
        0.2
    )
    # RESULT: Infinity  <<p1>> Rmax=? [ F t=1 ]: p1 can stop at once and reach t=2 with 0.9
    rew = m.reward_models[0].choice_rewards(m.row_groups)
    r = obj.expected_reach_reward(m, rew, t1, maximize=p1max)
    assert np.isinf(r.values[0]) and np.isinf(r.lower[0])


# ---------------------------------------------------------------------------------------------
# end components
# ---------------------------------------------------------------------------------------------


def _mdp_with_end_component():  # type: ignore[no-untyped-def]
    """s0: a -> s1, b -> 0.5 goal + 0.5 sink; s1: a -> s0, b -> 0.25 goal + 0.75 sink; goal, sink
    absorbing. {s0, s1} is an end component: Pmax = 0.5 in both (leave through s0's b)."""
    T = np.array(
        [
            [0, 1, 0, 0],
            [0, 0, 0.5, 0.5],
            [1, 0, 0, 0],
            [0, 0, 0.25, 0.75],
            [0, 0, 1, 0],
            [0, 0, 0, 1],
        ]
    )
    return make_model(ModelType.MDP, [0, 2, 4, 5, 6], T)


def test_naive_upper_iteration_does_not_converge_in_an_end_component() -> None:
    m = _mdp_with_end_component()
    unknown = np.array([True, True, False, False])
    goal = np.array([0.0, 0.0, 1.0, 0.0])
    sys = build_system(structure_of(m), unknown, maximize=np.ones(4, dtype=bool), fixed=goal)
    # the all-ones vector is a fixpoint of the Bellman operator: iterating from 1 stays at 1
    assert np.allclose(bellman(sys, np.ones(2)), 1.0)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_pmax_with_end_component_converges(method: Method) -> None:
    m = _mdp_with_end_component()
    goal = np.array([False, False, True, False])
    res = obj.reach_probability(
        m, goal, maximize=np.ones(4, dtype=bool), options=SolverOptions(method=method)
    )
    assert res.converged
    assert np.allclose(res.values[:2], 0.5, atol=1e-6)
    if method is not Method.VALUE:
        assert np.all(res.lower[:2] <= 0.5) and np.all(res.upper[:2] >= 0.5)
        assert np.all(res.upper[:2] - res.lower[:2] <= 2e-6)
    # the strategy leaves the end component through s0's b, and s1 moves to s0
    assert res.strategy is not None
    assert res.strategy[0] == 1 and res.strategy[1] == 2


@pytest.mark.parametrize("method", ALL_METHODS)
def test_game_end_component_with_both_players(method: Method) -> None:
    # s0 (max): a -> s1, b -> 0.5 goal + 0.5 sink;  s1 (min): a -> s0, b -> 0.6 goal + 0.4 sink.
    # The minimiser stays (back to s0) rather than pay 0.6, and the maximiser leaves with 0.5:
    # V(s0) = max(V(s1), 0.5), V(s1) = min(V(s0), 0.6); least fixpoint: 0.5 and 0.5.
    T = np.array(
        [[0, 1, 0, 0], [0, 0, 0.5, 0.5], [1, 0, 0, 0], [0, 0, 0.6, 0.4], [0, 0, 1, 0], [0, 0, 0, 1]]
    )
    m = make_model(
        ModelType.SMG, [0, 2, 4, 5, 6], T, state_players=[0, 1, 0, 0], player_names=("a", "b")
    )
    goal = np.array([False, False, True, False])
    maximize = _mask(m, Direction.MAX, frozenset({0}))
    res = obj.reach_probability(m, goal, maximize=maximize, options=SolverOptions(method=method))
    assert res.converged
    assert np.allclose(res.values[:2], 0.5, atol=1e-6)
    assert res.strategy is not None and res.strategy[0] == 1  # the maximiser leaves
    assert obj.exact_rational_reach(m, goal, maximize=maximize)[:2] == [
        Fraction(1, 2),
        Fraction(1, 2),
    ]


# ---------------------------------------------------------------------------------------------
# chains, until, precision, iteration cap, input errors
# ---------------------------------------------------------------------------------------------


def _random_walk(n: int = 5, p: float = 0.5):  # type: ignore[no-untyped-def]
    """Gambler's ruin on 0..n-1 (both ends absorbing), up with probability p."""
    T = np.zeros((n, n))
    T[0, 0] = T[n - 1, n - 1] = 1.0
    for i in range(1, n - 1):
        T[i, i + 1], T[i, i - 1] = p, 1 - p
    return make_model(ModelType.DTMC, np.arange(n + 1), T, initial_states=[n // 2])


@pytest.mark.parametrize("method", ALL_METHODS)
def test_gamblers_ruin(method: Method) -> None:
    # symmetric walk: P(reach n-1 from i) = i / (n-1)
    m = _random_walk()
    goal = np.zeros(5, dtype=bool)
    goal[4] = True
    res = obj.reach_probability(
        m, goal, maximize=np.ones(5, dtype=bool), options=SolverOptions(method=method)
    )
    assert np.allclose(res.values, [0, 0.25, 0.5, 0.75, 1], atol=1e-6)
    assert obj.exact_rational_reach(m, goal, maximize=np.ones(5, dtype=bool)) == [
        Fraction(i, 4) for i in range(5)
    ]


def test_until_respects_remain() -> None:
    # P[ remain U goal ] on the walk with state 1 forbidden: from 2, 3 the walk must not touch 1.
    # x2 = 0.5 x3, x3 = 0.5 + 0.5 x2  =>  x3 = 2/3, x2 = 1/3
    m = _random_walk()
    goal = np.zeros(5, dtype=bool)
    goal[4] = True
    remain = np.array([True, False, True, True, True])
    res = obj.reach_probability(m, goal, remain=remain, maximize=np.ones(5, dtype=bool))
    assert np.allclose(res.values, [0, 0, 1 / 3, 2 / 3, 1], atol=1e-6)
    assert obj.exact_rational_reach(m, goal, remain=remain, maximize=np.ones(5, dtype=bool))[
        2
    ] == Fraction(1, 3)


def test_relative_precision() -> None:
    # a biased walk with tiny values: relative precision bounds the gap relative to the value
    m = _random_walk(8, p=0.1)
    goal = np.zeros(8, dtype=bool)
    goal[7] = True
    res = obj.reach_probability(
        m,
        goal,
        maximize=np.ones(8, dtype=bool),
        options=SolverOptions(relative=True, precision=1e-4),
    )
    exact = np.array(
        [float(v) for v in obj.exact_rational_reach(m, goal, maximize=np.ones(8, dtype=bool))]
    )
    mid = slice(1, 7)
    assert np.all(res.lower[mid] <= exact[mid]) and np.all(exact[mid] <= res.upper[mid])
    assert np.all(res.upper[mid] - res.lower[mid] <= 2e-4 * exact[mid])


def test_iteration_cap_keeps_bounds_sound() -> None:
    m = _random_walk(30, p=0.45)
    goal = np.zeros(30, dtype=bool)
    goal[29] = True
    res = obj.reach_probability(
        m, goal, maximize=np.ones(30, dtype=bool), options=SolverOptions(max_iterations=5)
    )
    assert not res.converged and res.iterations <= 6
    exact = np.array(
        [float(v) for v in obj.exact_rational_reach(m, goal, maximize=np.ones(30, dtype=bool))]
    )
    assert np.all(res.lower <= exact + 1e-12) and np.all(exact <= res.upper + 1e-12)


@pytest.mark.parametrize("method", [Method.INTERVAL, Method.VALUE])
def test_a_deadline_stops_the_iteration_and_keeps_bounds_sound(method: Method) -> None:
    """SolverOptions.deadline (synthesis's time budget): a deadline already passed stops the
    iteration at its next look at the clock, unconverged, with bounds that still hold. (200
    states: on small systems the policy-iteration certificate proves the value at once.)"""
    m = _random_walk(200, p=0.45)
    goal = np.zeros(200, dtype=bool)
    goal[199] = True
    everywhere = np.ones(200, dtype=bool)
    res = obj.reach_probability(
        m, goal, maximize=everywhere,
        options=SolverOptions(method=method, precision=1e-12, deadline=time.perf_counter() - 1.0),
    )
    full = obj.reach_probability(m, goal, maximize=everywhere,
                                 options=SolverOptions(method=method, precision=1e-12))
    assert not res.converged and res.iterations <= 128  # the clock is read every 64 iterations
    assert full.converged and full.iterations > 1000
    if method is Method.INTERVAL:  # proven bounds: they hold (the converged ones as reference)
        assert np.all(res.lower <= full.upper) and np.all(full.lower <= res.upper)


def test_value_method_is_flagged_unsound() -> None:
    m = _random_walk()
    goal = np.zeros(5, dtype=bool)
    goal[4] = True
    res = obj.reach_probability(
        m, goal, maximize=np.ones(5, dtype=bool), options=SolverOptions(method=Method.VALUE)
    )
    assert not res.sound and np.array_equal(res.lower, res.upper)


def test_wrong_shapes_are_rejected() -> None:
    m = _random_walk()
    with pytest.raises(PosgmcError, match="length 5"):
        obj.reach_probability(m, np.zeros(3, dtype=bool), maximize=np.ones(5, dtype=bool))
    with pytest.raises(PosgmcError, match="one entry per state"):
        obj.reach_probability(m, np.zeros(5, dtype=bool), maximize=np.ones(2, dtype=bool))


def test_maximize_mask() -> None:
    m = smg_example()
    assert list(_mask(m, Direction.MAX, P1)) == [True, True, False, True, False]
    assert list(_mask(m, Direction.MIN, P1)) == [False, False, True, False, True]
    assert _mask(m, Direction.MAX, None).all()  # no coalition: every player (PRISM-games)
    mdp = _mdp_with_end_component()
    assert not _mask(mdp, Direction.MIN, P1).any()


def test_induced_chain_keeps_labels_and_rewards() -> None:
    m = game_prism()
    strategy = np.full(8, -1, dtype=np.int64)
    strategy[0] = 1  # stop at once
    chain = obj.induced_chain(m, strategy)
    assert chain.model_type is ModelType.DTMC and chain.num_choices == 8
    assert np.allclose(chain.transitions[0].toarray(), [[0, 0, 0, 0, 0, 0, 0.1, 0.9]])
    assert np.allclose(chain.reward_models[0].choice, 1.0)
    bad = strategy.copy()
    bad[1] = 0  # a choice of state 0
    with pytest.raises(PosgmcError, match="does not belong to state 1"):
        obj.induced_chain(m, bad)
