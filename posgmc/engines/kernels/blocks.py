"""Compiled Gauss-Seidel sweeps over the blocks of a whole :class:`~posgmc.engines.system.System`
(the large systems that are not solved component by component, e.g. one giant SCC).

The same arithmetic as the numpy path of :mod:`posgmc.engines.iteration`, without its Python
loop over blocks and slots: a row's value is ``offset[r]`` plus its entries ``A[r, t] x[t]`` in
entry order (scipy's ``csr_matvec`` order), a state's optimum is taken over its slot entries in
slot order, so both paths compute the same floating-point values step for step. Unlike the
numpy path, no row values are stored: the rows are read in their order (a block's rows are its
slot entries' rows, one entry after the other) and each value goes straight into its state's
optimum, which spares a write and a read of an [m] (or [m, 2]) buffer per sweep (the lower sweep
gains less: its scattered reads of ``x`` bound it).

``plan``: uint64[B, 6], per block ``(row_lo, row_hi, max_lo, a, min_lo, b)``; ``slots``:
uint64[E, 6] and ``blocks``: uint64[B + 1] as in :class:`~posgmc.engines.system.System`
(``System.sweep_tables``).
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled

_U = np.uintp
"""Indices are cast to unsigned in the hot loops: numba then skips its negative-index wraparound
branch on every access (indices here are never negative)."""


def _sweep_lower(
    indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, offset: np.ndarray,
    plan: np.ndarray, slots: np.ndarray, blocks: np.ndarray, x: np.ndarray, tmp: np.ndarray,
    inner: int, quarter_tau: float, relative: bool,
) -> float:
    """One sweep of ``_lower_phase_blocks``: block by block, up to ``inner`` updates of the
    block's states (``x[s] = max(x[s], B(x)(s))``) until its change is at most ``quarter_tau``.
    Returns the largest first-update change of a block (relative with ``relative``)."""
    d = 0.0
    for bi in range(plan.shape[0]):
        ml, a, nl, b = plan[bi, 2], plan[bi, 3], plan[bi, 4], plan[bi, 5]
        for k in range(inner):
            # each slot entry's rows in row order (the block's rows are its entries' rows, in
            # order), every row value taken into its state's optimum as soon as it is computed
            for ei in range(blocks[bi], blocks[bi + 1]):
                rs, eml, ea, enl, eb, j = slots[ei, 0], slots[ei, 1], slots[ei, 2], \
                    slots[ei, 3], slots[ei, 4], slots[ei, 5]
                for i in range(ea + eb):
                    r = rs + i
                    acc = offset[r]
                    for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                        acc += data[e] * x[_U(indices[e])]
                    if i < ea:
                        s = eml + i
                        if j == 0 or acc > tmp[s]:
                            tmp[s] = acc
                    else:
                        s = enl + i - ea
                        if j == 0 or acc < tmp[s]:
                            tmp[s] = acc
            dk = 0.0
            for lo, cnt in ((ml, a), (nl, b)):
                for s in range(lo, lo + cnt):
                    old = x[s]
                    new = tmp[s] if tmp[s] > old else old
                    change = new - old
                    if relative:
                        change = abs(change)
                        scale = abs(new)
                        if scale > 0.0:
                            change = change / scale
                    if change > dk:
                        dk = change
                    x[s] = new
            if k == 0 and dk > d:
                d = dk
            if dk <= quarter_tau:
                break
    return d


sweep_lower = compiled(_sweep_lower)


def _sweep_pair(
    indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, offset: np.ndarray,
    offset_upper: np.ndarray, plan: np.ndarray, slots: np.ndarray, blocks: np.ndarray,
    X: np.ndarray, Xn: np.ndarray, T: np.ndarray,
) -> None:
    """One sweep of both columns of ``X`` [n, 2] into ``Xn`` (``iteration._sweep_pair``): the
    rows of a block against ``Xn`` (earlier blocks already updated), each state the optimum of
    its rows; the lower column reads ``offset``, the upper one ``offset_upper``."""
    n = X.shape[0]
    for s in range(n):
        Xn[s, 0] = X[s, 0]
        Xn[s, 1] = X[s, 1]
    for bi in range(plan.shape[0]):
        ml, a, nl, b = plan[bi, 2], plan[bi, 3], plan[bi, 4], plan[bi, 5]
        for ei in range(blocks[bi], blocks[bi + 1]):
            rs, eml, ea, enl, eb, j = slots[ei, 0], slots[ei, 1], slots[ei, 2], slots[ei, 3], \
                slots[ei, 4], slots[ei, 5]
            for i in range(ea + eb):
                r = rs + i
                acc0 = offset[r]
                acc1 = offset_upper[r]
                for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                    t = _U(indices[e])
                    acc0 += data[e] * Xn[t, 0]
                    acc1 += data[e] * Xn[t, 1]
                if i < ea:
                    s = eml + i
                    if j == 0 or acc0 > T[s, 0]:
                        T[s, 0] = acc0
                    if j == 0 or acc1 > T[s, 1]:
                        T[s, 1] = acc1
                else:
                    s = enl + i - ea
                    if j == 0 or acc0 < T[s, 0]:
                        T[s, 0] = acc0
                    if j == 0 or acc1 < T[s, 1]:
                        T[s, 1] = acc1
        for lo, cnt in ((ml, a), (nl, b)):
            for s in range(lo, lo + cnt):
                Xn[s, 0] = T[s, 0]
                Xn[s, 1] = T[s, 1]


sweep_pair = compiled(_sweep_pair)
