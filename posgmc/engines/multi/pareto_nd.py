"""Pareto fronts of three or more objectives by weighted sums (the n-dimensional form of
:mod:`posgmc.engines.multi.pareto`).

The same method (Forejt, Kwiatkowska and Parker, ATVA 2012, which PRISM applies in any
dimension): every weighted sum ``w @ values`` (``w >= 0``) the LP maximises gives an achievable
point (the **under-approximation** is the downward closure of the convex hull of the points) and
a half-space ``w @ v <= w @ p`` holding every achievable point (the **over-approximation** is their
intersection). The loop:

1. the extremes: each objective maximised, the others as tie-breakers;
2. the facets of the under-approximation (the convex hull, by Qhull, of the points and of their
   far-down shifts along every axis, which closes it downwards) whose outward normal is ``>= 0``
   are probed: their normal is the next weight vector; a point more than ``tolerance`` beyond the
   facet is added; a facet is probed once;
3. until no facet yields a new point, or the LP budget.

**Precision**: for every vertex ``x`` of the over-approximation (Qhull's half-space
intersection, clipped below by a box that holds every point), the smallest ``t`` such that
``x - t (1, ..., 1)`` lies in the under-approximation (an LP), i.e. how far, uniformly in every
objective, a point that may be achievable lies beyond what is known to be. The largest is
reported: every achievable point lies within it of the under-approximation.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from posgmc.engines.multi.lp import LPStatus, OccupationLP
from posgmc.engines.multi.pareto import ParetoFront
from posgmc.errors import UnsupportedError

__all__ = ["pareto_front_nd"]

_TIE = 1e-7


def pareto_front_nd(
    lp: OccupationLP,
    axes: tuple[int, ...],
    *,
    at_least: dict[int, float] | None = None,
    tolerance: float = 1e-6,
    max_solves: int = 200,
) -> ParetoFront:
    """The Pareto front of the objectives ``axes`` (three or more) of ``lp``, subject to
    ``values[i] >= at_least[i]``; ``points``/``corners`` are float64[m, len(axes)], ``facets``
    float64[f, len(axes) + 1] (rows ``(w, b)``: ``w @ v <= b``).

    Raises:
        UnsupportedError: an objective is unbounded, or the LP solver failed.
    """
    at_least = dict(at_least or {})
    n = len(axes)
    solves = 0

    def solve(w: np.ndarray) -> np.ndarray | None:
        nonlocal solves
        solves += 1
        full = np.zeros(lp.num_objectives)
        full[list(axes)] = w
        point = lp.maximise(full, at_least=at_least)
        if point.status is LPStatus.INFEASIBLE:
            return None
        if point.status is LPStatus.UNBOUNDED:
            raise UnsupportedError("an objective of the Pareto query is unbounded (a reward can "
                                   "grow without limit): the front is not finite")
        if point.status is LPStatus.FAILED:
            raise UnsupportedError(f"the LP solver failed: {point.message}")
        return point.values[list(axes)]

    points: list[np.ndarray] = []
    facets: list[np.ndarray] = []
    for axis in range(n):
        w = np.full(n, _TIE)
        w[axis] = 1.0
        w /= np.linalg.norm(w)
        p = solve(w)
        if p is None:
            empty = np.zeros((0, n))
            return ParetoFront(empty, np.zeros((0, n + 1)), empty, 0.0, solves, True)
        facets.append(np.append(w, w @ p))
        if not any(np.linalg.norm(p - q) <= tolerance for q in points):
            points.append(p)
    probed: list[np.ndarray] = []
    converged = True
    while True:
        new = False
        for w in _upper_normals(np.array(points)):
            if any(np.linalg.norm(w - u) <= 1e-9 for u in probed):
                continue
            if solves >= max_solves:
                converged = False
                break
            probed.append(w)
            c = solve(w)
            assert c is not None  # noqa: S101 - feasible for one weight, feasible for all
            facets.append(np.append(w, w @ c))
            if float(w @ c) - max(float(w @ q) for q in points) > tolerance:
                points.append(c)
                new = True
        if not new or not converged:
            break
    under = _vertices(np.array(points))
    facet_rows = np.array(facets)
    corners, low = _corners(facet_rows, under)
    precision = max((_shift_into(x, under) for x in corners), default=0.0)
    # the vertices on the box only close the downward directions: not reported
    corners = corners[np.all(corners > low + 1e-9 * (1.0 + np.abs(low)), axis=1)]
    return ParetoFront(under, facet_rows, corners, precision, solves, converged)


def _closed(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The points and their far-down shifts along each axis (the downward closure, as a
    polytope Qhull can take), and the shift used."""
    span = float(np.max(points.max(axis=0) - points.min(axis=0), initial=0.0))
    far = 10.0 * (1.0 + span)
    shifts = [points]
    for axis in range(points.shape[1]):
        s = points.copy()
        s[:, axis] -= far
        shifts.append(s)
    low = points.min(axis=0) - far
    shifts.append(low[None, :])
    return np.unique(np.vstack(shifts), axis=0), far


def _upper_normals(points: np.ndarray) -> list[np.ndarray]:
    """The unit outward normals ``>= 0`` (no axis direction) of the facets of the
    under-approximation that touch a found point."""
    cloud, _ = _closed(points)
    try:
        hull = ConvexHull(cloud)
    except QhullError:
        try:
            hull = ConvexHull(cloud, qhull_options="QJ")
        except QhullError:
            return []
    out: list[np.ndarray] = []
    for eq in hull.equations:
        w = eq[:-1]
        if np.any(w < -1e-9) or np.count_nonzero(w > 1e-9) < 2:
            continue  # facing down, or an axis plane of the closure
        w = np.clip(w, 0.0, None)
        w /= np.linalg.norm(w)
        b = -eq[-1] / np.linalg.norm(eq[:-1])
        if not np.any(np.abs(points @ w - b) <= 1e-7 * (1.0 + abs(b))):
            continue
        if not any(np.linalg.norm(w - u) <= 1e-9 for u in out):
            out.append(w)
    return out


def _vertices(points: np.ndarray) -> np.ndarray:
    """The found points that are vertices of the under-approximation (not dominated by a convex
    combination of the others shifted up), by the first coordinate descending."""
    keep = []
    for i, p in enumerate(points):
        others = np.delete(points, i, axis=0)
        if len(others) and _shift_into(p, others) <= 1e-9:
            continue
        keep.append(p)
    out = np.array(keep).reshape(-1, points.shape[1])
    return out[np.lexsort(out.T[::-1] * -1)] if len(out) else out


def _corners(facets: np.ndarray, under: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertices of ``{v : facets @ (v, -1) <= 0}`` with the box ``v >= low`` (``low`` below
    every point, so that the box only closes the downward directions), and ``low``."""
    n = under.shape[1]
    span = float(np.max(under.max(axis=0) - under.min(axis=0), initial=0.0))
    low = under.min(axis=0) - (1.0 + span)
    # Qhull's form: A x + b <= 0
    rows = [np.append(f[:n], -f[n]) for f in facets]
    rows += [np.append(-np.eye(n)[i], low[i]) for i in range(n)]
    halfspaces = np.array(rows)
    interior = under.mean(axis=0) - 0.5 * (1.0 + span) * np.ones(n) / 2
    interior = np.maximum(interior, low + 1e-3 * (1.0 + span))
    if np.any(halfspaces[:, :n] @ interior + halfspaces[:, n] >= 0):
        return np.zeros((0, n)), low
    try:
        hs = HalfspaceIntersection(halfspaces, interior)
    except QhullError:
        return np.zeros((0, n)), low
    pts = np.unique(np.round(hs.intersections, 12), axis=0)
    return pts[np.lexsort(pts.T[::-1] * -1)], low


def _shift_into(x: np.ndarray, points: np.ndarray) -> float:
    """The smallest ``t`` with ``x - t 1`` below a convex combination of ``points`` (an LP over
    ``(t, lambda)``); 0 when ``x`` already lies in the downward closure."""
    m, n = points.shape
    c = np.zeros(1 + m)
    c[0] = 1.0
    # x - t <= sum_j lambda_j p_j   <=>   -t - sum_j lambda_j p_j <= -x
    a_ub = np.hstack([-np.ones((n, 1)), -points.T])
    a_eq = np.append(0.0, np.ones(m))[None, :]
    res = linprog(c, A_ub=a_ub, b_ub=-x, A_eq=a_eq, b_eq=[1.0],
                  bounds=[(None, None)] + [(0, None)] * m, method="highs")
    if res.status != 0:
        return float("inf")
    return max(0.0, float(res.x[0]))
