"""Proven bounds around a policy-iteration solution: a-posteriori certificates for least fixpoints.

Policy iteration (:mod:`posgmc.engines.policy_iteration`) ends with a float vector ``x`` and a
profile ``sigma`` (one row per unknown state) from sparse LU solves. ``x`` is accurate, but a float
solve proves nothing, and value iteration from below (the lower half of interval iteration) crawls
on *stiff* systems: a randomised strategy that leaves a loop with probability 1e-4 needs about 10^4
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
rows it maximises over (checked on the vector itself, rounding included, and repaired where the
count from policy iteration falls short: :func:`_max_steps`), so ``A_r (x + d t) + b_r <= x + d t``
wherever ``A_r x + b_r <= x + d``; ``d_u`` (``d_l``) is the largest violation of ``x`` itself,
enlarged a little. ``t_u`` is the same count with the minimiser fixed to ``sigma`` and the maximiser
maximising it. The inequalities are then *evaluated* on the vectors, and whatever they miss by
(rounding), ``tau``, is added once more along the count: since ``t >= 1 + A_r t`` on every row the
count maximises over, ``u + tau t_u`` is a pre-fixpoint when ``B(u) <= u + tau`` (and likewise
below). No tolerance is accepted without this amplification: a slack taken alone would be unsound
under a slow contraction (the reason interval iteration's check allows only a few ulps). The caller
widens the bounds as it widens iterated ones: proven up to floating-point error, like every
float-based checker's.

*Exact, for tiny systems.* Along a count of 10^13 steps (a loop left with probability 1e-13)
no float residual is small enough. With at most :data:`_EXACT_LIMIT` unknowns the certificate is
redone in rational arithmetic on the floats as stored: with the maximiser on ``sigma`` the
minimiser's exact best response (a few rounds of strict switches; every solve nonsingular since
``t_l`` is finite) gives values ``q`` that satisfy both inequalities above with ``d = tau = 0``
when no maximiser row beats them, so ``q`` is the least fixpoint itself; its bounds are ``q``
rounded outwards.

*Input rounding.* The stored floats are the written model rounded (``1 - p`` with p = 1e-13
keeps three digits of the exit probability ``p``): each probability and constant within
:data:`_INPUT` of its own size. Perturbing a row by ``dA_r``, ``db_r`` moves the fixpoint by at
most the count times ``max_r |dA_r x + db_r| <= _INPUT (max|x| + max|b|)``, negligible for
modest counts and decisive for huge ones: both certificates widen by it along ``t_u`` / ``t_l``,
so the bounds hold for the model as written, not only as stored (rare.nm's value 1, where the
stored model's is 0.99969). The exact certificate is returned however wide that makes it: no
method on the stored floats could prove more about the written model.

Where a certificate cannot be had (an infinite count: end components of either player; infinite
values; a gap above the requested precision), :func:`certify` returns None and the caller solves
by interval iteration instead.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from posgmc.engines import policy_iteration as ex
from posgmc.engines.rational import solve_dense
from posgmc.engines.system import System, argopt_rows, choice_values, reduce_rows

__all__ = ["certify"]

_EPS = float(np.finfo(np.float64).eps)

_ULPS = 8 * _EPS
"""A few ulps (relative): room left above x for rounding, and the rounding allowance of a check."""


_INPUT = 4 * float(np.finfo(np.float64).eps)
"""Relative rounding of a stored probability or constant against the written model's."""

_STEP_REPAIRS = 4
"""Restarts of policy iteration when its count is beaten on some row (:func:`_max_steps`)."""

_EXACT_LIMIT = 24
"""Up to this many unknowns a float certificate that is too wide is redone in exact arithmetic
(dense Gauss-Jordan over fractions with 53-bit denominators: cubic, with growing integers)."""

_EXACT_ROUNDS = 8
"""Rounds of exact strategy switches before the exact certificate gives up."""

_POLISH_ROUNDS = 4
"""Rounds of ulp-level strategy switches (:func:`_polished`) before a float certificate that is
too wide is given up."""


def _outward(q: list[Fraction]) -> tuple[np.ndarray, np.ndarray]:
    """The nearest floats below and above each rational."""
    mid = np.array([float(v) for v in q])
    lower = np.array([f if Fraction(f) <= v else np.nextafter(f, -np.inf) for f, v in zip(mid, q)])
    upper = np.array([f if Fraction(f) >= v else np.nextafter(f, np.inf) for f, v in zip(mid, q)])
    return lower, upper


def _input_allowance(sys: System, x: np.ndarray) -> float:
    """A bound on how far one Bellman step moves when every input moves by its rounding."""
    scale = float(np.max(np.abs(x), initial=0.0)) + float(np.max(np.abs(sys.offset), initial=0.0))
    return _INPUT * scale


def _exact_certificate(sys: System, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The exact least fixpoint of a tiny system, rounded outwards, or None (module docstring).

    The maximiser keeps ``sigma``, whose count ``t_l`` the caller proved finite: every minimiser
    profile against it leaves the unknowns, so each solve is nonsingular, and the minimiser's
    exact best response (strict switches) makes ``q`` the least fixpoint of ``B'``: a lower
    bound. If then no maximiser row beats ``q`` either, ``B(q) <= q``: an upper bound too."""
    n, k = sys.n, sys.num_max
    csr = sys.matrix.tocsr()
    rows = [
        (Fraction(float(sys.offset[r])),
         {int(c): Fraction(float(v)) for c, v in zip(csr.indices[csr.indptr[r]:csr.indptr[r + 1]],
                                                     csr.data[csr.indptr[r]:csr.indptr[r + 1]])})
        for r in range(sys.m)
    ]
    owner = [int(s) for s in sys.row_state]
    choice = [int(r) for r in sigma]

    def value(r: int, q: list[Fraction]) -> Fraction:
        b, out = rows[r]
        return b + sum((p * q[t] for t, p in out.items()), Fraction(0))

    for _ in range(_EXACT_ROUNDS):
        a = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]  # I - A_sigma
        for s, r in enumerate(choice):
            for t, p in rows[r][1].items():
                a[s][t] -= p
        q = solve_dense(a, [rows[r][0] for r in choice])
        better = [r for r in range(sys.m) if owner[r] >= k and value(r, q) < q[owner[r]]]
        if better:  # the minimiser improves: switch and solve again
            for r in better:
                choice[owner[r]] = r
            continue
        if any(value(r, q) > q[owner[r]] for r in range(sys.m) if owner[r] < k):
            return None  # sigma is not exactly optimal for the maximiser
        return _outward(q)
    return None


def _max_steps(gr: ex.Grouped, keep: np.ndarray) -> np.ndarray:
    """float64[n]: a count ``t >= 1 + A_r t`` on every row ``keep`` (every state keeps at least
    one), as the certificate needs it: the largest expected number of steps inside the unknowns
    over the strategies that use only those rows; inf where unbounded, or where no such count
    could be had.

    Policy iteration gives the largest count only up to its switching rules: on a stiff chain
    (counts of millions) a switch it puts down to the solves' rounding can be a real one, and
    then some kept row beats the count by far more than rounding (by 1.5 million steps on a
    count of 6 million, dodge-6-lines under a runner that exits with probability 1e-6). The
    inequality is therefore checked on the count returned, and policy iteration restarted from
    the rows that beat it (:data:`_STEP_REPAIRS` times at most); a violation below 1/2 that is
    left (rounding) is absorbed by scaling the count up, since ``t - A_r t >= 1 - v`` on every
    row gives ``t / (1 - v) - A_r t / (1 - v) >= 1``."""
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
    start = steps.row_groups[:-1].copy()
    for _ in range(_STEP_REPAIRS):
        t, rows, _ = ex.policy_iteration(steps, start, outer_max=True, idle_min=False,
                                         unbounded=True)
        if not np.all(np.isfinite(t)):
            return t
        y = steps.offset + steps.matrix @ t  # 1 + A_r t per kept row
        over = y - t[steps.row_state]
        # what rounding may hide in y and in the difference: a sum of k terms is off by at most
        # k ulps of the sum of their sizes (doubled, for the sizes' own rounding)
        terms = np.diff(steps.matrix.indptr) + 2.0
        size = np.abs(steps.matrix) @ np.abs(t) + 1.0 + np.abs(t[steps.row_state])
        slack = 2.0 * terms * _EPS * size
        v = float(np.max(over + slack, initial=0.0))
        if v <= 0.0:
            return t
        if v < 0.5:
            return t / (1.0 - v) * (1.0 + _ULPS)
        # restart from each state's row that beats the count most (policy iteration keeps the
        # current row on ties, so a state without a violation keeps its own)
        score = np.where(over > slack, over, -np.inf)
        top = np.maximum.reduceat(score, steps.row_groups[:-1])
        winners = np.flatnonzero((score == top[steps.row_state]) & np.isfinite(score))
        states, first = np.unique(steps.row_state[winners], return_index=True)
        start = rows.copy()
        start[states] = winners[first]
    return np.full(gr.n, np.inf)


def _float_certificate(
    sys: System, gr: ex.Grouped, x: np.ndarray, sigma: np.ndarray, *, cap: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The float certificate around ``x`` (module docstring): ``(lower, upper, t_low, t_up)``,
    or None when a count is infinite (end components)."""
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
    allow = _input_allowance(sys, x)
    upper = x + (d_up + allow) * t_up
    lower = x - (d_low + allow) * t_low

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
    return lower, upper, t_low, t_up


def _polished(
    sys: System, gr: ex.Grouped, x: np.ndarray, sigma: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """One round of strict improvements of ``sigma`` at the ulp level and the new profile's values,
    or None when no row improves on ``x`` by more than a few ulps (or the values are not finite).

    Policy iteration switches only for a gain above 1e-10 (relative), which keeps it from cycling
    on rounding noise; the certificate multiplies what is left by the expected number of steps,
    so on a stiff system (a count of 1e5 steps: a randomised strategy that leaves a loop with
    probability 1e-5) a leftover gain of 1e-10 widens the bounds to 1e-5. Each player moves to
    its best row wherever that beats the current row by more than a few ulps of the values."""
    y = choice_values(sys, x)
    best = argopt_rows(sys, y)
    sign = np.where(sys.row_maximize[sigma], 1.0, -1.0)
    scale = float(np.max(np.abs(x), initial=1.0))
    switch = sign * (y[best] - y[sigma]) > _ULPS * scale
    if not switch.any():
        return None
    rows = np.where(switch, best, sigma)
    inv = np.empty(sys.m, dtype=np.int64)  # local rows -> grouped rows
    inv[gr.source] = np.arange(gr.source.size)
    values = ex.evaluate(gr, inv[rows])
    if not np.all(np.isfinite(values)):
        return None
    return values, rows


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

    A float certificate wider than the precision is tried again after up to
    :data:`_POLISH_ROUNDS` rounds of ulp-level strict improvements of ``sigma``
    (:func:`_polished`); the bounds of every round are proven, and the narrowest count.

    Args:
        sys: the system (least-fixpoint objective: no inflation of the minimiser's end
            components; the caller does not call this for "infinite unless reached" rewards).
        x: float64[n], the values of the profile ``sigma``.
        sigma: int64[n], the profile's row per state (local row indices of ``sys``).
        cap: an a-priori upper bound on every value (1 for probabilities, inf if none).
        precision, relative: the requested half-width; a wider float certificate returns None
            (interval iteration may do better), an exact one is returned however wide (its
            width is the input rounding along the counts: see the module docstring).
    """
    n = sys.n
    if n == 0:
        return np.zeros(0), np.zeros(0)
    if not np.all(np.isfinite(x)):
        return None
    gr = ex.grouped(sys)
    found = _float_certificate(sys, gr, x, sigma, cap=cap)
    if found is None:
        return None
    lower, upper, t_low, t_up = found
    for _ in range(_POLISH_ROUNDS):
        if _narrow(lower, upper, precision, relative):
            return lower, upper
        step = _polished(sys, gr, x, sigma)
        if step is None:
            break
        x, sigma = step
        again = _float_certificate(sys, gr, x, sigma, cap=cap)
        if again is None:
            break
        # both are proven: keep the tighter of each side
        lower, upper = np.maximum(lower, again[0]), np.minimum(upper, again[1])
        t_low, t_up = again[2], again[3]
    if _narrow(lower, upper, precision, relative):
        return lower, upper
    if n <= _EXACT_LIMIT and sys.offset_upper is None:
        exact = _exact_certificate(sys, sigma)
        if exact is not None:
            allow = _input_allowance(sys, exact[1])
            low = exact[0] - allow * t_low
            return (np.maximum(low, 0.0) if np.all(sys.offset >= 0) else low,
                    np.minimum(exact[1] + allow * t_up, cap))
    return None


def _narrow(lower: np.ndarray, upper: np.ndarray, precision: float, relative: bool) -> bool:
    """Whether the certificate meets the requested half-width."""
    half = 0.5 * (upper - lower)
    limit = precision * 0.5 * (np.abs(upper) + np.abs(lower)) if relative else precision
    return not bool(np.any(half > limit))
