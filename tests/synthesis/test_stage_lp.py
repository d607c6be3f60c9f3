"""The adversary's randomised stage rules (posgmc.synthesis.stage_lp) in the one-sided game's
belief grid (posgmc.synthesis.belief_grid): they close the gap that deterministic rules leave on
a game where the adversary must keep the decision maker guessing, and the bound stays sound
whatever rule is offered (the LP only chooses; the sound engines prove)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.syntax import parser
from posgmc.synthesis import belief_dynamics, belief_grid, stage_lp
from posgmc.synthesis.search import problem_of
from tests.random_games import random_posg
from tests.synthesis.helpers import every_deterministic, fss_guaranteed, runner_crossing_at_once

ROOT = Path(__file__).resolve().parents[2]
HIDE = ROOT / "tests" / "data" / "games" / "hide.posg"
ROUNDS = ROOT / "tests" / "data" / "games" / "hide_rounds.posg"


def _game(model, prop: str, zero_based: bool = False):  # type: ignore[no-untyped-def]
    coalition = api._resolver(model, zero_based).coalition_of
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=1,
                      coalition_of=coalition, scalar=api._scalar)


def _hide(r: str = "0.5"):  # type: ignore[no-untyped-def]
    model = api.build(api.load(HIDE, constants={"r": r})).model
    # phase 0; phase 1 on either side; phase 2 won (left or right) or lost (left or right)
    assert model.num_states == 7
    return _game(model, '<<seeker>> Pmax=? [ F "won" ]')


def _bound(problem, vertices: int = 20_000) -> belief_grid.GridBound:  # type: ignore[no-untyped-def]
    """The bound within a work budget (grid vertices), not a wall-clock one: what it proves
    depends on the model alone, however loaded the machine is."""
    found = belief_grid.grid_bound(problem, deadline=None, vertices=vertices)
    assert found is not None
    return found


def _first_grid(found: belief_grid.GridBound) -> float:
    """The first solve at resolution 2 (before any stage LP: deterministic rules and the uniform
    mixture only)."""
    return next(v for n, v in found.tried if n == 2)


def test_the_hider_mixes_to_the_optimum() -> None:
    """hide.posg, r = 1/2: the optimum is 1/3 (derived in the model's comment). Deterministic
    rules and the uniform mixture give 1/2 (the first solve at resolution 2); the stage LPs'
    rules bring the bound to within 1e-3 of 1/3 and never below it."""
    found = _bound(_hide())
    assert _first_grid(found) == pytest.approx(0.5, abs=1e-6)
    assert 1 / 3 <= found.value <= 1 / 3 + 1e-3


def test_a_dyadic_mixture_is_found_exactly() -> None:
    """hide.posg, r = 1/3: the optimum is 1/4, at the hider's mixture (1/4, 3/4), a grid belief
    at resolution 4: the bound is the optimum up to the solver's relative precision."""
    found = _bound(_hide("1/3"))
    assert 0.25 <= found.value <= 0.25 * (1 + 1e-7)


def _rounds(prop: str):  # type: ignore[no-untyped-def]
    model = api.build(api.load(ROUNDS, constants={"r": "0.5"})).model
    # phase 0; phase 1 on either side; phase 2 (won)
    assert model.num_states == 4
    return _game(model, prop)


def test_expected_rounds_are_bounded_below_by_the_optimum() -> None:
    """hide_rounds.posg, r = 1/2: at least 3 rounds are expected (the model's comment); the
    bound side is the lower one, from 2 (deterministic rules and the uniform mixture) to
    within 1e-2 of 3, never above it."""
    found = _bound(_rounds('<<seeker>> R{"rounds"}min=? [ F "won" ]'))
    assert _first_grid(found) == pytest.approx(2.0, abs=1e-6)
    assert 3.0 - 1e-2 <= found.value <= 3.0


def test_discounted_rounds_are_bounded_below_by_the_optimum() -> None:
    """hide_rounds.posg, r = 1/2, discount 0.9: the optimum is 0.9 / (1 - 0.81 (2/3)) =
    1.95652... (the model's comment, p = 1/3); deterministic rules concede p = 1/2:
    0.9 / (1 - 0.81 / 2) = 1.51260..."""
    found = _bound(_rounds('<<seeker>> R{"rounds"}min=? [ Fdiscount=0.9 "won" ]'))
    optimum = 0.9 / (1 - 0.81 * (2 / 3))
    assert _first_grid(found) == pytest.approx(0.9 / (1 - 0.81 / 2), abs=1e-6)
    assert optimum - 1e-2 <= found.value <= optimum


def test_stage_rules_are_distributions_per_state() -> None:
    """Both LPs return, per state of the belief's support, a distribution over its choices
    that is not deterministic (a deterministic rule is offered anyway, so None is returned)."""
    problem = _hide()
    dyn = belief_dynamics.Dynamics(problem, None)
    s0 = int(problem.model.initial_states[0])
    states, p = np.array([s0]), np.array([1.0])
    cols, _ = dyn.rules(states)
    owner = np.zeros(cols.size, dtype=np.int64)
    cutoff, _ = belief_grid.full_observation_bounds(problem)
    beliefs = belief_grid._Grid(problem.model.num_states, 1)
    beliefs.vertex(states, np.array([1]))
    data = stage_lp.StageData.of(dyn.T_cont, dyn.T_stop, beliefs.matrix(), np.ones(1), cutoff,
                                 minimise=True)
    step = stage_lp.OneStep(np.stack([dyn.stop[a] + dyn.P[a] @ cutoff
                                      for a in range(dyn.actions.size)]),
                            dyn.mask, dyn.group, cutoff, dyn.Z)
    rule = stage_lp.one_step_rule(data, step, p, cols, owner)
    # against the one-step estimate max(q, (1 - q) / 2) the hider's best q is 1/3
    assert rule is not None and rule.sum() == pytest.approx(1.0)
    assert sorted(rule.tolist()) == pytest.approx([1 / 3, 2 / 3], abs=1e-7)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1))
def test_any_offered_rule_keeps_the_bound_sound(seed: int) -> None:
    """Whatever randomised rules the LPs return (here: random ones), the solved abstraction
    stays above the optimum 1/3 of hide.posg: soundness rests on the sound solve alone."""
    rng = np.random.default_rng(seed)

    def random_rule(*args: object) -> np.ndarray:
        owner = np.asarray(args[-1])
        x = rng.random(owner.size)
        out: np.ndarray = x / np.bincount(owner, weights=x)[owner]
        return out

    original = (stage_lp.stage_rule, stage_lp.one_step_rule, stage_lp.grid_rule)
    stage_lp.stage_rule = random_rule  # type: ignore[assignment]
    stage_lp.one_step_rule = random_rule  # type: ignore[assignment]
    stage_lp.grid_rule = lambda J, owner, targets: random_rule(owner)  # type: ignore[assignment]
    try:
        found = _bound(_hide(), vertices=4000)
    finally:
        stage_lp.stage_rule, stage_lp.one_step_rule, stage_lp.grid_rule = original
    assert found.value >= 1 / 3


def _contains_every_deterministic_fss(seed: int, maximize: bool, memories: tuple[int, ...]
                                      ) -> None:
    """On a random one-sided POSG the grid bound is on the far side of what every deterministic
    FSS of the given memories ensures against the omniscient adversary (brute force)."""
    model = random_posg(seed)
    prop = '<<p0>> Pmax=? [ F "goal" ]' if maximize else '<<p0>> Pmin=? [ F "goal" ]'
    problem = _game(model, prop)
    found = belief_grid.grid_bound(problem, deadline=None, vertices=4000)
    if found is None:
        return  # the initial state does not continue: nothing to bound
    sign = 1.0 if maximize else -1.0
    for memory in memories:
        for gamma, delta in every_deterministic(problem, memory):
            value = fss_guaranteed(problem, memory, gamma, delta)
            assert sign * found.value >= sign * value - 1e-7


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
def test_random_game_bounds_hold_against_memoryless_defences(seed: int, maximize: bool) -> None:
    _contains_every_deterministic_fss(seed, maximize, (1,))


@pytest.mark.slow
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
def test_random_game_bounds_hold_against_two_node_defences(seed: int, maximize: bool) -> None:
    _contains_every_deterministic_fss(seed, maximize, (1, 2))


LANES = ROOT / "tests" / "data" / "games" / "dodge_lanes.posg"


def _lanes():  # type: ignore[no-untyped-def]
    model = api.build(api.load(LANES)).model
    # the guard's first move (lane 0 kept or left), then per round: the runner's turn (lane x
    # what it saw), the guard's (lane x crossing or not x seen), and the outcomes
    assert (model.num_states, model.num_choices) == (18, 44)
    return _game(model, '<<runner>> Pmax=? [ F "won" ]')


def test_a_guard_that_keeps_the_runner_guessing_is_found_on_the_grid() -> None:
    """dodge_lanes.posg (a runner that may peek and wait for ever against a guard that must
    re-randomise its lane with a slipping move): the optimum is 1/10 and full observation 1/5
    (both derived in the model's comment). With the guard's deterministic rules and the uniform
    mixture the resolution-2 grid leaks information at every peek and stays at full observation;
    the exact belief unfolding of those rules gives 0.12 (the uniform mixture's lane odds 3/5 :
    2/5); the rules that keep the posterior on the grid (stage_lp.grid_rule: switch with
    probability 5/8) bring the bound to the optimum, and never below what a memoryless runner
    crossing left or right at random is verified to ensure."""
    problem = _lanes()
    cutoff, _ = belief_grid.full_observation_bounds(problem)
    assert cutoff[problem.model.initial_states[0]] == pytest.approx(0.2, abs=1e-5)
    plain = belief_grid.grid_bound(problem, deadline=None, vertices=5_000, mix=False)
    assert plain is not None
    assert dict(plain.tried)[0] == pytest.approx(0.12, abs=1e-6)
    assert dict(plain.tried)[2] == pytest.approx(0.2, abs=1e-6)
    mixed = belief_grid.grid_bound(problem, deadline=None, vertices=20_000, mix=True)
    assert mixed is not None
    assert 0.1 <= mixed.value <= 0.1 + 1e-6
    # the runner that crosses at once, left or right with probability 1/2 (memoryless)
    guaranteed = runner_crossing_at_once(problem)
    assert guaranteed == pytest.approx(0.1, abs=1e-6)
    assert mixed.value >= guaranteed - 1e-9


def test_a_grid_rule_lands_on_its_target() -> None:
    """A guard known to be in lane 0 that switches with a slip of 1/5 reaches the posterior
    (1/2, 1/2), a resolution-2 grid belief, only by switching with probability 5/8; grid_rule
    finds that rule, in simple fractions so that floating point lands on the vertex itself."""
    problem = _lanes()
    dyn = belief_dynamics.Dynamics(problem, None)
    s0 = int(problem.model.initial_states[0])  # the guard's first move, lane 0
    states = np.array([s0])
    cols, _ = dyn.rules(states)
    owner = np.zeros(cols.size, dtype=np.int64)
    J = dyn.T_cont[cols].tocsr()
    succ = np.unique(J.indices)
    assert succ.size == 2  # the runner's turn with the guard in lane 0 or 1
    rule = stage_lp.grid_rule(J, owner, [(succ, np.array([0.5, 0.5]))])
    assert rule is not None
    switch = [problem.model.action_names[a] for a in
              problem.model.choice_actions[cols].tolist()].index("switch")
    assert rule[switch] == 5 / 8
    y = np.asarray(J.T @ rule).ravel()[succ]
    assert np.array_equal(y / y.sum(), np.array([0.5, 0.5]))
