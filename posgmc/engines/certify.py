"""Proven bounds around a policy-iteration solution: a-posteriori certificates for least fixpoints.

Policy iteration (:mod:`posgmc.engines.exact`) ends with a float vector ``x`` and a profile
``sigma`` (one row per unknown state) from sparse LU solves. ``x`` is accurate, but a float solve
proves nothing, and value iteration from below (the lower half of interval iteration) crawls on
*stiff* systems: a randomised strategy that leaves a loop with probability 1e-4 needs about 10^4
steps per digit. This module turns ``x`` into proven bounds with one or two more solves, for the
least fixpoint ``lfp B`` of the Bellman operator of a :class:`~posgmc.engines.system.System`
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
same count with the minimiser fixed to ``sigma`` and the maximiser maximising it. The
inequalities are then *evaluated* on the vectors, and whatever they miss by (rounding), ``tau``,
is added once more along the count: since ``t >= 1 + A_r t`` on every row the count maximises
over, ``u + tau t_u`` is a pre-fixpoint when ``B(u) <= u + tau`` (and likewise below). No
tolerance is accepted without this amplification: a slack taken alone would be unsound under a
slow contraction (the reason interval iteration's check allows only a few ulps). The caller
widens the bounds as it widens iterated ones: proven up to floating-point error, like every
float-based checker's.

Where a certificate cannot be had (an infinite count: end components of either player; infinite
values; a gap above the requested precision), :func:`certify` returns None and the caller solves
by interval iteration instead.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines import exact as ex
from posgmc.engines.system import System, choice_values, reduce_rows

__all__ = ["certify"]

_ULPS = 8 * float(np.finfo(np.float64).eps)
"""A few ulps (relative): room left above x for rounding, and the rounding allowance of a check."""


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
    keep_up = row_max | own  # the maximiser free, the minimiser on sigma
    keep_low = ~row_max | own  # the maximiser on sigma, the minimiser free
    t_up = _max_steps(gr, keep_up[gr.source])
    t_low = _max_steps(gr, keep_low[gr.source])
    if not (np.all(np.isfinite(t_up)) and np.all(np.isfinite(t_low))):
        return None  # end components: no count bounds every row (interval iteration instead)

    gap = choice_values(sys, x) - x[sys.row_state]  # how far each row's value lies above x
    scale = float(np.max(np.abs(x), initial=1.0))
    d_up = max(float(np.max(gap[keep_up], initial=0.0)), 0.0) * 1.01 + _ULPS * scale
    d_low = max(float(np.max(-gap[keep_low], initial=0.0)), 0.0) * 1.01 + _ULPS * scale
    upper = x + d_up * t_up
    lower = x - d_low * t_low

    # The checks that make them bounds. What rounding leaves of B(u) - u (resp. l - B'(l)),
    # tau, is absorbed by one more step along the counts: t >= 1 + A_r t on every row they
    # maximise over, so B(u + tau t) <= B(u) + tau (t - 1) <= u + tau t.
    y = choice_values(sys, upper)
    over = reduce_rows(sys, y) - upper
    tau = max(float(np.max(over, initial=0.0)), 0.0) + _ULPS * float(np.max(np.abs(upper)))
    upper = upper + tau * t_up
    y = choice_values(sys, lower)
    k = sys.num_max
    best = reduce_rows(sys, y)
    under = np.concatenate([lower[:k] - y[sigma[:k]], lower[k:] - best[k:]])
    tau = max(float(np.max(under, initial=0.0)), 0.0) + _ULPS * float(np.max(np.abs(lower)))
    lower = lower - tau * t_low
    if np.all(sys.offset >= 0):
        lower = np.maximum(lower, 0.0)  # lfp >= 0 when every constant is
    upper = np.minimum(upper, cap)  # lfp <= cap
    half = 0.5 * (upper - lower)
    limit = precision * 0.5 * (np.abs(upper) + np.abs(lower)) if relative else precision
    if np.any(half > limit):
        return None
    return lower, upper
