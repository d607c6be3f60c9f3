"""Freudenthal's triangulation (posgmc.synthesis.freudenthal): a belief is a convex combination
of grid beliefs, the batched triangulation is the single one row by row, and a grid belief is its
own vertex."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.synthesis import freudenthal


@settings(max_examples=200, deadline=None)
@given(weights=st.lists(st.floats(0.001, 1.0), min_size=1, max_size=12),
       resolution=st.sampled_from([1, 2, 3, 4, 7, 16, 64]))
def test_freudenthal_is_a_convex_combination_of_grid_beliefs(weights: list[float],
                                                             resolution: int) -> None:
    p = np.asarray(weights) / np.sum(weights)
    counts, lam = freudenthal.freudenthal(p, resolution)
    assert counts.shape == (lam.size, p.size)
    assert np.all(lam > 0) and abs(lam.sum() - 1.0) <= 1e-12
    assert np.all(counts >= 0) and np.all(counts.sum(axis=1) == resolution)
    assert np.abs(lam @ (counts / resolution) - p).max() <= 1e-9
    assert lam.size <= p.size  # the vertices of one simplex of the triangulation


@settings(max_examples=50, deadline=None)
@given(rows=st.integers(1, 6), m=st.integers(1, 8), seed=st.integers(0, 1000),
       resolution=st.sampled_from([1, 2, 5, 16]))
def test_the_batch_triangulation_is_the_single_one(rows: int, m: int, seed: int,
                                                   resolution: int) -> None:
    P = np.random.default_rng(seed).random((rows, m)) + 0.01
    P /= P.sum(axis=1, keepdims=True)
    counts, lam = freudenthal.freudenthal_batch(P, resolution)
    for i in range(rows):
        one_counts, one_lam = freudenthal.freudenthal(P[i], resolution)
        keep = lam[i] > 0
        assert np.array_equal(counts[i][keep], one_counts)
        assert np.array_equal(lam[i][keep], one_lam)


def test_a_grid_belief_is_its_own_vertex() -> None:
    counts, lam = freudenthal.freudenthal(np.array([0.25, 0.5, 0.25]), 4)
    assert counts.tolist() == [[1, 2, 1]] and lam.tolist() == [1.0]
