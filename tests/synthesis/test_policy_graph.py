"""Point-based backups of a finite-state strategy (posgmc.synthesis.policy_graph): a new node's
value is the product's own Bellman backup, so the policy graph's estimate is what its product
check gives, and it never starts below the strategy it was built over — on random POMDPs and
random one-sided games, whatever adversary rule placed the beliefs."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.synthesis import belief, belief_grid, lower_side, policy_graph
from posgmc.synthesis.search import parametrisation, problem_of
from tests.random_games import random_pomdp, random_posg
from tests.synthesis.helpers import GUESS


def _problem(model, prop: str, adversary: int | None):  # type: ignore[no-untyped-def]
    coalition = api._resolver(model, False).coalition_of
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=adversary,
                      coalition_of=coalition, scalar=api._scalar)


def _uniform(problem):  # type: ignore[no-untyped-def]
    par = parametrisation(problem, 1)
    g, d = par.probabilities(np.zeros(par.shapes[0]), np.zeros(par.shapes[1]))
    return par.strategy(g, d)


def _graphs(problem, cutoff, explore: int = 200, max_nodes: int = 24):  # type: ignore[no-untyped-def]
    """One policy graph per adversary rule the lower side tries (a POMDP: one)."""
    model = problem.model
    upper, choice = belief_grid.full_observation_bounds(problem)
    cut = belief.cutoff_values(model, cutoff, problem.query, coalition_of=problem.coalition_of,
                               scalar=problem.scalar)
    for _, rule in lower_side._rules(problem, cutoff, choice):
        points = belief.belief_points(
            model, player=0, cutoff=cutoff, cut_values=cut, upper=upper, target=problem.target,
            remain=problem.remain, rewards=problem.rewards, discount=problem.discount,
            maximize=problem.maximize, deadline=None, explore=explore, adversary_rule=rule)
        if points is None:
            continue
        yield policy_graph.backed_up(
            model, player=0, cutoff=cutoff, cut_values=cut, beliefs=points,
            target=problem.target, remain=problem.remain, rewards=problem.rewards,
            discount=problem.discount, maximize=problem.maximize, max_nodes=max_nodes,
            deadline=None, per_round=4)


def _verified(problem, fss):  # type: ignore[no-untyped-def]
    r = StrategyChecker(problem.model, {fss.player: fss}, coalition_of=problem.coalition_of,
                        scalar=problem.scalar).check(problem.query, text="test")
    assert r.guaranteed is not None
    return r.guaranteed


def test_guessing_game_reaches_the_optimum() -> None:
    """GUESS (tests/synthesis/helpers.py): memoryless 3/4 at best, 1 with memory ("a" first,
    then "b"); the backups from the uniform memoryless strategy find the two-step plan."""
    model = api.build(api.load(text=GUESS)).model
    assert (model.num_states, model.num_choices) == (7, 14)
    problem = _problem(model, 'Pmax=? [ F "goal" ]', None)
    cutoff = _uniform(problem)
    (graph,) = list(_graphs(problem, cutoff))
    assert graph is not None and graph.added >= 2
    assert graph.estimate == 1.0
    proven = _verified(problem, graph.strategy)
    assert proven.lower >= 1.0 - 1e-5 and graph.strategy.memory_size == 1 + graph.added


def _estimate_is_the_product_value(model, adversary: int | None, maximize: bool) -> None:  # type: ignore[no-untyped-def]
    prop = ('<<p0>> ' if adversary is not None else '') + \
        ('Pmax=? [ F "goal" ]' if maximize else 'Pmin=? [ F "goal" ]')
    problem = _problem(model, prop, adversary)
    cutoff = _uniform(problem)
    base = _verified(problem, cutoff)
    for graph in _graphs(problem, cutoff):
        if graph is None:  # no backup beats the cut-off strategy at any belief
            continue
        proven = _verified(problem, graph.strategy)
        assert proven.lower - 1e-6 <= graph.estimate <= proven.upper + 1e-6
        if maximize:
            assert proven.upper >= base.lower - 1e-6
        else:
            assert proven.lower <= base.upper + 1e-6


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
@example(seed=10, maximize=True)
@example(seed=34, maximize=False)
def test_random_pomdp_graphs_are_valued_exactly(seed: int, maximize: bool) -> None:
    _estimate_is_the_product_value(random_pomdp(seed), None, maximize)


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans())
@example(seed=0, maximize=True)
@example(seed=3, maximize=False)
@example(seed=124, maximize=False)  # the adversary's states form cycles with exits
def test_random_game_graphs_are_valued_exactly(seed: int, maximize: bool) -> None:
    """Against the omniscient adversary, whichever stage rule the beliefs assumed."""
    _estimate_is_the_product_value(random_posg(seed), 1, maximize)
