"""Topological (SCC-ordered) sound solving: the bands of a topological :class:`System` one after
the other, each against the proven bounds of the bands below it.

A system laid out with ``topological=True`` (:func:`posgmc.engines.system.build_system`,
:mod:`posgmc.engines.scc`) carries ``bands``: unions of whole strongly connected components in
reverse topological order, so that the rows of band k only reach states of bands ``<= k``. Band
k is solved as a system of its own (:func:`_band`): its entries into lower bands become constants,
``b_lo[r] = b[r] + sum_t A[r, t] lower[t]`` and ``b_hi[r] = b[r] + sum_t A[r, t] upper[t]``, and
:func:`posgmc.engines.iteration.solve` runs the lower iteration with ``b_lo`` and the upper one
with ``b_hi`` (``System.offset_upper``). Python loops over the bands (about
:data:`~posgmc.engines.scc.DEFAULT_BANDS`), never over components: all components of a band are
iterated together, vectorised, Gauss-Seidel over the band's blocks.

Soundness. Let v be the least fixpoint of the whole system (the value) and assume
``lower <= v <= upper`` on the bands below k (induction; nothing below band 0). Restricted to band
k, v is the least fixpoint of the band's operator with the constants ``b + A_out v`` (the values
below are fixed, and the least fixpoint of the whole restricts to the least fixpoint of the band
given the rest, because band k's states do not reach back into it from below). The band operator
is monotone in its constants, so its least fixpoint with ``b_lo`` is ``<= v`` and its least
fixpoint with ``b_hi`` is ``>= v`` on band k. :func:`solve`'s lower bound is below the first
(value iteration from 0), its upper bound above the second (Park induction on the upper problem,
with the deflation or inflation arguments of :mod:`posgmc.engines.iteration`, which hold for
every constant vector); so band k's bounds enclose v, and the induction goes on. The end-component
treatments apply unchanged: end components never cross an SCC boundary.

**Self-loops** are eliminated per row before solving: a row ``x_s = c + p x_s`` with
``0 < p < 1`` becomes ``x_s = c / (1 - p)``. For the least fixpoint this is exact, for max and for
min states alike: with ``f_r(x) = c_r + p_r x_s`` and ``g_r = c_r / (1 - p_r)``, every fixpoint
of one operator is a pre-fixpoint of the other (``x_s >= f_r(x) <=> x_s >= g_r(x)`` for max;
``x_s = f_{r*}(x) <=> x_s = g_{r*}(x)`` for the optimal row of a min state), so the two least
fixpoints coincide by Park induction both ways. Rows with ``p`` within 1e-9 of 1 are left alone.
A trivial SCC (one state) is thereby solved in one step: its rows only read the bands below.

**Precision.** With absolute precision ``eps`` and K bands, band k is asked for the half-width
``G/2 + eps/K``, G the largest gap ``upper - lower`` among the states its rows read below: the
gap of the band's exact pair of fixpoints is at most G (its values are sub-convex combinations of
those below plus common constants), so the target is reachable, and along any chain of bands the
gaps add at most ``2 eps / K`` per band: every final gap is at most ``2 eps``. The relative mode
works the same with ``R = max (upper - lower) / (|upper| + |lower|)`` in place of ``G/2``.

A band that does not converge (iteration cap, stalled gap), reads a state that is not solved yet
(the order is wrong) or an infinite upper bound makes :func:`solve_topological` return None; the
caller then solves the whole system at once (sound either way).

**Compiled path** (:mod:`posgmc.engines.kernels.sweeps`, when the kernels are enabled, the system
carries its component labels and no game end-component treatment is needed: ``ec`` NONE, or
DEFLATE with one player). The same induction, with every strongly connected component its own
band: the components are solved in label order (successors first) inside one compiled loop, so
nothing is paid per component in Python. A component of one state without a self-loop too likely
to eliminate is solved in closed form (the eliminated rows only read solved states: one Bellman
step with the lower bounds below and one with the upper ones is the exact pair of fixpoints).
Any other component gets the interval iteration of :mod:`posgmc.engines.iteration` on its own
states, the same operators: value iteration from 0 for the lower bound (Gauss-Seidel inside the
component: every value written is B of a vector below the least fixpoint), a guess
``lower + G + eps/K`` and Jacobi steps of the upper bound until ``F(U) <= U`` (Park induction),
then ``F`` iterated until the gap meets the precision. Deflation uses the component itself as
the set T of the iteration module's argument: a one-player maximiser needs no condition on T
beyond "internal rows stay in T with b = 0" (there are no minimiser states), every other row
counts as an exit, and the components are disjoint, so ``F = D o B`` has the least fixpoint of
``B``. This cap is coarser than the maximal end components' when a component holds more than
one; a component whose upper bound then does not converge makes the compiled path give up
(None) and the bands above solve the system. Precision: K is the number of iterated components
on the longest path of the condensation (closed-form components add no gap beyond what they
read), so the gaps along any path add up to at most ``2 eps``. Rounding: every component adds
a few ulps to what it reads; the final widening is a relative ``max(1e-10, 64 ulp x L)``, L the
number of components on the longest path.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from posgmc.engines import scc
from posgmc.engines.iteration import _NOISE, _ROUNDING, Bounds, EndComponents, solve, widen
from posgmc.engines.options import SolverOptions
from posgmc.engines.system import Block, System

__all__ = ["solve_topological"]

_INNER = 32
"""Updates of a block in a row (``solve(inner=...)``): a block of a band holds a few small SCCs in
order, which then converge before the blocks after them read them."""

_SELF_LOOP_LIMIT = 1.0 - 1e-9
"""Self-loops at least this likely are not eliminated (dividing by 1 - p would amplify rounding)."""


def solve_topological(
    sys: System, options: SolverOptions, *, cap: float, ec: EndComponents
) -> Bounds | None:
    """Bounds on the least fixpoint of a topologically laid out system, band by band (see the
    module docstring), or None if a band cannot be solved on its own.

    Args:
        sys: a system with ``bands``.
        options: as for :func:`posgmc.engines.iteration.solve` (interval methods only).
        cap: an a-priori upper bound on every value.
        ec: the end-component treatment.

    Returns:
        :class:`Bounds` in local order, or None.
    """
    if sys.bands is None:
        return None
    if scc.compiled_at(sys.n) and _compiled_applies(sys, ec):
        found = _solve_components(sys, options, cap=cap, ec=ec)
        if found is not None:
            return found
    n = sys.n
    bands = sys.bands
    num_bands = int(bands.size - 1)
    lower = np.zeros(n)
    upper = np.full(n, cap, dtype=np.float64)
    solved = np.zeros(n, dtype=bool)
    plan = sys.plan
    iters = 0
    ecs = False
    share = options.precision / num_bands
    for k in range(num_bands):
        band = _band(sys, plan, int(bands[k]), int(bands[k + 1]), lower, upper, solved)
        if band is None:
            return None
        sub, reads = band
        gap = upper[reads] - lower[reads]
        if reads.size and not np.all(np.isfinite(gap)):
            return None
        if options.relative:
            scale = np.abs(upper[reads]) + np.abs(lower[reads])
            with np.errstate(divide="ignore", invalid="ignore"):
                inherited = float(np.max(np.where(scale > 0, gap / scale, 0.0), initial=0.0))
        else:
            inherited = float(np.max(gap, initial=0.0)) / 2.0
        budget = options.max_iterations - iters
        if budget < 1:
            return None
        opts = replace(
            options,
            precision=inherited + share,
            max_iterations=budget,
            want_strategy=False,
            initial_strategy=None,
        )
        res = solve(sub, opts, cap=cap, ec=ec, inner=_INNER, spread=inherited)
        iters += res.iterations
        if not res.converged:
            return None
        ecs = ecs or res.end_components
        ml0, ml1, nl0, nl1 = _state_ranges(plan, int(bands[k]), int(bands[k + 1]))
        na = ml1 - ml0
        lower[ml0:ml1] = res.lower[:na]
        lower[nl0:nl1] = res.lower[na:]
        upper[ml0:ml1] = res.upper[:na]
        upper[nl0:nl1] = res.upper[na:]
        solved[ml0:ml1] = True
        solved[nl0:nl1] = True
    return Bounds(lower, upper, iters, True, True, ecs)


def _state_ranges(plan: tuple[Block, ...], b0: int, b1: int) -> tuple[int, int, int, int]:
    """The maximising states ``[ml0, ml1)`` and minimising states ``[nl0, nl1)`` of blocks
    ``b0:b1`` (contiguous: states are ordered by player, then block)."""
    first, last = plan[b0], plan[b1 - 1]
    return first[2], last[2] + last[3], first[4], last[4] + last[5]


def _band(
    sys: System,
    plan: tuple[Block, ...],
    b0: int,
    b1: int,
    lower: np.ndarray,
    upper: np.ndarray,
    solved: np.ndarray,
) -> tuple[System, np.ndarray] | None:
    """The system of blocks ``b0:b1`` against the bounds below, self-loops eliminated, and the
    (local) states its rows read below; None if a row reads a state that is not solved."""
    r0, r1 = plan[b0][0], plan[b1 - 1][1]
    ml0, ml1, nl0, nl1 = _state_ranges(plan, b0, b1)
    na = ml1 - ml0
    nloc = na + (nl1 - nl0)
    m = r1 - r0
    A = sys.matrix
    p0, p1 = int(A.indptr[r0]), int(A.indptr[r1])
    cols = A.indices[p0:p1]
    data = A.data[p0:p1]
    lengths = np.diff(A.indptr[r0 : r1 + 1])
    er = np.repeat(np.arange(m, dtype=np.int64), lengths)
    in_max = (cols >= ml0) & (cols < ml1)
    in_min = (cols >= nl0) & (cols < nl1)
    inside = in_max | in_min
    out = ~inside
    out_cols = cols[out]
    if not solved[out_cols].all():
        return None
    local = np.where(in_max, cols - ml0, cols - nl0 + na)
    rs = sys.row_state[r0:r1]
    rs_local = np.where(rs < sys.num_max, rs - ml0, rs - nl0 + na)
    er_out = er[out]
    d_out = data[out]
    offset_lo = sys.offset[r0:r1] + np.bincount(er_out, d_out * lower[out_cols], minlength=m)
    with np.errstate(invalid="ignore"):
        offset_hi = sys.offset[r0:r1] + np.bincount(er_out, d_out * upper[out_cols], minlength=m)
    stays = sys.stays[r0:r1] & (np.bincount(er_out, minlength=m) == 0)
    # self-loop elimination (see the module docstring)
    diag = inside & (local == rs_local[er])
    p_self = np.bincount(er[diag], data[diag], minlength=m)
    elim = (p_self > 0) & (p_self < _SELF_LOOP_LIMIT)
    keep = inside & ~(diag & elim[er])
    if elim.any():
        scale = np.where(elim, 1.0 / np.where(elim, 1.0 - p_self, 1.0), 1.0)
        new_data = data[keep] * scale[er[keep]]
        offset_lo *= scale
        offset_hi *= scale
    else:
        new_data = data[keep]
    idx_dtype = A.indices.dtype
    indptr = np.zeros(m + 1, dtype=idx_dtype)
    np.cumsum(np.bincount(er[keep], minlength=m), out=indptr[1:])
    matrix = sp.csr_matrix(
        (new_data, local[keep].astype(idx_dtype, copy=False), indptr), shape=(m, nloc)
    )
    slots = sys.slots[int(sys.blocks[b0]) : int(sys.blocks[b1])].copy()
    slots[:, 0] -= r0
    slots[:, 1] -= ml0
    slots[:, 3] += na - nl0
    blocks = sys.blocks[b0 : b1 + 1] - sys.blocks[b0]
    band = System(
        states=np.concatenate([sys.states[ml0:ml1], sys.states[nl0:nl1]]),
        rows=sys.rows[r0:r1],
        row_state=rs_local,
        matrix=matrix,
        offset=offset_lo,
        stays=stays,
        num_max=na,
        slots=slots,
        blocks=blocks,
        offset_upper=offset_hi,
    )
    return band, out_cols


_CHUNKS = 32
"""Kernel calls of :func:`_solve_components` (the deadline is looked at between two)."""


def _compiled_applies(sys: System, ec: EndComponents) -> bool:
    """The compiled solver covers the system: no end-component treatment, or deflation in a
    one-player system (a game's deflation depends on the minimiser's optimal rows, and inflation
    on the minimiser's end components: those stay with the band solver)."""
    if sys.labels is None or sys.n == 0 or max(sys.m, sys.matrix.nnz) >= 2**31 - 1:
        return False  # (the kernel's index arrays are int32)
    if ec is EndComponents.NONE:
        return True
    return ec is EndComponents.DEFLATE and sys.num_max in (0, sys.n)


def _solve_components(
    sys: System, options: SolverOptions, *, cap: float, ec: EndComponents
) -> Bounds | None:
    """Component by component in compiled code (see the module docstring), or None if a
    component does not converge, the order is wrong or the deadline passes. ``iterations`` of the
    result is the most sweeps one component took (closed-form components take none)."""
    from posgmc.engines.kernels import sweeps

    assert sys.labels is not None  # noqa: S101 - checked by _compiled_applies
    A = sys.matrix
    n = sys.n
    row_ptr, row_list, order, comp_ptr, comp_of, iterate, chain, levels, ok = sweeps.prepare(
        n, sys.row_state, sys.labels, A.indptr, A.indices, A.data, _SELF_LOOP_LIMIT
    )
    if not ok:
        return None
    lower = np.zeros(n)
    upper = np.full(n, cap, dtype=np.float64)
    scratch = np.empty((int(np.diff(comp_ptr).max()), 2))
    share = options.precision / int(chain)
    deflate = ec is EndComponents.DEFLATE and sys.num_max == n
    num = int(comp_ptr.size - 1)
    # chunks of about n / _CHUNKS states, cut at component boundaries
    cuts = np.unique(np.searchsorted(comp_ptr, np.linspace(0, n, _CHUNKS + 1)[1:-1]))
    bounds_at = [0, *(int(c) for c in cuts if 0 < c < num), num]
    most = 0
    internal = False
    for c0, c1 in zip(bounds_at[:-1], bounds_at[1:]):
        if options.deadline is not None and time.perf_counter() > options.deadline:
            return None
        status, iters, found = sweeps.solve_range(
            c0, c1, sys.num_max, A.indptr, A.indices, A.data, sys.offset, sys.stays,
            row_ptr, row_list, order, comp_ptr, comp_of, iterate, lower, upper, scratch,
            float(cap), deflate, share, options.relative, options.max_iterations,
            _SELF_LOOP_LIMIT, _NOISE, _ROUNDING,
        )
        if status != sweeps.OK:
            return None
        most = max(most, int(iters))
        internal = internal or bool(found)
    # rounding: a few ulps per component on the longest path (see the module docstring)
    lower, upper = widen(lower, upper, relative=max(1e-10, 64 * _EPS * int(levels)))
    return Bounds(lower, np.minimum(upper, cap), most, True, True, internal)


_EPS = float(np.finfo(np.float64).eps)
