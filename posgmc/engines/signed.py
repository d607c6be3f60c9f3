"""Sound value iteration for expected rewards of any sign until a target that every strategy
profile reaches almost surely (a stochastic shortest path problem whose policies are all proper).

Setting: a :class:`~posgmc.engines.system.System` ``B(x)(s) = opt_r (b[r] + A[r] x)`` whose rows
may have constants ``b`` of either sign and in which *every* memoryless profile leaves the system
(reaches the target) with probability 1 from every state. Then (Bertsekas & Tsitsiklis, "An analysis
of stochastic shortest path problems", 1991; the game case: Patek & Bertsekas, 1999) ``B`` is
monotone and a contraction in a weighted sup norm, its fixpoint ``V*`` is unique and is the value,
and value iteration converges to it from every start.

Bounds without a least fixpoint: split ``b = b+ - b-`` into its positive and negative parts. Every
profile's expected total of ``b+`` is at most ``U0 = max over profiles E[sum b+]`` and its expected
total of ``b-`` at most ``N0 = max over profiles E[sum b-]``, so ``L0 = -N0 <= V* <= U0``. Both are
non-negative least-fixpoint problems without end components, which
:func:`~posgmc.engines.iteration.solve` bounds soundly (its upper bounds are used). By monotonicity
``B^k(L0) <= B^k(V*) = V*`` and ``B^k(U0) >= V*`` for every k, so every iterate of the two sequences
is a proven bound; we keep the running maximum of the lower and the running minimum of the upper
iterates (also iterates of monotone maps below/above ``V*``) and stop when the gap meets the
precision. Final bounds are widened outwards for floating-point rounding by 1e-10 of the bound plus
1e-10 of the largest bound (cancellation between rewards of opposite signs), in the spirit of
:mod:`posgmc.engines.iteration`.

Whether every profile is proper is decided by the caller with graph analysis
(:func:`proper_region`), never assumed.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.graph import Structure, almost_sure_reach, attractor
from posgmc.engines.iteration import Bounds, EndComponents, gap_ok, max_change, solve
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.system import System, bellman, build_system

__all__ = ["proper_region", "start_bounds", "solve_proper", "value_iteration"]


def proper_region(
    g: Structure, target: np.ndarray, remain: np.ndarray, *, allowed: np.ndarray | None
) -> np.ndarray:
    """bool[S]: the states from which *every* strategy profile (over the ``allowed`` choices)
    reaches ``target`` almost surely while staying in ``remain``.

    Args:
        g: the model structure.
        target, remain: bool[S].
        allowed: bool[C] or None (all): the choices the profiles may use.

    Returns:
        bool[S] (``target`` included): almost-sure reachability with every state universal.
    """
    nobody = np.zeros(g.num_states, dtype=bool)
    region, _ = almost_sure_reach(g, target, remain, existential=nobody, universal_allowed=allowed)
    return region


def start_bounds(
    g: Structure,
    unknown: np.ndarray,
    rewards: np.ndarray,
    *,
    allowed: np.ndarray | None,
    options: SolverOptions,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Proven bounds ``L0 <= V* <= U0`` for any optimisation directions (module docstring).

    Args:
        g: the model structure.
        unknown: bool[S]: the states of the problem; every profile over the ``allowed`` choices
            must reach the states outside ``unknown`` (value 0) almost surely from each of them.
        rewards: float64[C], any sign.
        allowed: bool[C] or None: the choices of the problem.
        options: the iteration cap of the two auxiliary solves (always sound interval iteration,
            whatever ``options.method`` says).

    Returns:
        ``(lower, upper, iterations)``: float64[S] each (0 outside ``unknown``; a bound may be
        infinite where an auxiliary solve hit the iteration cap before it was verified), and the
        iterations spent.
    """
    S = g.num_states
    everyone = np.ones(S, dtype=bool)
    usable = unknown[g.choice_state] if allowed is None else unknown[g.choice_state] & allowed
    # the starts only need to be proven, not tight: they lie about |V*| away from the value anyway
    # (the maxima of r+ and r- ignore the other part), so a relative 5e-2 costs the main iteration
    # nothing measurable; relative precision is safe because the states solved below all have a
    # positive value
    aux = SolverOptions(
        method=Method.INTERVAL,
        precision=5e-2,
        relative=True,
        max_iterations=options.max_iterations,
        want_strategy=False,
    )
    out = []
    iterations = 0
    for part in (np.maximum(rewards, 0.0), np.maximum(-rewards, 0.0)):
        bound = np.zeros(S)
        # the maximum total of ``part`` is 0 exactly where no row with a positive ``part`` can be
        # reached; elsewhere it is positive
        positive, _ = attractor(
            g,
            np.zeros(S, dtype=bool),
            existential=everyone,
            candidates=unknown,
            allowed=usable,
            initial_choices=usable & (part > 0),
        )
        if positive.any():
            sys = build_system(g, positive, maximize=everyone, allowed=allowed, choice_offset=part)
            # no end components (every profile leaves), so the least fixpoint is the only one and
            # optimistic iteration verifies its upper bound
            b = solve(sys, aux, cap=np.inf, ec=EndComponents.NONE)
            bound[sys.states] = b.upper
            iterations += b.iterations
        out.append(bound)
    return -out[1], out[0], iterations


def _widen(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward rounding. As in :mod:`posgmc.engines.iteration` by a relative 1e-10, plus 1e-10 of
    the largest finite bound: with rewards of both signs a value near 0 can be a difference of
    large terms, whose rounding error scales with the terms, not with the value."""
    finite = np.concatenate([lower[np.isfinite(lower)], upper[np.isfinite(upper)]])
    scale = float(np.max(np.abs(finite), initial=0.0))
    lo_slack = np.where(np.isfinite(lower), 1e-10 * (np.abs(lower) + scale), 0.0)
    hi_slack = np.where(np.isfinite(upper), 1e-10 * (np.abs(upper) + scale), 0.0)
    return lower - lo_slack, upper + hi_slack


def solve_proper(
    sys: System, options: SolverOptions, *, lower: np.ndarray, upper: np.ndarray
) -> Bounds:
    """Interval value iteration on a system whose profiles are all proper (module docstring).

    Args:
        sys: the system (constants of any sign; every profile must leave it almost surely).
        options: precision (absolute or relative), iteration cap.
        lower, upper: float64[n] (local order): proven bounds ``lower <= V* <= upper`` to start
            from, e.g. from :func:`start_bounds`.

    Returns:
        :class:`Bounds` in local order; ``converged`` False when the iteration cap was hit or the
        gap stopped shrinking (floating-point limit); the bounds are proven either way.
    """
    n = sys.n
    if n == 0:
        empty = np.zeros(0)
        return Bounds(empty, empty.copy(), 0, True, True)
    prec, rel = options.precision, options.relative
    lo = np.array(lower, dtype=np.float64)
    hi = np.array(upper, dtype=np.float64)
    iterations = 0
    converged = gap_ok(lo, hi, prec, rel)
    last_gap = np.inf
    while not converged and iterations < options.max_iterations:
        # every iterate of a monotone map started below (above) V* stays below (above) it; two
        # one-vector products are faster than one two-column product with scipy's kernels
        np.maximum(lo, bellman(sys, lo), out=lo)
        np.minimum(hi, bellman(sys, hi), out=hi)
        iterations += 1
        converged = gap_ok(lo, hi, prec, rel)
        if iterations % 1000 == 0:
            gap = float(np.max(hi - lo))
            if gap >= last_gap * (1.0 - 1e-9):
                break  # rounding noise dominates: the bounds stay proven, converged stays False
            last_gap = gap
    lo, hi = _widen(lo, hi)
    return Bounds(lo, hi, iterations, converged, True)


def value_iteration(sys: System, options: SolverOptions) -> Bounds:
    """Plain value iteration from 0 with the usual (unsound) stopping rule: two successive iterates
    closer than the precision. It converges because every profile is proper.

    Returns:
        :class:`Bounds` with ``lower = upper`` and ``sound = False``.
    """
    n = sys.n
    x = np.zeros(n)
    iterations = 0
    converged = n == 0
    while not converged and iterations < options.max_iterations:
        nxt = bellman(sys, x)
        iterations += 1
        converged = max_change(nxt, x, options.relative) <= options.precision
        x = nxt
    return Bounds(x, x.copy(), iterations, converged, False)
