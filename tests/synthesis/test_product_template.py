"""Refilled products (posgmc.synthesis.product_template): for every FSS of a template's support,
the refilled product is the one strategy_product builds (same states, rows and pattern; the
same probabilities up to the order of floating-point sums), on random POSGs and memory sizes; and
the candidate chain's reachability analysis (parametric.chain_reach) is the engines'."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.engines.graph import positive_reach
from posgmc.strategies.binding import bind
from posgmc.strategies.product import strategy_product
from posgmc.syntax import parser
from posgmc.synthesis.parametric import TEMPLATES, chain_reach, structure_of_chain
from posgmc.synthesis.product_template import support_key
from posgmc.synthesis.search import parametrisation, problem_of
from tests.random_games import random_posg


def _problem(model):  # type: ignore[no-untyped-def]
    goal = model.num_states - 2  # random_posg: the absorbing goal
    return problem_of(model, parser.parse_property(f'<<p0>> Pmax=? [ F s={goal} ]').expr,
                      player=0, adversary=1,
                      coalition_of=api._resolver(model, False).coalition_of, scalar=api._scalar)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), k=st.integers(1, 3), sparse=st.booleans())
def test_a_refilled_product_is_the_built_one(seed: int, k: int, sparse: bool) -> None:
    par = parametrisation(_problem(random_posg(seed)), k)
    rng = np.random.default_rng(seed)
    shape_a, shape_d = par.shapes
    # a random support (the same for every draw): each rule keeps its first offered label and
    # each update its node 0
    keep_a = (rng.random(shape_a) < 0.6) | (not sparse)
    keep_a[:, np.arange(par.mask.shape[0]), par.mask.argmax(axis=1)] = True
    keep_d = (rng.random(shape_d) < 0.6) | (not sparse)
    keep_d[..., 0] = True
    keys = set()
    for _ in range(3):
        gamma, delta = par.probabilities(rng.normal(size=shape_a) * 2,
                                         rng.normal(size=shape_d) * 2)
        gamma, delta = gamma * keep_a, delta * keep_d
        gamma /= gamma.sum(axis=2, keepdims=True)
        delta /= delta.sum(axis=3, keepdims=True)
        keys.add(support_key(gamma, delta))
        got = par._product(gamma, delta)
        ref = strategy_product(par.model, [bind(par.model, par.strategy(gamma, delta))])
        assert np.array_equal(got.state_of, ref.state_of)
        assert np.array_equal(got.memory_of, ref.memory_of)
        A, B = got.model.transitions, ref.model.transitions
        assert A.shape == B.shape
        assert np.array_equal(A.indptr, B.indptr) and np.array_equal(A.indices, B.indices)
        np.testing.assert_allclose(A.data, B.data, rtol=1e-14, atol=0.0)
        assert np.array_equal(got.model.row_groups, ref.model.row_groups)
    assert len(keys) == 1  # one support: one template, refilled after the first build
    assert len(par._templates) <= min(TEMPLATES, 1)


def test_the_template_is_reused_within_a_support() -> None:
    par = parametrisation(_problem(random_posg(3)), 2)
    rng = np.random.default_rng(0)
    shape_a, shape_d = par.shapes
    values = []
    for _ in range(5):
        gamma, delta = par.probabilities(rng.normal(size=shape_a), rng.normal(size=shape_d))
        values.append(par.evaluate(gamma, delta, gradient=False).value)
        ref = strategy_product(par.model, [bind(par.model, par.strategy(gamma, delta))])
        assert par._product(gamma, delta).model.num_states == ref.model.num_states
    assert len(par._templates) == 1
    assert all(0.0 <= v <= 1.0 for v in values)


@given(seed=st.integers(0, 10_000), n=st.integers(1, 30), density=st.floats(0.0, 0.3))
def test_chain_reach_is_the_engines_positive_reach(seed: int, n: int, density: float) -> None:
    # a candidate's chain is analysed by one compiled search instead of the engines' attractor
    rng = np.random.default_rng(seed)
    P = sp.random(n, n, density=density, random_state=rng, format="csr")
    P.data[rng.random(P.nnz) < 0.2] = 0.0  # stored zeros are no edges
    target, remain = rng.random(n) < 0.2, rng.random(n) < 0.7
    expected = positive_reach(structure_of_chain(P), target, remain,
                              existential=np.ones(n, dtype=bool))
    assert np.array_equal(chain_reach(P, target, remain), expected)
    # remembered per support: the same pattern with other (positive) probabilities gets the same
    # answer, other stored zeros do not
    Q = P.copy()
    Q.data[Q.data > 0] = rng.uniform(0.5, 1.0, int((Q.data > 0).sum()))
    assert np.array_equal(chain_reach(Q, target, remain), expected)
    if P.nnz:
        Q.data[:] = 0.0
        assert np.array_equal(chain_reach(Q, target, remain), target)
