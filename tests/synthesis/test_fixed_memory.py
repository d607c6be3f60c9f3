"""Randomised action maps over a fixed memory (posgmc.synthesis.fixed_memory): on PAYNT's dodge
game the ascent over the belief-support frame finds a randomised runner that the sound product
check proves far above every deterministic defence found, and its ranking value is the check's;
on random games the evaluation is the product's value and its gradient the finite difference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.synthesis import belief_grid, belief_support, fixed_memory
from posgmc.synthesis.search import problem_of
from tests.random_games import random_pomdp, random_posg

ROOT = Path(__file__).resolve().parents[2]
DODGE = ROOT / "tests" / "data" / "benchmarks" / "posmg" / "dodge-6-lines-position"


def _problem(model, prop: str, adversary: int | None):  # type: ignore[no-untyped-def]
    coalition = api._resolver(model, False).coalition_of
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=adversary,
                      coalition_of=coalition, scalar=api._scalar)


def _proven(problem, fss):  # type: ignore[no-untyped-def]
    r = StrategyChecker(problem.model, {fss.player: fss}, coalition_of=problem.coalition_of,
                        scalar=problem.scalar).check(problem.query, text="test")
    assert r.guaranteed is not None and r.guaranteed.sound
    return r.guaranteed


def test_randomised_runner_beats_the_deterministic_defences() -> None:
    """dodge-6-lines-position (PAYNT's one-sided game, tests/data/benchmarks/posmg): PAYNT's
    FSCs and posgmc's deterministic lower side (policy graphs, benchmarks/synthesis_bench.py
    --bracket) both reach 0.488; full observation 1. Against an omniscient guard a runner that
    randomises over its belief support escapes with probability above 0.99 (30 Adam steps from
    the cautious start), proven by the sound check, whose bounds contain the ascent's value."""
    model = api.build(api.load(DODGE / "sketch.templ")).model
    assert (model.num_states, model.num_choices) == (639, 2487)
    problem = _problem(model, '<<1>> Pmax=? [ F "goal" ]', 1)
    frame = belief_support.support_frame(model, 0)
    assert frame is not None
    upper, _ = belief_grid.full_observation_bounds(problem)
    found = fixed_memory.ascend_frame(problem, frame, iterations=30, start=upper)
    assert found.evaluations == 30
    g = _proven(problem, found.strategy)
    assert g.lower > 0.99
    assert g.lower - 1e-6 <= found.value <= g.upper + 1e-6
    assert not found.strategy.is_deterministic


def _gradient_is_the_difference(model, adversary: int | None, maximize: bool,  # type: ignore[no-untyped-def]
                                seed: int) -> None:
    prop = ('<<p0>> ' if adversary is not None else '') + \
        ('Pmax=? [ F "goal" ]' if maximize else 'Pmin=? [ F "goal" ]')
    problem = _problem(model, prop, adversary)
    frame = belief_support.support_frame(model, 0)
    assert frame is not None
    par = fixed_memory.FrameParametrisation(problem, frame)
    theta = np.random.default_rng(seed).normal(size=frame.num_entries)
    gamma = par.probabilities(theta)
    value, grad = par.evaluate(gamma)
    g = _proven(problem, frame.strategy(model, 0, gamma))
    assert g.lower - 1e-6 <= value <= g.upper + 1e-6
    # a direction within each rule (sums to 0): the one-sided difference of the max-min (whose
    # derivative is the gradient's wherever the adversary's best response is unique)
    d = np.random.default_rng(seed + 1).normal(size=frame.num_entries)
    d -= (np.add.reduceat(d, par.starts[:-1]) / np.diff(par.starts))[par.of_entry]
    h = 1e-6 * float(gamma.min())
    moved, _ = par.evaluate(gamma + h * d)
    assert abs((moved - value) / h - float(grad @ d)) <= 1e-3 * (1.0 + float(np.abs(grad @ d)))


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
def test_random_game_gradients(seed: int, maximize: bool) -> None:
    _gradient_is_the_difference(random_posg(seed), 1, maximize, seed)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
def test_random_pomdp_gradients(seed: int, maximize: bool) -> None:
    _gradient_is_the_difference(random_pomdp(seed), None, maximize, seed)
