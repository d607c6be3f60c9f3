"""The compiled Gauss-Seidel kernel for float estimates
(:mod:`posgmc.engines.kernels.ordered_sweeps`): on random discounted games (a contraction, one
fixpoint) its values agree with the fixpoint computed independently here (numpy Jacobi sweeps to
1e-14), in the checked component order or as one component in any order, with self-loops and
states of several rows, min and max states mixed; and a chain (one row per state) solved in
component order needs one update per state."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import kernels, scc
from posgmc.engines.kernels.ordered_sweeps import solve_ordered
from posgmc.synthesis.ordered_evaluation import solving_order

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")


def _random_game(seed: int, states: int, fixed: int
                 ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray]:
    """(rows [R, states + fixed] csr, row_groups of the first ``states`` states, rewards per row,
    minimise per state); the last ``fixed`` columns are states with fixed values."""
    rng = np.random.default_rng(seed)
    counts = rng.integers(1, 4, size=states)
    R = int(counts.sum())
    dense = np.where(rng.random((R, states + fixed)) < 0.3, rng.random((R, states + fixed)), 0.0)
    dense[np.arange(R), rng.integers(0, states + fixed, size=R)] += 0.5  # no empty row
    dense /= dense.sum(axis=1, keepdims=True)
    rg = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return sp.csr_matrix(dense), rg, rng.random(R), rng.random(states) < 0.5


def _jacobi(T: sp.csr_matrix, rg: np.ndarray, reward: np.ndarray, minimize: np.ndarray,
            x: np.ndarray, g: float) -> np.ndarray:
    n = rg.size - 1
    for _ in range(10_000):
        rows = reward + g * (T @ x)
        new = np.where(minimize, np.minimum.reduceat(rows, rg[:-1]),
                       np.maximum.reduceat(rows, rg[:-1]))
        change = np.abs(new - x[:n]).max()
        x = x.copy()
        x[:n] = new
        if change <= 1e-14:
            break
    return x


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(0, 3), st.booleans())
def test_values_agree_with_the_fixpoint(seed: int, states: int, fixed: int, by_component: bool
                                        ) -> None:
    """In the components of :func:`~posgmc.synthesis.ordered_evaluation.solving_order`, or all
    states as one component in any order (plain Gauss-Seidel)."""
    T, rg, reward, minimize = _random_game(seed, states, fixed)
    g = 0.9
    rng = np.random.default_rng(seed + 1)
    start = np.concatenate([rng.random(states), rng.random(fixed)])  # any start on the free part
    expected = _jacobi(T, rg, reward, minimize, start, g)
    if by_component:
        # the fixed states as absorbing ones, so that the graph is a model's
        full = sp.vstack([T, sp.csr_matrix((np.ones(fixed), (np.arange(fixed), states +
                                                               np.arange(fixed))),
                                           shape=(fixed, states + fixed))]).tocsr()
        full_rg = np.concatenate([rg, rg[-1] + 1 + np.arange(fixed)])
        mask = np.arange(states + fixed) < states
        order, comp_ptr = solving_order(full, full_rg, mask)
    else:
        order = rng.permutation(states).astype(np.int64)
        comp_ptr = np.array([0, states], dtype=np.int64)
    x = start.copy()
    solve_ordered(T.indptr.astype(np.int64), T.indices.astype(np.int64), T.data, rg,
                  np.arange(states, dtype=np.int64), order, comp_ptr, reward, g, minimize,
                  1e-13, 1.0, 100_000, x)
    assert np.array_equal(x[states:], start[states:])  # the fixed values are only read
    assert np.abs(x - expected).max() <= 1e-10


def test_a_wrong_order_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """The chain 0 <- 1 <- 2 (state 0 into the fixed state 3): three components, 0 first. Were
    the labels not topological (patched here), state 1 would read state 0 unsolved: the check
    of :func:`solving_order` then makes all states one component."""
    T = sp.csr_matrix(np.array([[0.5, 0, 0, 0.5], [0.5, 0.5, 0, 0], [0, 0.5, 0.5, 0],
                                [0, 0, 0, 1.0]]))
    rg = np.arange(5, dtype=np.int64)
    listed = np.array([True, True, True, False])
    order, comp_ptr = solving_order(T, rg, listed)
    assert order.tolist() == [0, 1, 2] and comp_ptr.tolist() == [0, 1, 2, 3]
    monkeypatch.setattr(scc, "components", lambda *_a, **_k: np.array([2, 1, 0, -1]))
    order, comp_ptr = solving_order(T, rg, listed)
    assert order.tolist() == [2, 1, 0] and comp_ptr.tolist() == [0, 3]


def test_a_chain_in_component_order_is_solved_in_one_pass() -> None:
    """States 0 <- 1 <- 2 (state i moves to i - 1 with probability 0.5, else stays: a self-loop),
    state 0 to the fixed state 3 (value 1): each state's equation, its self-loop eliminated, is
    final once its successor is: one update per state."""
    T = sp.csr_matrix(np.array([[0.5, 0, 0, 0.5], [0.5, 0.5, 0, 0], [0, 0.5, 0.5, 0]]))
    x = np.array([0.0, 0.0, 0.0, 1.0])
    work = solve_ordered(T.indptr.astype(np.int64), T.indices.astype(np.int64), T.data,
                         np.arange(4, dtype=np.int64), np.arange(3, dtype=np.int64),
                         np.arange(3, dtype=np.int64), np.arange(4, dtype=np.int64),
                         np.zeros(3), 1.0, np.zeros(3, dtype=bool), 1e-12, 1.0, 100, x)
    assert x.tolist() == [1.0, 1.0, 1.0, 1.0]  # reached surely: 0.5 / (1 - 0.5) per step
    assert work == 3
