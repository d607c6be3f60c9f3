"""The MILP composition (posgmc.synthesis.milp) against brute force over every deterministic
memoryless defence, on small random POSGs: with the decision maker partially observing and
fully observing (ACJJKT19's orientation) (issue #9)."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from posgmc import api
from posgmc.syntax import parser
from posgmc.synthesis.adversaries import enumerate_adversaries
from posgmc.synthesis.compose import VersusJob
from posgmc.synthesis.milp import compose_milp, supported
from posgmc.synthesis.search import parametrisation, problem_of
from tests.synthesis.test_compose import random_posg


def _problem(model, prop: str):  # type: ignore[no-untyped-def]
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=1,
                      coalition_of=api._resolver(model, False).coalition_of, scalar=api._scalar)


@pytest.mark.parametrize("full_observation", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4, 5, 6, 7])
def test_milp_is_the_brute_force_min_max(seed: int, full_observation: bool) -> None:
    model = random_posg(seed)
    if full_observation:  # p0 sees the state: no observation function of its own
        model = dataclasses.replace(model, observations=())
    sink = model.num_states - 1  # random_posg: the absorbing sink is the last state
    problem = _problem(model, f'<<p0>> Pmin=? [ F s={sink} ]')
    assert supported(problem)
    adversaries = enumerate_adversaries(model, 1, memory=1, limit=4).strategies
    par = parametrisation(problem, 1)
    Zu, Au = par.mask.shape
    defences = list(itertools.product(*[np.flatnonzero(par.mask[z]).tolist() for z in range(Zu)]))
    if len(defences) > 300:
        pytest.skip("brute force too slow for the default suite")
    best = np.inf
    for pick in defences:
        gamma = np.zeros((1, Zu, Au))
        gamma[0, np.arange(Zu), pick] = 1.0
        fss = par.strategy(gamma, np.ones((1, Zu, Au, 1)))
        best = min(best, max(VersusJob(fss, a).run(problem) for a in adversaries))
    found = compose_milp(problem, adversaries)
    assert found is not None and found.optimal
    assert found.value == pytest.approx(best, abs=1e-7)
    # its strategy achieves it (the strategy checker on each product)
    assert max(VersusJob(found.strategy, a).run(problem) for a in adversaries) == pytest.approx(
        best, abs=1e-7
    )


def test_maximised_probabilities_are_not_offered() -> None:
    """The greatest solution of x <= P x counts a loop as reaching: not exact, so not offered."""
    model = random_posg(0)
    assert not supported(_problem(model, '<<p0>> Pmax=? [ F "goal" ]'))
