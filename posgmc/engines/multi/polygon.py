"""Downward-closed convex sets in the plane, as the chains of their Pareto vertices.

A set ``X = conv(V) - R^2_+`` (everything below some convex combination of the vertices ``V``) is
kept as its **chain**: float64[m, 2], the vertices on its upper-right boundary by the first
coordinate descending (so the second ascends), m >= 1. These are the sets the value iteration of
:mod:`posgmc.engines.multi.games` manipulates (Chen, Forejt, Kwiatkowska, Simaitis, Wiltsche,
"On stochastic games with multiple objectives", MFCS 2013): achievable points of two objectives,
closed under convex combination (randomisation) and under giving up value.

Operations (exact up to floating point): :func:`hull` (the set of a union of points),
:func:`weighted_sum` (``r + sum_i p_i X_i``, a Minkowski sum: the edges of the chains merged by
slope), :func:`intersection` (through the half-planes of the edges), :func:`contains`, and
:func:`support` (``max_{v in X} w . v`` for directions ``w >= 0``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["hull", "weighted_sum", "intersection", "contains", "support", "point"]

_EPS = 1e-12


def point(v: np.ndarray) -> np.ndarray:
    """The chain of the downward closure of one point."""
    return np.asarray(v, dtype=float).reshape(1, 2)


def hull(points: np.ndarray) -> np.ndarray:
    """The chain of the downward closure of the convex hull of ``points`` (float64[k, 2])."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.lexsort((-pts[:, 1], -pts[:, 0]))]
    keep: list[np.ndarray] = []
    for p in pts:
        if keep and p[1] <= keep[-1][1] + _EPS:
            continue  # dominated
        while len(keep) >= 2:
            o, m = keep[-2], keep[-1]
            cross = (m[0] - o[0]) * (p[1] - o[1]) - (m[1] - o[1]) * (p[0] - o[0])
            if cross <= _EPS * (1 + abs(o).max() + abs(p).max()):
                keep.pop()  # m is on or below the segment o-p
            else:
                break
        keep.append(p)
    return np.array(keep).reshape(-1, 2)


def weighted_sum(chains: list[np.ndarray], weights: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The chain of ``offset + sum_i weights[i] * X_i`` (weights >= 0)."""
    start = np.asarray(offset, dtype=float).copy()
    edges = []
    for chain, w in zip(chains, weights):
        start += w * chain[0]
        if len(chain) > 1:
            edges.append(w * np.diff(chain, axis=0))
    if not edges:
        return point(start)
    e = np.vstack(edges)
    # edges go up and to the left; along the boundary their angle grows from 90 to 180 degrees
    order = np.argsort(np.arctan2(e[:, 1], e[:, 0]), kind="stable")
    vertices = start + np.vstack([np.zeros(2), np.cumsum(e[order], axis=0)])
    return hull(vertices)


def _halfplanes(chain: np.ndarray) -> np.ndarray:
    """Rows ``(n1, n2, b)``: the set is ``{v : n . v <= b}``."""
    rows = [np.array([1.0, 0.0, chain[0][0]]), np.array([0.0, 1.0, chain[-1][1]])]
    for p, q in zip(chain[:-1], chain[1:]):
        n = np.array([q[1] - p[1], p[0] - q[0]])
        norm = np.linalg.norm(n)
        if norm > _EPS:
            n /= norm
            rows.append(np.array([n[0], n[1], float(n @ p)]))
    return np.array(rows)


def intersection(chains: list[np.ndarray]) -> np.ndarray:
    """The chain of the intersection of the sets (never empty: the sets are downward closed)."""
    if len(chains) == 1:
        return chains[0]
    rows = np.vstack([_halfplanes(c) for c in chains])
    slack = 1e-9 * (1 + np.abs(rows[:, 2]))
    out = []
    for i in range(len(rows)):
        for j in range(i + 1, len(rows)):
            m = rows[[i, j], :2]
            det = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
            if abs(det) < 1e-14:
                continue
            x = np.linalg.solve(m, rows[[i, j], 2])
            if np.all(rows[:, :2] @ x <= rows[:, 2] + slack):
                out.append(x)
    return hull(np.array(out))


def contains(chain: np.ndarray, v: np.ndarray, *, tolerance: float = 0.0) -> bool:
    """Whether ``v`` lies in the set (within ``tolerance`` of every half-plane)."""
    rows = _halfplanes(chain)
    return bool(np.all(rows[:, :2] @ np.asarray(v, dtype=float) <= rows[:, 2] + tolerance))


def support(chain: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """``max_{v in X} w . v`` for each row ``w >= 0`` of ``directions``."""
    out: np.ndarray = (directions @ chain.T).max(axis=1)
    return out
