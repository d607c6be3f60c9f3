"""The fixpoint problem on the unknown states (:class:`System`), its memory layout and the
Bellman kernels every solver runs.

A :class:`System` is the part of a model left after graph precomputation: ``n`` unknown states,
``m`` rows (their usable choices), a sparse matrix ``A`` [m, n] and a constant ``b`` [m] per row,
so that the Bellman operator is::

    B(x)(s) = opt_{r in rows(s)} ( b[r] + sum_t A[r, t] x[t] ),   opt = max or min per state.

Performance: unknown states are renumbered maximisers first, then by block, then by decreasing
number of rows, and rows are stored by *block and slot* (slot j holds the j-th row of every state
of the block with more than j rows). A Bellman step is then one sparse matrix-vector product into a
preallocated buffer (scipy's ``csr_matvec`` kernel, falling back to ``A @ x``) and, per slot, one
contiguous ``np.maximum``/``np.minimum`` -- no ``reduceat``, no allocation.

Blocks (large systems only) group consecutive backward-search layers of the positive region;
:mod:`posgmc.engines.iteration` sweeps them Gauss-Seidel style.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from posgmc.engines import scc
from posgmc.engines.graph import Structure
from posgmc.engines.scc import topological_blocks

try:  # the C kernels behind ``A @ x``; they accumulate into a given output buffer
    from scipy.sparse import _sparsetools as _kernels

    HAVE_KERNELS = hasattr(_kernels, "csr_matvec") and hasattr(_kernels, "csr_matvecs")
except ImportError:  # pragma: no cover - depends on the scipy build
    _kernels = None
    HAVE_KERNELS = False
"""Whether scipy's accumulating kernels are available; the in-place solvers need them."""

__all__ = [
    "HAVE_KERNELS",
    "System",
    "accumulate_rows",
    "argopt_rows",
    "bellman",
    "build_system",
    "choice_values",
    "choose",
    "multiply_into",
    "reduce_entries",
    "reduce_into",
    "reduce_rows",
]


SlotEntry = tuple[int, int, int, int, int, int]
"""One row of the slot table, ``(row_lo, max_lo, a, min_lo, b, slot)`` (see
:attr:`System.slots`)."""

Block = tuple[int, int, int, int, int, int, tuple[SlotEntry, ...]]
"""One Gauss-Seidel block, ``(row_lo, row_hi, max_lo, a, min_lo, b, entries)``
(:attr:`System.plan`)."""


@dataclass(frozen=True, eq=False)
class System:
    """The unknowns of one fixpoint problem in slot layout (see the module docstring).

    ``states``: int64[n], the model state of each unknown; local states ``[0, num_max)`` maximise.
    ``rows``: int32[m] (int64 if the model's choices do not fit), the model choice of each row;
    ``row_state``: int32[m] (int64 if n does not fit), its local state.
    ``matrix``: csr float64 [m, n]; ``offset``: float64[m] (b); ``stays``: bool[m], no probability
    leaves the unknowns.

    ``slots``: int64[E, 6], one entry ``(row_start, max_lo, a, min_lo, b, j)`` per (block, slot
    j): rows ``[row_start, row_start + a)`` are the j-th rows of the maximising states
    ``[max_lo, max_lo + a)`` and the next ``b`` rows the j-th rows of the minimising states
    ``[min_lo, min_lo + b)``. ``blocks``: int64[B + 1], block i owns the entries
    ``blocks[i]:blocks[i+1]``, whose rows are contiguous; its j = 0 entry covers all its states.
    Blocks are the Gauss-Seidel order of the lower iteration (nearest the known values first);
    without an order there is one block and entry j is slot j of every state.

    ``bands``: int64[K + 1] or None: with a topological layout (see
    :mod:`posgmc.engines.topological`), band k owns the blocks ``bands[k]:bands[k+1]``, a union of
    whole strongly connected components whose rows only reach states of bands ``<= k``.
    ``offset_upper``: float64[m] or None: a second constant per row for the upper bound (a band
    solved against proven lower/upper bounds of the bands below it); None: ``offset`` for both.
    ``labels``: int64[n] or None (with ``bands``): the strongly connected component of each state,
    labels in solving order (a component's rows only reach components of smaller labels).
    """

    states: np.ndarray
    rows: np.ndarray
    row_state: np.ndarray
    matrix: sp.csr_matrix
    offset: np.ndarray
    stays: np.ndarray
    num_max: int
    slots: np.ndarray
    blocks: np.ndarray
    bands: np.ndarray | None = None
    offset_upper: np.ndarray | None = None
    labels: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.states.size)

    @property
    def m(self) -> int:
        return int(self.rows.size)

    @property
    def maximize(self) -> np.ndarray:
        """bool[n]."""
        out = np.zeros(self.n, dtype=bool)
        out[: self.num_max] = True
        return out

    @property
    def row_maximize(self) -> np.ndarray:
        """bool[m]: the row belongs to a maximising state."""
        return self.row_state < self.num_max

    @property
    def num_blocks(self) -> int:
        return int(self.blocks.size - 1)

    @cached_property
    def entries(self) -> tuple[SlotEntry, ...]:
        """The slot table as Python ints (the reduction loops read it every step)."""
        return tuple(
            (int(rs), int(ml), int(a), int(nl), int(b), int(j))
            for rs, ml, a, nl, b, j in self.slots
        )

    @cached_property
    def plan(self) -> tuple[Block, ...]:
        """Per block ``(row_lo, row_hi, max_lo, a, min_lo, b, entries)``: its rows, its maximising
        states ``[max_lo, max_lo + a)``, minimising states ``[min_lo, min_lo + b)`` and entries."""
        out: list[Block] = []
        for i in range(self.num_blocks):
            ents = self.entries[int(self.blocks[i]) : int(self.blocks[i + 1])]
            rs, ml, a, nl, b, _ = ents[0]
            last = ents[-1]
            out.append((rs, last[0] + last[2] + last[4], ml, a, nl, b, ents))
        return tuple(out)

    @cached_property
    def sweep_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(plan, slots, blocks)`` for the compiled sweeps (:mod:`posgmc.engines.kernels.blocks`):
        :attr:`plan` without the entries as uint64[B, 6], :attr:`slots` and :attr:`blocks` as
        uint64 (unsigned indices spare the compiled loops a negative-index check per access)."""
        plan = np.array([block[:6] for block in self.plan], dtype=np.uint64).reshape(-1, 6)
        return plan, self.slots.astype(np.uint64), self.blocks.astype(np.uint64)

    @cached_property
    def first_row(self) -> np.ndarray:
        """int64[n]: the first row (local index) of every state."""
        out = np.empty(self.n, dtype=np.int64)
        for rs, ml, a, nl, b, j in self.entries:
            if j == 0:
                out[ml : ml + a] = np.arange(rs, rs + a)
                out[nl : nl + b] = np.arange(rs + a, rs + a + b)
        return out


_MAX_BLOCKS = 128
"""Gauss-Seidel blocks at most on the numpy path: each costs a few numpy calls per sweep; fewer
blocks of several BFS layers each still carry the values outwards by one block per layer inside a
sweep."""

_MAX_COMPILED_BLOCKS = 1024
"""Gauss-Seidel blocks at most when the compiled sweeps run (:mod:`posgmc.engines.kernels.blocks`,
systems of ``scc.COMPILED_MIN_SIZE`` unknowns or more): a block costs them nothing per sweep, so
every backward-search layer gets its own block (inside a block the update is a Jacobi step, which
moves values by one layer only). two_robots N=32 ``Pmax`` (124 layers): 42 sweeps instead of 88
with 74 blocks. The cap bounds the Python-side tables (``System.entries``)."""

_MIN_BLOCKED_STATES = 50_000
"""Below this many unknowns one block (Jacobi) is as fast: the per-block overhead dominates."""


def _block_of(layer: np.ndarray, max_blocks: int) -> np.ndarray:
    """int64[n]: a block per layer, or, with more than ``max_blocks`` layers, consecutive layers
    merged into ``max_blocks`` blocks of similar size."""
    lay = layer.astype(np.int64)
    unjoined = lay < 0
    if unjoined.any():
        lay[unjoined] = lay.max(initial=0) + 1
    _, lay = np.unique(lay, return_inverse=True)
    counts = np.bincount(lay)
    if counts.size <= max_blocks:  # a block per layer
        dense: np.ndarray = lay.astype(np.int64)
        return dense
    size = -(-lay.size // max_blocks)
    first = (np.cumsum(counts) - counts) // size  # the chunk where each layer starts
    _, block_of_layer = np.unique(first, return_inverse=True)
    out: np.ndarray = block_of_layer[lay]
    return out


_COMPACT_CHUNK = 1 << 20
"""Entries moved per step of :func:`_compact` (its only temporary)."""


def _compact(keep: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """``a[keep]`` for each array, computed in place: the kept entries move to the front of each
    array chunk by chunk (a kept entry never moves right, and each chunk is read into a temporary
    before it is written), so no second full-size copy exists. Returns views of the fronts."""
    total = 0
    for lo in range(0, keep.size, _COMPACT_CHUNK):
        k = keep[lo : lo + _COMPACT_CHUNK]
        count = int(np.count_nonzero(k))
        for a in arrays:
            a[total : total + count] = a[lo : lo + _COMPACT_CHUNK][k]
        total += count
    return tuple(a[:total] for a in arrays)


def build_system(
    g: Structure,
    unknown: np.ndarray,
    *,
    maximize: np.ndarray,
    allowed: np.ndarray | None = None,
    choice_offset: np.ndarray | None = None,
    fixed: np.ndarray | None = None,
    layer: np.ndarray | None = None,
    topological: bool = False,
    band_states: int | None = None,
) -> System:
    """The fixpoint problem on ``unknown`` states.

    Args:
        g: the model structure.
        unknown: bool[S]; every unknown state needs at least one allowed choice.
        maximize: bool[S].
        allowed: bool[C] or None: the choices the optimisation ranges over.
        choice_offset: float64[C] or None: a constant per choice (a reward).
        fixed: float64[S] or None: the known value of every other state; probability mass into known
            states adds ``p * fixed`` to the row's offset.
        layer: int64[S] or None: an order for the Gauss-Seidel lower iteration, smallest first
            (e.g. the backward-search round where a state joined the positive region: values flow
            from the known states outwards); None: one block.
        topological: lay the states out in bands of strongly connected components in solving
            order (:mod:`posgmc.engines.scc`) when that pays; ``System.bands`` then says so.
        band_states: states per band of the topological layout (None: automatic; tests force
            small bands with it).

    Returns:
        The :class:`System`.
    """
    S = g.num_states
    unk = np.flatnonzero(unknown)
    rows_global, counts_all = _usable_rows(g, unknown, allowed)
    counts = counts_all[unk]
    if counts.size and counts.min() < 1:
        raise ValueError("every unknown state needs at least one allowed choice")
    is_max = maximize[unk]
    kmax = int(counts.max()) if counts.size else 0
    block, band_of_block, labels = _blocks(g, unk, layer, topological, band_states)
    nb = int(block.max()) + 1 if block.size else 1
    order = _state_order(is_max, block, counts, nb, kmax)
    states = unk[order]
    counts = counts[order]
    if labels is not None:
        labels = labels[order]
    block = block[order]
    del order
    n = int(states.size)
    num_max = int(is_max.sum())
    local_of = np.full(S, -1, dtype=np.int64)
    local_of[states] = np.arange(n, dtype=np.int64)
    slots, blocks, table, state_base = _slot_layout(block, counts, num_max, nb, kmax)
    # int32 where every model choice fits (the two largest arrays of the system after its matrix)
    rows = np.empty(rows_global.size, dtype=np.int32 if g.num_choices_total < 2**31 else np.int64)
    row_state = np.empty(rows.size, dtype=np.int32 if n < 2**31 else np.int64)
    if scc.compiled_at(int(rows.size)):
        indptr, local = _place_compiled(
            g, rows_global, local_of, table, state_base, rows, row_state
        )
        del rows_global, state_base, local_of  # not needed by the fill
        matrix, offset, stays = _fill_compiled(g, rows, local, indptr, choice_offset, fixed, n)
    else:
        row_st = g.choice_state[rows_global]
        start_of = np.zeros(S + 1, dtype=np.int64)
        np.cumsum(counts_all, out=start_of[1:])
        rank = np.arange(rows_global.size, dtype=np.int64) - start_of[row_st]
        loc = local_of[row_st]
        pos = table[state_base[loc] + rank] + loc
        del rank, row_st, start_of, state_base
        rows[pos] = rows_global
        del rows_global
        row_state[pos] = loc
        del pos, loc  # the row gather below is the peak: no layout temporary outlives its use
        # matrix restricted to the unknown columns; the rest goes into the offset
        offset = (
            np.zeros(rows.size)
            if choice_offset is None
            else choice_offset[rows].astype(np.float64)
        )
        data, indices, indptr, stays = _gather(g.transitions, rows, local_of, fixed, offset, n)
        matrix = sp.csr_matrix((data, indices, indptr), shape=(rows.size, n), copy=False)
    bands = None
    if band_of_block is not None:
        bands = np.zeros(int(band_of_block[-1]) + 2, dtype=np.int64)
        np.cumsum(np.bincount(band_of_block), out=bands[1:])
    return System(
        states=states,
        rows=rows,
        row_state=row_state,
        matrix=matrix,
        offset=offset,
        stays=stays,
        num_max=num_max,
        slots=slots,
        blocks=blocks,
        bands=bands,
        labels=labels,
    )


def _usable_rows(
    g: Structure, unknown: np.ndarray, allowed: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """``(rows_global, counts_all)``: the model choices the system ranges over (allowed choices
    of unknown states, grouped by state), and int64[S] how many each state has."""
    usable = unknown[g.choice_state]
    if allowed is not None:
        usable &= allowed
    rows_global = np.flatnonzero(usable)
    if allowed is None:
        counts_all = np.where(unknown, g.num_choices, 0)
    else:
        counts_all = np.bincount(g.choice_state[rows_global], minlength=g.num_states)
    return rows_global, counts_all


def _blocks(
    g: Structure,
    unk: np.ndarray,
    layer: np.ndarray | None,
    topological: bool,
    band_states: int | None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``(block, band_of_block, labels)`` of the unknown states ``unk``: the bands of strongly
    connected components when ``topological`` and the layout pays (with each band's block range
    and the component labels), else blocks by ``layer`` on a large enough system, else one
    block."""
    if topological and unk.size:
        found = topological_blocks(
            g.transitions,
            g.row_groups,
            unk,
            layer=None if layer is None else layer[unk],
            band_states=band_states,
            transpose=(g.back_ptr, g.back_choices, g.choice_state),
        )
        if found is not None:
            return found
    if layer is not None and unk.size >= _MIN_BLOCKED_STATES:
        # as many blocks as the sweeps that will run can use (iteration._lower_phase_blocks)
        fast = scc.compiled_at(int(unk.size))
        return _block_of(layer[unk], _MAX_COMPILED_BLOCKS if fast else _MAX_BLOCKS), None, None
    return np.zeros(unk.size, dtype=np.int64), None, None


def _state_order(
    is_max: np.ndarray, block: np.ndarray, counts: np.ndarray, nb: int, kmax: int
) -> np.ndarray:
    """The permutation of the unknown states into the system's order: maximisers first, then by
    block, then by decreasing number of rows (a stable sort on a small integer key; numpy uses
    radix sort for 16-bit keys)."""
    key = ((~is_max).astype(np.int64) * nb + block) * (kmax + 1) + (kmax - counts)
    if key.size and int(key.max()) < 2**16:
        return np.argsort(key.astype(np.uint16), kind="stable")
    return np.argsort(key, kind="stable")


def _slot_layout(
    block: np.ndarray, counts: np.ndarray, num_max: int, nb: int, kmax: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(slots, blocks, table, state_base)`` for the ordered states (their ``block`` and row
    ``counts``; the first ``num_max`` maximise): ``slots``/``blocks`` as in :class:`System`;
    a usable row of local state ``s`` with rank ``j`` among its state's rows goes to position
    ``table[state_base[s] + j] + s`` (one gather per row)."""
    n = int(counts.size)
    # entry (block i, slot j): the states of block i with more than j rows, per player; counts are
    # sorted decreasingly inside each (player, block), so these are prefixes of its state ranges
    player = (np.arange(n) >= num_max).astype(np.int64)
    hist = np.bincount((block * 2 + player) * (kmax + 1) + counts, minlength=nb * 2 * (kmax + 1))
    hist = hist.reshape(nb, 2, kmax + 1)
    total = hist.sum(axis=2)  # [nb, 2]
    more = total[:, :, None] - np.cumsum(hist, axis=2)[:, :, :kmax]  # [nb, 2, kmax]
    sizes = (more[:, 0, :] + more[:, 1, :]).ravel()  # in (block, slot) order
    row_start = (np.cumsum(sizes) - sizes).reshape(nb, kmax) if kmax else np.zeros((nb, 0), int)
    max_lo = np.cumsum(total[:, 0]) - total[:, 0]
    min_lo = num_max + np.cumsum(total[:, 1]) - total[:, 1]
    nonempty = sizes > 0
    bi, jj = np.divmod(np.flatnonzero(nonempty), max(kmax, 1))
    slots = np.stack(
        [
            row_start[bi, jj],
            max_lo[bi],
            more[bi, 0, jj],
            min_lo[bi],
            more[bi, 1, jj],
            jj,
        ],
        axis=1,
    ).astype(np.int64).reshape(-1, 6)
    blocks = np.zeros(nb + 1, dtype=np.int64)
    np.cumsum(np.bincount(bi, minlength=nb), out=blocks[1:])
    # scatter every usable row to its position (rows_global is grouped by state):
    # position = table[block, player, slot] + local state, one gather per row
    table = np.stack(
        [row_start - max_lo[:, None], row_start + more[:, 0, :] - min_lo[:, None]], axis=1
    ).ravel()  # [nb, 2, kmax]
    state_base = (block * 2 + player) * kmax
    return slots, blocks, table, state_base


def _gather(
    T: sp.csr_matrix,
    rows: np.ndarray,
    local_of: np.ndarray,
    fixed: np.ndarray | None,
    offset: np.ndarray,
    n: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(data, indices, indptr, stays)`` of the system's matrix: the model rows ``rows`` restricted
    to the unknown columns (``local_of >= 0``, renumbered); the mass into known states adds
    ``p * fixed`` to ``offset`` (in place). ``sub`` is this call's own copy of the rows, so its
    arrays are reused in place where the dtypes allow."""
    sub = T[rows]
    if fixed is not None and np.any(fixed != 0):
        known_fixed = np.where(local_of >= 0, 0.0, fixed)
        offset += sub @ known_fixed  # before the column indices are rewritten below
        del known_fixed
    index_dtype = np.int32 if max(n, sub.nnz) < 2**31 - 1 else np.int64
    local32 = local_of.astype(index_dtype)
    if sub.indices.dtype == index_dtype:
        loc = np.take(local32, sub.indices, out=sub.indices, mode="clip")  # unbuffered, in place
    else:
        loc = local32[sub.indices]
    del local32
    inside = loc >= 0
    all_inside = bool(inside.all())
    if all_inside:
        indptr = sub.indptr.astype(index_dtype, copy=False)
        stays = np.ones(rows.size, dtype=bool)
        data, indices = sub.data, loc
    else:
        per_row = np.add.reduceat(inside, sub.indptr[:-1], dtype=index_dtype)
        per_row[np.diff(sub.indptr) == 0] = 0
        indptr = np.zeros(rows.size + 1, dtype=index_dtype)
        np.cumsum(per_row, out=indptr[1:])
        stays = per_row == np.diff(sub.indptr)
        del per_row
        data, indices = _compact(inside, sub.data, loc)
    del sub, loc, inside
    return data, indices, indptr, stays


def _place_compiled(
    g: Structure,
    rows_global: np.ndarray,
    local_of: np.ndarray,
    table: np.ndarray,
    state_base: np.ndarray,
    rows: np.ndarray,
    row_state: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The row scatter in one compiled pass over the usable model rows in model order
    (:mod:`posgmc.engines.kernels.layout`): fills ``rows`` and ``row_state``; returns the
    system's csr ``indptr`` and the local number of every model state (-1: known), both int32
    where they fit."""
    from posgmc.engines.kernels.layout import place_rows

    T = g.transitions
    index_dtype = np.int32 if max(local_of.size, T.nnz) < 2**31 - 1 else np.int64
    local = local_of.astype(index_dtype)
    indptr = np.zeros(rows.size + 1, dtype=index_dtype)
    place_rows(
        rows_global, g.choice_state, local, table, state_base, T.indptr, T.indices, rows,
        row_state, indptr,
    )
    np.cumsum(indptr, out=indptr)
    return indptr, local


def _fill_compiled(
    g: Structure,
    rows: np.ndarray,
    local: np.ndarray,
    indptr: np.ndarray,
    choice_offset: np.ndarray | None,
    fixed: np.ndarray | None,
    n: int,
) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """:func:`_gather` in one compiled pass over the system's rows (placed by
    :func:`_place_compiled`, the model's arrays no longer needed for it are freed by then):
    ``(matrix, offset, stays)``, the same arrays as the numpy path (int32 indices where they
    fit)."""
    from posgmc.engines.kernels.layout import fill_rows

    T = g.transitions
    m = rows.size
    offset = np.zeros(m) if choice_offset is None else choice_offset[rows].astype(np.float64)
    nnz = int(indptr[-1])
    indices = np.empty(nnz, dtype=local.dtype)
    data = np.empty(nnz, dtype=np.float64)
    stays = np.empty(m, dtype=bool)
    use_fixed = fixed is not None and bool(np.any(fixed != 0))
    known = np.zeros(0) if fixed is None or not use_fixed else fixed.astype(np.float64, copy=False)
    fill_rows(
        rows, T.indptr, T.indices, T.data, local, known, use_fixed, indptr, indices, data, offset,
        stays,
    )
    matrix = sp.csr_matrix((data, indices, indptr), shape=(m, n), copy=False)
    return matrix, offset, stays


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------


def accumulate_rows(A: sp.csr_matrix, r0: int, r1: int, x: np.ndarray, y: np.ndarray) -> None:
    """``y += A[r0:r1] @ x`` in place, by scipy's kernel (only when :data:`HAVE_KERNELS`).

    ``x``: float64[n] or C-contiguous float64[n, k]; ``y``: float64[r1 - r0] or C-contiguous
    float64[r1 - r0, k] (a view into a larger buffer is updated in place)."""
    indptr = A.indptr[r0 : r1 + 1]
    if x.ndim == 1:
        _kernels.csr_matvec(r1 - r0, A.shape[1], indptr, A.indices, A.data, x, y)
    else:
        _kernels.csr_matvecs(
            r1 - r0, A.shape[1], x.shape[1], indptr, A.indices, A.data, x.ravel(), y.ravel()
        )


def multiply_into(sys: System, x: np.ndarray, y: np.ndarray) -> None:
    """y = offset + A x (x: [n] or [n, k] C-contiguous; y preallocated, same trailing shape)."""
    A = sys.matrix
    if x.ndim == 1:
        y[:] = sys.offset
        if HAVE_KERNELS:
            _kernels.csr_matvec(A.shape[0], A.shape[1], A.indptr, A.indices, A.data, x, y)
        else:  # pragma: no cover
            y += A @ x
    else:
        y[:] = sys.offset[:, None]
        if sys.offset_upper is not None and x.shape[1] == 2:
            y[:, 1] = sys.offset_upper
        if HAVE_KERNELS:
            _kernels.csr_matvecs(
                A.shape[0],
                A.shape[1],
                x.shape[1],
                A.indptr,
                A.indices,
                A.data,
                x.ravel(),
                y.ravel(),
            )
        else:  # pragma: no cover
            y += A @ x


def reduce_entries(entries: tuple[SlotEntry, ...], y: np.ndarray, out: np.ndarray) -> None:
    """``out[s]`` = the optimum of ``y`` over the rows of s, for the states of ``entries``."""
    for rs, ml, a, nl, b, j in entries:
        if j == 0:
            out[ml : ml + a] = y[rs : rs + a]
            out[nl : nl + b] = y[rs + a : rs + a + b]
            continue
        if a:
            np.maximum(out[ml : ml + a], y[rs : rs + a], out=out[ml : ml + a])
        if b:
            np.minimum(out[nl : nl + b], y[rs + a : rs + a + b], out=out[nl : nl + b])


def reduce_into(sys: System, y: np.ndarray, out: np.ndarray) -> None:
    """out[s] = opt over the rows of s of y[row] (1-D or 2-D along axis 0)."""
    reduce_entries(sys.entries, y, out)


def bellman(sys: System, x: np.ndarray) -> np.ndarray:
    """B(x) (allocating; for tests and one-off use)."""
    y = np.empty((sys.m,) + x.shape[1:])
    multiply_into(sys, np.ascontiguousarray(x), y)
    out = np.empty_like(x, dtype=np.float64)
    reduce_into(sys, y, out)
    return out


def reduce_rows(sys: System, y: np.ndarray) -> np.ndarray:
    """float64[n]: the optimum over each state's rows of the row values ``y`` (float64[m])."""
    out = np.empty(sys.n)
    reduce_into(sys, y, out)
    return out


def argopt_rows(sys: System, y: np.ndarray) -> np.ndarray:
    """int64[n]: the first optimal row (local index) of each state for row values ``y``."""
    return _argopt(sys, y)


def choice_values(sys: System, x: np.ndarray) -> np.ndarray:
    """float64[m]: b + A x per row."""
    y = np.empty((sys.m,) + x.shape[1:])
    multiply_into(sys, np.ascontiguousarray(x, dtype=np.float64), y)
    return y


def _argopt(sys: System, y: np.ndarray) -> np.ndarray:
    """int64[n]: the first optimal row of each state for row values y."""
    arg = sys.first_row.copy()
    best = y[arg]
    for rs, ml, a, nl, b, j in sys.entries:
        if j == 0:
            continue
        if a:
            seg = y[rs : rs + a]
            better = seg > best[ml : ml + a]
            best[ml : ml + a][better] = seg[better]
            arg[ml : ml + a][better] = rs + np.flatnonzero(better)
        if b:
            seg = y[rs + a : rs + a + b]
            better = seg < best[nl : nl + b]
            best[nl : nl + b][better] = seg[better]
            arg[nl : nl + b][better] = rs + a + np.flatnonzero(better)
    return arg


def choose(sys: System, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A strategy from bounds: the best row of each state for the midpoint, and the rows that are
    not provably suboptimal (maximiser: ``b + A upper >= lower(s)``; minimiser: ``b + A lower <=
    upper(s)``).

    Returns:
        ``(best_row, candidate)``: int64[n] local row indices; bool[m].
    """
    lo = np.where(np.isfinite(lower), lower, 0.0)
    hi = upper.copy()
    finite = np.isfinite(hi)
    y = choice_values(sys, np.ascontiguousarray(np.stack([lo, np.where(finite, hi, 0.0)], axis=1)))
    y_lo, y_hi = y[:, 0], y[:, 1]
    # rows into states with an infinite upper bound have an infinite upper value
    if not finite.all():
        inf_rows = np.asarray(sys.matrix @ (~finite).astype(np.float64)) > 0
        y_hi = np.where(inf_rows, np.inf, y_hi)
    mid = np.where(np.isfinite(y_hi), 0.5 * (y_lo + y_hi), y_lo)
    best = _argopt(sys, mid)
    rs = sys.row_state
    rmax = sys.row_maximize
    tol = 1e-12 * (1.0 + np.abs(lo[rs]))
    candidate = np.where(rmax, y_hi >= lo[rs] - tol, y_lo <= hi[rs] + tol)
    candidate[best] = True
    return best, candidate
