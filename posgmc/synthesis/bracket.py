"""The optimum bracket of a synthesised property: ``lower <= optimum <= upper`` for the best value
any strategy of the decision maker (any memory, randomised) achieves against an omniscient
adversary.

One side is the synthesised strategy's proven ``guaranteed`` (some strategy achieves it, so the
optimum is at least that much for a maximiser, at most for a minimiser). The other side (the
*bound side*) is the tightest of the proven bounds that hold for every strategy:

* ``full_observation``: a decision maker that sees the state does at least as well;
* on a game, ``upper_bound``: the decision maker seeing everything against one fixed adversary
  strategy (the strongest enumerated). Any fixed adversary bounds the max-min, because the
  omniscient adversary of ``guaranteed`` may play it;
* on a POMDP and on a one-sided game, the belief-grid abstraction
  (:mod:`posgmc.synthesis.belief_grid`; on a game the adversary's rules at each belief include
  randomised ones chosen by :mod:`posgmc.synthesis.stage_lp`).
"""

from __future__ import annotations

import math

from posgmc.checking.results import Bound, Optimum
from posgmc.synthesis import belief_grid
from posgmc.synthesis.options import Gap
from posgmc.synthesis.problem import Problem

__all__ = ["DEFAULT_SHARE", "GAP_SHARE", "DEFAULT_VERTICES", "GAP_VERTICES", "optimum_of"]

DEFAULT_SHARE = 0.06
"""Without ``--gap``: the bound side gets this part of the time budget on top of it (so a run
takes at most this much longer than the search alone)."""

DEFAULT_VERTICES = 20_000
"""Without ``--gap``: the belief grid's work budget, grid vertices explored over all resolutions
(times ``--effort``), so that the bracket depends only on model, options and seed; the grids
also stop once refinement stops tightening the best bound (``settle`` of
:func:`~posgmc.synthesis.belief_grid.grid_bound`)."""

GAP_VERTICES = 400_000
"""With ``--gap``: the same budget (the grid stops earlier when the gap is closed)."""

GAP_SHARE = 0.3
"""With ``--gap``: the part of the time budget kept for the bound side (the search gets the
rest); it stops as soon as the gap is closed."""


def optimum_of(problem: Problem, guaranteed: Bound, full_observation: Bound,
               upper_bound: Bound | None, *, deadline: float | None,
               gap: Gap | None = None,
               vertices: int = DEFAULT_VERTICES) -> tuple[Optimum, dict[str, object]]:
    """The bracket and its statistics (JSON-ready) for the problem whose synthesised strategy
    proves ``guaranteed``; the belief grid explores at most ``vertices`` vertices over all its
    resolutions, stops at ``deadline`` (None: no wall-clock cap) and as soon as the gap (``gap``,
    else closed to 1e-6) is reached."""
    maximize = problem.maximize
    sign = 1.0 if maximize else -1.0
    # the achievable side: what the synthesised strategy proves
    achieved = guaranteed.lower if maximize else guaranteed.upper
    candidates: list[tuple[float, str]] = []
    if full_observation.sound:
        candidates.append((full_observation.upper if maximize else full_observation.lower,
                           "full observation"))
    if upper_bound is not None and upper_bound.sound:
        candidates.append((upper_bound.upper if maximize else upper_bound.lower,
                           "omniscient decision maker against the strongest adversary found"))
    stats: dict[str, object] = {}
    if belief_grid.applies(problem) and guaranteed.sound:
        want = gap if gap is not None else Gap(1e-6)
        # stop refining once the bound side is within the gap of the achieved side
        stop_at = achieved + sign * want.width(achieved, achieved)
        # the adversary's randomised rules (stage LPs, re-solves) only when a gap is asked for,
        # and without one the grids stop once refinement stops paying: the default bracket must
        # stay cheap
        found = belief_grid.grid_bound(problem, deadline=deadline, target=stop_at,
                                       vertices=vertices, mix=gap is not None,
                                       settle=gap is None)
        if found is not None:
            kind = "exact belief MDP" if found.exact else "complete" if found.complete else \
                "frontier cut off at full observation"
            where = f"belief grid (resolution {found.resolution}, {found.vertices} vertices" \
                if found.resolution else f"belief unfolding ({found.vertices} beliefs"
            candidates.append((found.value, f"{where}, {kind})"))
            stats = {"resolution": found.resolution, "vertices": found.vertices,
                     "complete": found.complete, "exact": found.exact,
                     "tried": [{"resolution": n, "bound": v} for n, v in found.tried]}
    # the time is in the result's phases ("optimum bound"): statistics stay deterministic
    sound = guaranteed.sound and bool(candidates)
    if candidates:
        bound, method = min(candidates, key=lambda c: sign * c[0])
    else:
        bound, method = sign * math.inf, "none"
    lower, upper = (achieved, bound) if maximize else (bound, achieved)
    return Optimum(lower, upper, method, sound), stats
