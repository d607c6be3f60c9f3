"""Expected reach rewards with rewards of mixed sign (``R[F ...]`` as a stochastic shortest path
problem whose policies are all proper); every expected number is derived in a comment."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.engines import objectives as obj
from posgmc.engines.graph import structure_of
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.signed import proper_region, solve_proper, start_bounds
from posgmc.engines.system import build_system
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import chain_reward, game_value, small_models

ALL_METHODS = list(Method)
CUM = obj.ReachRewardMode.CUMULATIVE
ZERO = obj.ReachRewardMode.ZERO


def _width(values: np.ndarray) -> float:
    """The widest interval expected: twice the default precision 1e-6, plus the outward rounding
    of posgmc.engines.signed (1e-10 of the bound and of the largest bound, on each side)."""
    return 2e-6 + 1e-9 * (1.0 + float(np.max(np.abs(values), initial=0.0)))


def _check(res: EngineResult, expected: list[float], tol: float = 1e-5) -> None:
    exp = np.asarray(expected, dtype=float)
    inf = np.isinf(exp)
    assert np.array_equal(np.isinf(res.values), inf), res.values
    assert np.allclose(res.values[~inf], exp[~inf], atol=tol), res.values
    if res.method is not Method.VALUE:
        assert res.sound
        assert np.all(res.lower[~inf] <= exp[~inf] + 1e-9), res.lower
        assert np.all(exp[~inf] <= res.upper[~inf] + 1e-9), res.upper
    if res.method is Method.INTERVAL:
        assert res.converged
        assert np.all(res.upper[~inf] - res.lower[~inf] <= _width(exp[~inf]))


# ---------------------------------------------------------------------------------------------
# dtmc
# ---------------------------------------------------------------------------------------------


def _seesaw_chain() -> ExplicitModel:
    """s0 (reward +3) -> 0.5 s1 + 0.5 goal; s1 (reward -2) -> 0.5 s0 + 0.5 goal; goal absorbing
    (its reward -5 is never collected: the target is absorbing)."""
    T = np.array([[0, 0.5, 0.5], [0.5, 0, 0.5], [0, 0, 1]])
    return make_model(ModelType.DTMC, [0, 1, 2, 3], T)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_dtmc_with_mixed_signs(method: Method) -> None:
    m = _seesaw_chain()
    assert (m.num_states, m.num_choices, m.num_transitions) == (3, 3, 5)
    # V0 = 3 + V1/2, V1 = -2 + V0/2  =>  V0 = 2 + V0/4  =>  V0 = 8/3, V1 = -2 + 4/3 = -2/3
    res = obj.expected_reach_reward(
        m,
        np.array([3.0, -2.0, -5.0]),
        np.array([False, False, True]),
        maximize=np.ones(3, bool),
        options=SolverOptions(method=method),
    )
    _check(res, [8 / 3, -2 / 3, 0.0])


def test_dtmc_missing_the_target_is_still_infinite() -> None:
    # s0 (reward -1) -> 0.5 goal + 0.5 sink; sink absorbing (reward -1). The target is reached with
    # probability 1/2 < 1: +inf from s0 and the sink (PRISM's rule, whatever the reward signs)
    T = np.array([[0, 0.5, 0.5], [0, 1, 0], [0, 0, 1]])
    m = make_model(ModelType.DTMC, [0, 1, 2, 3], T)
    res = obj.expected_reach_reward(
        m, np.array([-1.0, 0.0, -1.0]), np.array([False, True, False]), maximize=np.ones(3, bool)
    )
    _check(res, [np.inf, 0.0, np.inf])


def test_negative_rewards_on_target_or_infinite_states_keep_the_non_negative_path() -> None:
    # the goal's own (negative) reward is never collected and the sink's value is +inf anyway, so
    # the non-negative algorithm runs: s0 (reward 2) -> 0.5 s0 + 0.5 goal gives V0 = 2 / 0.5 = 4
    T = np.array([[0.5, 0.5, 0], [0, 1, 0], [0, 0, 1]])
    m = make_model(ModelType.DTMC, [0, 1, 2, 3], T)
    res = obj.expected_reach_reward(
        m, np.array([2.0, -7.0, -1.0]), np.array([False, True, False]), maximize=np.ones(3, bool)
    )
    _check(res, [4.0, 0.0, np.inf])


# ---------------------------------------------------------------------------------------------
# mdp and smg
# ---------------------------------------------------------------------------------------------


def _two_state(model_type: ModelType, players: list[int] | None = None) -> ExplicitModel:
    """s0: a (reward -1) -> s1; b (reward +1) -> goal.
    s1: c (reward +4) -> 0.5 goal + 0.5 s0; d (reward -3) -> goal.  goal (s2) absorbing.
    Every profile reaches the goal almost surely (the loop s0 -> s1 -> s0 is left with probability
    1/2 per round). Choices: 0=a, 1=b, 2=c, 3=d, 4=goal loop."""
    T = np.array([[0, 1, 0], [0, 0, 1], [0.5, 0, 0.5], [0, 0, 1], [0, 0, 1]])
    return make_model(
        model_type,
        [0, 2, 4, 5],
        T,
        state_players=players,
        player_names=("p1", "p2") if players is not None else (),
    )


TWO_STATE_REWARDS = np.array([-1.0, 1.0, 4.0, -3.0, -9.0])
TWO_STATE_GOAL = np.array([False, False, True])


@pytest.mark.parametrize("method", ALL_METHODS)
def test_mdp_with_mixed_signs(method: Method) -> None:
    m = _two_state(ModelType.MDP)
    assert (m.num_states, m.num_choices, m.num_transitions) == (3, 5, 6)
    opts = SolverOptions(method=method)
    # max: V1 = max(4 + V0/2, -3), V0 = max(-1 + V1, 1). With (a, c): V0 = 3 + V0/2 = 6, V1 = 7;
    # b gives 1 < 6 and d gives -3 < 7, so (a, c) is optimal: (6, 7)
    mx = obj.expected_reach_reward(
        m, TWO_STATE_REWARDS, TWO_STATE_GOAL, maximize=np.ones(3, bool), options=opts
    )
    _check(mx, [6.0, 7.0, 0.0])
    # min: with (a, d): V1 = -3, V0 = -4; c gives 4 - 2 = 2 > -3 and b gives 1 > -4: (-4, -3)
    mn = obj.expected_reach_reward(
        m, TWO_STATE_REWARDS, TWO_STATE_GOAL, maximize=np.zeros(3, bool), options=opts
    )
    _check(mn, [-4.0, -3.0, 0.0])
    assert mx.strategy is not None and mn.strategy is not None
    assert mx.strategy.tolist() == [0, 2, -1]  # a, c
    assert mn.strategy.tolist() == [0, 3, -1]  # a, d


@pytest.mark.parametrize("method", ALL_METHODS)
def test_smg_with_mixed_signs(method: Method) -> None:
    opts = SolverOptions(method=method)
    # s0 maximises, s1 minimises: V1 = min(4 + V0/2, -3) = -3 for any V0 <= 2, and then
    # V0 = max(-1 - 3, 1) = 1 <= 2 (consistent): (1, -3); strategy b, d
    m = _two_state(ModelType.SMG, players=[0, 1, 0])
    res = obj.expected_reach_reward(
        m, TWO_STATE_REWARDS, TWO_STATE_GOAL, maximize=np.array([True, False, True]), options=opts
    )
    _check(res, [1.0, -3.0, 0.0])
    assert res.strategy is not None and res.strategy.tolist() == [1, 3, -1]
    # s0 minimises, s1 maximises: V1 = max(4 + V0/2, -3), V0 = min(-1 + V1, 1). With b: V0 = 1,
    # V1 = 4.5, and a would give 3.5 > 1: (1, 4.5); strategy b, c
    m = _two_state(ModelType.SMG, players=[1, 0, 0])
    res = obj.expected_reach_reward(
        m, TWO_STATE_REWARDS, TWO_STATE_GOAL, maximize=np.array([False, True, True]), options=opts
    )
    _check(res, [1.0, 4.5, 0.0])
    assert res.strategy is not None and res.strategy.tolist() == [1, 2, -1]


def test_strategy_reproduces_the_value() -> None:
    # the strategy's induced chain has the optimal value (all profiles are proper: no fix needed)
    m = _two_state(ModelType.MDP)
    for maximize, value in ((True, [6.0, 7.0, 0.0]), (False, [-4.0, -3.0, 0.0])):
        res = obj.expected_reach_reward(
            m, TWO_STATE_REWARDS, TWO_STATE_GOAL, maximize=np.full(3, maximize)
        )
        assert res.strategy is not None
        rows = np.where(res.strategy < 0, m.row_groups[:-1], res.strategy)
        achieved = chain_reward(m, rows, TWO_STATE_REWARDS, TWO_STATE_GOAL, "inf")
        assert np.allclose(achieved, value, atol=1e-9)


def test_relative_precision_and_iteration_cap_keep_the_bounds_proven() -> None:
    m = _two_state(ModelType.MDP)
    rel = obj.expected_reach_reward(
        m,
        TWO_STATE_REWARDS,
        TWO_STATE_GOAL,
        maximize=np.ones(3, bool),
        options=SolverOptions(precision=1e-8, relative=True),
    )
    assert rel.converged
    width = 1e-8 * (np.abs(rel.upper) + np.abs(rel.lower))
    assert np.all(rel.upper[:2] - rel.lower[:2] <= width[:2])
    _check(rel, [6.0, 7.0, 0.0])
    # a tiny iteration cap: not converged, but the exact values (6, 7) stay inside the bounds
    capped = obj.expected_reach_reward(
        m,
        TWO_STATE_REWARDS,
        TWO_STATE_GOAL,
        maximize=np.ones(3, bool),
        options=SolverOptions(max_iterations=3),
    )
    assert not capped.converged and capped.sound
    assert capped.lower[0] <= 6.0 <= capped.upper[0] and capped.lower[1] <= 7.0 <= capped.upper[1]


def test_start_bounds_enclose_the_value() -> None:
    # L0 = -max E[total r-], U0 = max E[total r+] on the two-state mdp (derivations: r+ gives
    # max(V0, V1) with V1 = 4 + V0/2, V0 = max(V1, 1) = V1  =>  V0 = V1 = 8; r- gives
    # V1 = max(V0/2, 3), V0 = max(1 + V1, 0) => V0 = 4, V1 = 3)
    m = _two_state(ModelType.MDP)
    g = structure_of(m)
    unknown = ~TWO_STATE_GOAL
    lo, hi, _ = start_bounds(g, unknown, TWO_STATE_REWARDS, allowed=None, options=SolverOptions())
    # proven, and tight up to the auxiliary solves' relative precision (5e-2 half-width)
    assert np.all(hi[:2] >= [8.0, 8.0]) and np.all(hi[:2] <= [8.0 * 1.11, 8.0 * 1.11])
    assert np.all(lo[:2] <= [-4.0, -3.0]) and np.all(lo[:2] >= [-4.0 * 1.11, -3.0 * 1.11])
    assert hi[2] == lo[2] == 0.0
    # iterating from them converges to the value of either direction (here: max)
    sys = build_system(g, unknown, maximize=np.ones(3, bool), choice_offset=TWO_STATE_REWARDS)
    b = solve_proper(sys, SolverOptions(precision=1e-9), lower=lo[sys.states], upper=hi[sys.states])
    assert b.converged and np.all(b.lower <= [6.0, 7.0]) and np.all([6.0, 7.0] <= b.upper)


# ---------------------------------------------------------------------------------------------
# what is not supported
# ---------------------------------------------------------------------------------------------


def _negative_loop(model_type: ModelType, players: list[int] | None = None) -> ExplicitModel:
    """s0: loop (reward -1) -> s0; go (reward 0) -> goal (s1, absorbing). Choices 0=loop, 1=go."""
    T = np.array([[1, 0], [0, 1], [0, 1]])
    return make_model(
        model_type,
        [0, 2, 3],
        T,
        state_players=players,
        player_names=("p1", "p2") if players is not None else (),
    )


@pytest.mark.parametrize("model_type", [ModelType.MDP, ModelType.SMG])
def test_end_component_with_a_negative_reward_is_rejected(model_type: ModelType) -> None:
    # minimising in s0: the target can be forced (value finite by PRISM's rule), but looping k
    # times before leaving collects -k, so the infimum is -inf: an end component with a negative
    # reward, which the proper-SSP method cannot handle
    players = [0, 0] if model_type is ModelType.SMG else None
    m = _negative_loop(model_type, players)
    r = np.array([-1.0, 0.0, 0.0])
    goal = np.array([False, True])
    with pytest.raises(UnsupportedError) as info:
        obj.expected_reach_reward(m, r, goal, maximize=np.zeros(2, bool))
    msg = info.value.message
    assert msg.startswith("R[F ...] with negative rewards (e.g. -1 in state 0) is only supported")
    assert "every strategy profile reaches the target with probability 1" in msg
    assert "from state 0 some profile avoids the target" in msg
    assert "end component" in msg and "-infinity or undefined" in msg
    assert info.value.hint is not None and "Fdiscount" in info.value.hint
    # maximising, s0 can stay away from the target forever: +inf (PRISM's rule), no error
    res = obj.expected_reach_reward(m, r, goal, maximize=np.ones(2, bool))
    _check(res, [np.inf, 0.0])


def test_improper_region_elsewhere_is_rejected_with_the_relevant_state() -> None:
    # s0: go (reward -1) -> goal; s2: wait (reward 0) -> s2, leave (reward 1) -> goal. Minimising,
    # s2 can idle forever (an end component), so not every profile is proper: rejected (the global
    # rule), and the message names the negative reward of state 0 and the improper state 2
    T = np.array([[0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 0]])
    m = make_model(
        ModelType.MDP, [0, 1, 2, 4], T, variable_names=("x",), state_values=[[0], [1], [2]]
    )
    with pytest.raises(UnsupportedError) as info:
        obj.expected_reach_reward(
            m,
            np.array([-1.0, 0.0, 0.0, 1.0]),
            np.array([False, True, False]),
            maximize=np.zeros(3, bool),
        )
    assert "(e.g. -1 in state 0 (x=0))" in info.value.message
    assert info.value.message.endswith(
        "from state 2 (x=2) some profile avoids the target with positive probability (it can stay"
        " in an end component forever)"
    )


def test_other_objectives_reject_negative_rewards_clearly() -> None:
    m = _negative_loop(ModelType.MDP)
    r = np.array([-1.0, 0.0, 0.0])
    goal = np.array([False, True])
    with pytest.raises(UnsupportedError) as info:
        obj.total_reward(m, r, maximize=np.ones(2, bool))
    assert info.value.message == (
        "negative rewards are not supported for the expected total reward R[C] (e.g. -1 in state 0)"
    )
    assert info.value.hint is not None and "Cdiscount" in info.value.hint
    with pytest.raises(UnsupportedError) as info:
        obj.expected_reach_reward(m, r, goal, maximize=np.ones(2, bool), mode=ZERO)
    assert info.value.message.startswith("negative rewards are not supported for R[F0 ...]")
    with pytest.raises(UnsupportedError) as info:
        obj.expected_reach_reward(m, r, goal, maximize=np.ones(2, bool), mode=CUM)
    assert info.value.message.startswith("R[Fc ...] with negative rewards (e.g. -1 in state 0)")
    assert "from every state (then it equals R[F ...])" in info.value.message


@pytest.mark.parametrize("method", ALL_METHODS)
def test_cumulative_equals_reach_when_every_profile_is_proper(method: Method) -> None:
    m = _two_state(ModelType.MDP)
    opts = SolverOptions(method=method)
    for maximize, expected in ((True, [6.0, 7.0, 0.0]), (False, [-4.0, -3.0, 0.0])):
        res = obj.expected_reach_reward(
            m,
            TWO_STATE_REWARDS,
            TWO_STATE_GOAL,
            maximize=np.full(3, maximize),
            mode=CUM,
            options=opts,
        )
        _check(res, expected)


def test_check_reports_the_error_through_the_api() -> None:
    text = """mdp
module m
  s : [0..1] init 0;
  [loop] s=0 -> (s'=0);
  [go] s=0 -> (s'=1);
  [] s=1 -> true;
endmodule
rewards "r"
  [loop] true : -1;
endrewards
"""
    session = api.load(text=text)
    report = api.check(session, properties=['R{"r"}min=? [F s=1]', 'R{"r"}max=? [F s=1]'])
    assert len(report.errors) == 1
    prop, err = report.errors[0]
    assert prop == 'R{"r"}min=? [F s=1]'
    assert isinstance(err, UnsupportedError)
    assert "negative rewards (e.g. -1 in state 0 (s=0))" in err.message
    # the engine knows no position; the checker points at the refused property (a --prop text)
    assert err.span is not None and (err.span.line, err.span.column) == (1, 1)
    assert err.span.file == "<--prop 1>"
    # maximising, s=0 can loop forever: +inf
    assert report.results[0].value == np.inf


# ---------------------------------------------------------------------------------------------
# random proper models: the bounds enclose the exact value
# ---------------------------------------------------------------------------------------------


@st.composite
def proper_models(draw: st.DrawFn) -> tuple[ExplicitModel, np.ndarray, np.ndarray]:
    """A random small model plus an absorbing goal that every row reaches with probability 1/4 (so
    every profile reaches it almost surely), integer rewards in [-4, 4] and random directions."""
    base = draw(small_models(max_states=4))
    S = base.num_states
    P = base.transitions.toarray()
    C = P.shape[0]
    T = np.zeros((C + 1, S + 1))
    T[:C, :S] = 0.75 * P
    T[:C, S] = 0.25
    T[C, S] = 1.0
    rg = np.append(base.row_groups, C + 1)
    game = base.model_type is ModelType.SMG
    model = make_model(
        base.model_type,
        rg,
        T,
        state_players=np.append(base.state_players, 0) if game else None,
        player_names=base.player_names,
    )
    rewards = np.array(draw(st.lists(st.integers(-4, 4), min_size=C + 1, max_size=C + 1)), float)
    maximize = np.array(draw(st.lists(st.booleans(), min_size=S + 1, max_size=S + 1)))
    return model, rewards, maximize


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(proper_models())
def test_bounds_enclose_the_exact_value(case: tuple[ExplicitModel, np.ndarray, np.ndarray]) -> None:
    model, rewards, maximize = case
    S = model.num_states
    goal = np.zeros(S, dtype=bool)
    goal[-1] = True
    g = structure_of(model)
    assert proper_region(g, goal, np.ones(S, dtype=bool), allowed=None).all()
    mx = maximize if model.model_type is not ModelType.DTMC else np.ones(S, dtype=bool)
    # brute force over memoryless deterministic profiles (optimal in turn-based SSP games)
    brute = game_value(model, mx, lambda rows: chain_reward(model, rows, rewards, goal, "inf"))
    exact = obj.expected_reach_reward(
        model, rewards, goal, maximize=mx, options=SolverOptions(method=Method.EXACT)
    )
    assert np.allclose(exact.values, brute, atol=1e-9)
    res = obj.expected_reach_reward(model, rewards, goal, maximize=mx)
    assert res.converged and res.sound
    slack = 1e-9 * (1.0 + np.abs(brute))
    assert np.all(res.lower <= brute + slack) and np.all(brute <= res.upper + slack)
    assert np.all(res.upper - res.lower <= _width(brute))
    # the returned strategy is optimal: its induced chain has the value (up to the precision)
    assert res.strategy is not None
    rows = np.where(res.strategy < 0, model.row_groups[:-1], res.strategy)
    achieved = chain_reward(model, rows, rewards, goal, "inf")
    assert np.allclose(achieved, brute, atol=1e-5)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_models(max_states=4), st.data())
def test_any_model_is_solved_or_rejected(model: ExplicitModel, data: st.DataObject) -> None:
    # on arbitrary models (end components allowed) the answer is either the brute-force value, or
    # UnsupportedError naming the rule; dtmcs are never rejected (the chain is the only profile)
    S, C = model.num_states, model.num_choices
    goal = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    rewards = np.array(data.draw(st.lists(st.integers(-3, 3), min_size=C, max_size=C)), float)
    mx = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    if model.model_type is ModelType.DTMC:
        mx = np.ones(S, dtype=bool)
    try:
        res = obj.expected_reach_reward(model, rewards, goal, maximize=mx)
    except UnsupportedError as e:
        assert model.model_type is not ModelType.DTMC
        assert "is only supported when every strategy profile reaches the target" in e.message
        return
    brute = game_value(model, mx, lambda rows: chain_reward(model, rows, rewards, goal, "inf"))
    inf = np.isinf(brute)
    assert np.array_equal(np.isinf(res.values), inf) and np.all(brute[inf] > 0)
    slack = 1e-9 * (1.0 + np.abs(brute[~inf]))
    assert np.all(res.lower[~inf] <= brute[~inf] + slack)
    assert np.all(brute[~inf] <= res.upper[~inf] + slack)


# ---------------------------------------------------------------------------------------------
# a benchmark (also in tests/checking/test_storm_agreement.py)
# ---------------------------------------------------------------------------------------------


def test_4x3_95_agrees_with_storm_and_the_exact_solve(benchmarks: Path) -> None:
    path = benchmarks / "pomdp" / "4x3-95" / "sketch.templ"
    built = api.build(api.load(path))
    m = built.model
    # RESULTS.md: Storm 22 states / 82 choices / 354 transitions
    assert (m.num_states, m.num_choices, m.num_transitions) == (22, 82, 354)
    prop = 'R{"reward"}max=? [F "discount_sink"]'
    sound = api.check(api.load(path), properties=[prop], built=built, full_observation=True)
    exact = api.check(
        api.load(path),
        properties=[prop],
        built=built,
        full_observation=True,
        options=CheckOptions(solver=SolverOptions(method=Method.EXACT)),
    )
    lo, hi = sound.results[0].lower, sound.results[0].upper
    # Storm's sound fully observable value (tests/data/storm_reference.json; RESULTS.md 2.48144)
    assert abs(sound.results[0].value - 2.4814363925094303) <= 1e-6 * 2.4814363925094303
    assert lo <= exact.results[0].value <= hi and hi - lo <= _width(np.array([hi]))
