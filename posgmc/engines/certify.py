"""Proven bounds around a policy-iteration solution: a-posteriori certificates for least fixpoints.

Policy iteration (:mod:`posgmc.engines.exact`) ends with a float vector ``x`` and a profile
``sigma`` (one row per unknown state) from sparse LU solves. ``x`` is accurate, but a float solve
proves nothing, and value iteration from below (the lower half of interval iteration) crawls on
*stiff* systems: a randomised strategy that leaves a loop with probability 1e-4 needs about 10^4
steps per digit. This module turns ``x`` into proven bounds with one or two more solves, for the
least fixpoint ``lfp B`` of the Bellman operator of a :class:`~posgmc.engines.iteration.System`
(``B(x)(s) = opt_r (b[r] + A[r] x)``, maximising states first)::

    upper: u = x + d_u t_u   where  B(u) <= u                          =>  u >= lfp B
    lower: l = x - d_l t_l   where  l <= b_sigma + A_sigma l  at maximising states,
                                    l <= B(l)                  at minimising states,
           and t_l finite                                              =>  l <= lfp B

*Upper* (Park induction, Knaster-Tarski): every pre-fixpoint of a monotone operator lies above
its least fixpoint, whatever the end components. *Lower*: let ``B'`` be ``B`` with the
maximiser's rows cut to ``sigma``; ``B' <= B`` pointwise, so ``lfp B' <= lfp B``. ``t_l`` is the
largest expected number of steps before the unknowns are left when the maximiser plays
``sigma`` and the minimiser maximises the count: finite exactly when no minimiser strategy stays
inside the unknowns forever against ``sigma``, i.e. ``B'`` has no end components. Then ``B'``
has a unique fixpoint and ``B'^k(y) -> lfp B'`` from every start, so a post-fixpoint
``l <= B'(l)`` gives ``l <= B'^k(l) -> lfp B' <= lfp B``.

The perturbations make the inequalities hold with room: ``t`` satisfies ``t >= 1 + A_r t`` on the
rows it maximises over, so ``A_r (x + d t) + b_r <= x + d t`` wherever ``A_r x + b_r <= x + d``;
``d_u`` (``d_l``) is the largest violation of ``x`` itself, enlarged a little. ``t_u`` is the
same count with the minimiser fixed to ``sigma`` and the maximiser maximising it (where that is
infinite, the count of the profile ``sigma`` itself: the upper bound needs no finiteness, only
its check). The
inequalities are then *checked* on the vectors (nothing rests on the choice of ``d``), with the
relative rounding noise :data:`~posgmc.engines.iteration._NOISE` that the iterative engine
tolerates too, and the caller widens the bounds as it widens iterated ones: proven up to
floating-point error, like every float-based checker's.

Where a certificate cannot be had (an infinite count: end components; infinite values; a gap
above the requested precision), :func:`certify` returns None and the caller solves by interval
iteration instead.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines import exact as ex
from posgmc.engines.iteration import _NOISE, System, choice_values, reduce_rows

__all__ = ["certify"]


def _max_steps(gr: ex.Grouped, keep: np.ndarray) -> np.ndarray:
    """float64[n]: the largest expected number of steps inside the unknowns over the strategies
    that use only the rows ``keep`` (every state keeps at least one); inf where unbounded."""
    sub = gr.restrict(keep)
    steps = ex.Grouped(
        matrix=sub.matrix,
        offset=np.ones(sub.source.size),
        stays=sub.stays,
        row_groups=sub.row_groups,
        row_state=sub.row_state,
        maximize=np.ones(sub.n, dtype=bool),
        source=sub.source,
    )
    t, _, _ = ex.policy_iteration(
        steps, steps.row_groups[:-1].copy(), outer_max=True, idle_min=False, unbounded=True
    )
    return t


def _lower_ok(sys: System, y: np.ndarray, sigma: np.ndarray, low: np.ndarray) -> bool:
    """``low <= b_sigma + A_sigma low`` at maximising states and ``low <= B(low)`` at minimising
    ones (up to rounding noise), with ``y`` the row values of ``low``."""
    k = sys.num_max
    slack = _NOISE * np.maximum(np.abs(low), 1.0)
    best = reduce_rows(sys, y)
    return bool(
        np.all(y[sigma[:k]] >= low[:k] - slack[:k]) and np.all(best[k:] >= low[k:] - slack[k:])
    )


def certify(
    sys: System,
    x: np.ndarray,
    sigma: np.ndarray,
    *,
    cap: float,
    precision: float,
    relative: bool,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Proven ``(lower, upper)`` around the policy-iteration values ``x`` of ``lfp B``, or None.

    Args:
        sys: the system (least-fixpoint objective: no inflation of the minimiser's end
            components; the caller does not call this for "infinite unless reached" rewards).
        x: float64[n], the values of the profile ``sigma``.
        sigma: int64[n], the profile's row per state (local row indices of ``sys``).
        cap: an a-priori upper bound on every value (1 for probabilities, inf if none).
        precision, relative: the requested half-width; a wider certificate returns None.
    """
    n = sys.n
    if n == 0:
        return np.zeros(0), np.zeros(0)
    if not np.all(np.isfinite(x)):
        return None
    gr = ex.grouped(sys)
    own = np.zeros(sys.m, dtype=bool)
    own[sigma] = True
    row_max = sys.row_maximize
    y = choice_values(sys, x)
    gap = y - x[sys.row_state]  # how far each row's value lies above x

    # upper: the maximiser free, the minimiser on sigma
    keep_up = np.zeros(sys.m, dtype=bool)
    keep_up[row_max | own] = True
    t_up = _max_steps(gr, keep_up[gr.source])
    if not np.all(np.isfinite(t_up)):
        # The maximiser has end components (it may stay forever): count the steps of the profile
        # itself. Staying rows then keep u's average, which often still passes the check below.
        t_up = _max_steps(gr, own[gr.source])
    # lower: the maximiser on sigma, the minimiser free
    keep_low = np.zeros(sys.m, dtype=bool)
    keep_low[~row_max | own] = True
    t_low = _max_steps(gr, keep_low[gr.source])
    if not (np.all(np.isfinite(t_up)) and np.all(np.isfinite(t_low))):
        return None

    scale = float(np.max(np.abs(x), initial=1.0))
    d_up = max(float(np.max(gap[keep_up], initial=0.0)), 0.0) * 1.01 + 1e-15 * scale
    d_low = max(float(np.max(-gap[keep_low], initial=0.0)), 0.0) * 1.01 + 1e-15 * scale
    upper = x + d_up * t_up
    lower = x - d_low * t_low
    if np.all(sys.offset >= 0):
        lower = np.maximum(lower, 0.0)  # lfp >= 0 when every constant is
    upper = np.minimum(upper, cap)  # lfp <= cap, and B(min(u, cap)) <= min(u, cap)

    # the checks that make them bounds
    noise = _NOISE * np.maximum(np.abs(upper), 1.0)
    if not np.all(reduce_rows(sys, choice_values(sys, upper)) <= upper + noise):
        return None
    if not _lower_ok(sys, choice_values(sys, lower), sigma, lower):
        return None
    half = 0.5 * (upper - lower)
    limit = precision * 0.5 * (np.abs(upper) + np.abs(lower)) if relative else precision
    if np.any(half > limit):
        return None
    return lower, upper
