"""Two-objective Pareto fronts by weighted sums, with an under- and an over-approximation.

The method of Forejt, Kwiatkowska and Parker ("Pareto curves for probabilistic model checking",
ATVA 2012), which PRISM's ``multi(...)`` Pareto queries use: each weighted sum ``w @ values``
is optimised (here by the occupation LP, :mod:`posgmc.engines.multi.lp`), which yields

* an achievable point ``p`` (the **under-approximation** is the downward closure of the convex
  hull of the points found: every point in it is achieved by a strategy mixing theirs), and
* a half-plane ``w @ v <= w @ p`` containing every achievable point (the **over-approximation**
  is the intersection of the half-planes).

Both objectives are in the maximising sense. The extremes come from optimising one objective with
the other as a tie-breaker; then each segment between neighbouring points is probed with its outward
normal; a segment is final when no point lies further than ``tolerance`` beyond it. The
``precision`` reported is the largest distance from a vertex of the over-approximation to the
under-approximation (0 up to the LP's tolerance when every segment was closed), computed from the
polygons themselves, so it holds however the loop ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posgmc.engines.multi.lp import LPStatus, OccupationLP
from posgmc.errors import UnsupportedError

__all__ = ["ParetoFront", "pareto_front"]

_TIE = 1e-7
"""The weight of the other objective when one is optimised (a tie-breaker)."""


@dataclass(frozen=True, eq=False)
class ParetoFront:
    """A two-objective front in the maximising sense.

    ``points``: float64[m, 2], the vertices of the under-approximation, by the first objective
    descending (so the second ascends); empty when the constraints cannot be met.
    ``facets``: float64[f, 3], rows ``(w1, w2, b)``: the over-approximation is
    ``{v : w1 v1 + w2 v2 <= b for every row}``.
    ``corners``: float64[k, 2], the vertices of the over-approximation, in the same order.
    ``precision``: the largest distance from a corner to the under-approximation.
    ``solves``: LPs solved; ``converged``: every segment was closed within the tolerance.
    """

    points: np.ndarray
    facets: np.ndarray
    corners: np.ndarray
    precision: float
    solves: int
    converged: bool


def pareto_front(
    lp: OccupationLP,
    first: int,
    second: int,
    *,
    at_least: dict[int, float] | None = None,
    tolerance: float = 1e-6,
    max_solves: int = 200,
) -> ParetoFront:
    """The Pareto front of objectives ``first`` and ``second`` of ``lp``, subject to
    ``values[i] >= at_least[i]``.

    Raises:
        UnsupportedError: an objective is unbounded (a reward that can grow without limit) or
            the LP solver failed.
    """
    at_least = dict(at_least or {})
    pair = (first, second)
    solves = 0

    def solve(weights: np.ndarray, extra: dict[int, float]) -> np.ndarray | None:
        nonlocal solves
        solves += 1
        full = np.zeros(lp.num_objectives)
        full[list(pair)] = weights
        point = lp.maximise(full, at_least={**at_least, **extra})
        if point.status is LPStatus.INFEASIBLE:
            return None
        if point.status is LPStatus.UNBOUNDED:
            raise UnsupportedError(
                "an objective of the Pareto query is unbounded (a reward can grow without "
                "limit): the front is not finite"
            )
        if point.status is LPStatus.FAILED:
            raise UnsupportedError(f"the LP solver failed: {point.message}")
        return point.values[list(pair)]

    def extreme(axis: int) -> tuple[np.ndarray | None, np.ndarray]:
        # the optimum of one objective, the other breaking ties: an LP's optimal basic solution
        # for weights (1, TIE) is such a vertex unless the front is steeper than 1/TIE there
        # (then it is another vertex of the front); either way w @ v <= w @ p is a valid facet
        w = np.full(2, _TIE)
        w[axis] = 1.0
        w /= np.linalg.norm(w)
        return solve(w, {}), w

    a, wa = extreme(0)
    if a is None:
        empty = np.zeros((0, 2))
        return ParetoFront(empty, np.zeros((0, 3)), empty, 0.0, solves, True)
    b, wb = extreme(1)
    assert b is not None  # noqa: S101 - feasible for one weight, feasible for all
    facets = [np.array([wa[0], wa[1], float(wa @ a)]), np.array([wb[0], wb[1], float(wb @ b)])]
    points = [a, b]
    queue = [(a, b)] if np.linalg.norm(a - b) > tolerance else []
    converged = True
    while queue:
        if solves >= max_solves:
            converged = False
            break
        p, q = queue.pop()
        w = np.array([q[1] - p[1], p[0] - q[0]])
        norm = np.linalg.norm(w)
        if norm <= tolerance or (w < 0).any():
            continue
        w = w / norm
        c = solve(w, {})
        assert c is not None  # noqa: S101
        facets.append(np.array([w[0], w[1], float(w @ c)]))
        if float(w @ c) - float(w @ p) > tolerance:
            points.append(c)
            queue += [(p, c), (c, q)]
    under = _hull(np.array(points))
    facet_rows = np.array(facets)
    corners = _corners(facet_rows)
    precision = max((_distance_to_under(x, under) for x in corners), default=0.0)
    return ParetoFront(under, facet_rows, corners, precision, solves, converged)


def _hull(points: np.ndarray) -> np.ndarray:
    """The vertices of the upper-right boundary of the downward closure of the points' convex
    hull, by the first coordinate descending."""
    pts = points[np.lexsort((-points[:, 1], -points[:, 0]))]
    keep: list[np.ndarray] = []
    for p in pts:
        if keep and p[1] <= keep[-1][1] + 1e-12:
            continue  # dominated: no larger second coordinate at a smaller first
        while len(keep) >= 2:
            o, m = keep[-2], keep[-1]
            # m lies on or below the segment o-p: not a vertex
            cross = (m[0] - o[0]) * (p[1] - o[1]) - (m[1] - o[1]) * (p[0] - o[0])
            if cross <= 1e-12:
                keep.pop()
            else:
                break
        keep.append(p)
    return np.array(keep).reshape(-1, 2)


def _corners(facets: np.ndarray) -> np.ndarray:
    """The vertices of ``{v : facets[:, :2] @ v <= facets[:, 2]}`` (every pairwise intersection
    of facet lines that satisfies all facets), by the first coordinate descending."""
    out = []
    slack = 1e-9 * (1 + np.abs(facets[:, 2]))
    for i in range(len(facets)):
        for j in range(i + 1, len(facets)):
            m = facets[[i, j], :2]
            if abs(np.linalg.det(m)) < 1e-14:
                continue
            x = np.linalg.solve(m, facets[[i, j], 2])
            if np.all(facets[:, :2] @ x <= facets[:, 2] + slack):
                out.append(x)
    if not out:
        return np.zeros((0, 2))
    pts = np.unique(np.round(np.array(out), 12), axis=0)
    return pts[np.argsort(-pts[:, 0], kind="stable")]


def _distance_to_under(x: np.ndarray, under: np.ndarray) -> float:
    """Euclidean distance from ``x`` to the downward closure of the convex hull of ``under``
    (vertices by the first coordinate descending)."""
    pieces = []
    top, left = under[0], under[-1]
    # the boundary: a ray down from the first vertex, the segments, a ray left from the last
    pieces.append(_to_ray(x, top, np.array([0.0, -1.0])))
    pieces.append(_to_ray(x, left, np.array([-1.0, 0.0])))
    for p, q in zip(under[:-1], under[1:]):
        pieces.append(_to_segment(x, p, q))
    inside = x[0] <= top[0] + 1e-12 and x[1] <= left[1] + 1e-12 and all(
        (q[0] - p[0]) * (x[1] - p[1]) - (q[1] - p[1]) * (x[0] - p[0]) >= -1e-12
        for p, q in zip(under[:-1], under[1:])
    )
    return 0.0 if inside else float(min(pieces))


def _to_segment(x: np.ndarray, p: np.ndarray, q: np.ndarray) -> float:
    d = q - p
    t = float(np.clip((x - p) @ d / max(float(d @ d), 1e-300), 0.0, 1.0))
    return float(np.linalg.norm(x - (p + t * d)))


def _to_ray(x: np.ndarray, p: np.ndarray, d: np.ndarray) -> float:
    t = max(float((x - p) @ d), 0.0)
    return float(np.linalg.norm(x - (p + t * d)))
