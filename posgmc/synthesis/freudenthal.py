"""Freudenthal's triangulation of the belief simplex: the grid beliefs a belief is a convex
combination of, and the weights (:mod:`posgmc.synthesis.belief_grid` bounds the optimum on them).

The grid is Freudenthal's triangulation at resolution N, taken on each belief's support (states
in their index order): in the coordinates x_i = N Σ_{j>=i} b_j the belief lies in the simplex
whose vertices are ⌊x⌋ plus the unit vectors added in the order of decreasing fractional part;
a vertex is an integer vector, so vertices are identified exactly (no float hashing). Any
decomposition into beliefs would be sound (only convexity is used); this one keeps the number of
distinct vertices small and nests for N, 2N, 4N, ...
"""

from __future__ import annotations

import numpy as np

__all__ = ["SNAP", "freudenthal", "freudenthal_batch"]


SNAP = 1e-12
"""Cumulative coordinates within this (relative to N) of an integer are that integer: float
noise in a posterior (~1e-15 relative) must not split a grid belief into a tiny simplex around
it; kept small because the snap moves the decomposition off the posterior by as much."""


def freudenthal(p: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices and weights of ``p`` (float64[m], a distribution, all entries > 0) in
    Freudenthal's triangulation of resolution N: (int64[k, m] counts, each row summing to N, so
    that vertex i is counts[i] / N; float64[k] weights λ > 0 summing to 1) with
    Σ_i λ_i counts[i] / N = p (up to rounding)."""
    m = p.size
    N = int(resolution)
    if m == 1:
        return np.full((1, 1), N, dtype=np.int64), np.ones(1)
    x = N * np.cumsum(p[::-1])[::-1]
    x[0] = N
    near = np.rint(x)
    x = np.where(np.abs(x - near) <= SNAP * N, near, x)
    v = np.floor(x)
    d = x - v
    order = 1 + np.argsort(-d[1:], kind="stable")
    dd = d[order]
    lam = np.empty(m)
    lam[0] = 1.0 - dd[0]
    lam[1:m - 1] = dd[:-1] - dd[1:]
    lam[m - 1] = dd[-1]
    Y = np.tile(v, (m, 1))
    Y[:, order] += np.tri(m, m - 1, k=-1)
    counts = np.empty((m, m), dtype=np.int64)
    counts[:, :-1] = (Y[:, :-1] - Y[:, 1:]).astype(np.int64)
    counts[:, -1] = Y[:, -1].astype(np.int64)
    keep = lam > 0
    return counts[keep], lam[keep]


def freudenthal_batch(P: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`freudenthal` of every row of ``P`` (float64[n, m], distributions with all entries
    > 0) at once: (int64[n, m, m] counts, float64[n, m] weights; a vertex of weight 0 is not
    part of the decomposition)."""
    n, m = P.shape
    N = int(resolution)
    if m == 1:
        return np.full((n, 1, 1), N, dtype=np.int64), np.ones((n, 1))
    x = N * np.cumsum(P[:, ::-1], axis=1)[:, ::-1]
    x[:, 0] = N
    near = np.rint(x)
    x = np.where(np.abs(x - near) <= SNAP * N, near, x)
    v = np.floor(x)
    d = x - v
    order = 1 + np.argsort(-d[:, 1:], axis=1, kind="stable")
    dd = np.take_along_axis(d, order, axis=1)
    lam = np.empty((n, m))
    lam[:, 0] = 1.0 - dd[:, 0]
    lam[:, 1:m - 1] = dd[:, :-1] - dd[:, 1:]
    lam[:, m - 1] = dd[:, -1]
    Y = np.repeat(v[:, None, :], m, axis=1)  # [n, vertex, coordinate]
    steps = np.tri(m, m - 1, k=-1)  # vertex k adds the first k unit vectors of the order
    rows = np.arange(n)[:, None, None]
    Y[rows, np.arange(m)[None, :, None], order[:, None, :]] += steps[None]
    counts = np.empty((n, m, m), dtype=np.int64)
    counts[:, :, :-1] = (Y[:, :, :-1] - Y[:, :, 1:]).astype(np.int64)
    counts[:, :, -1] = Y[:, :, -1].astype(np.int64)
    return counts, lam
