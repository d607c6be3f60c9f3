"""The strongly connected components (SCCs) of the unknown states in a solving order, and the
blocks and bands of a topological system layout (see :mod:`posgmc.engines.topological`).

One decomposition per system: with the compiled kernels, Tarjan's algorithm over the model's own
csr arrays (:mod:`posgmc.engines.kernels.components`, no copy); without them
``scipy.sparse.csgraph.connected_components(connection="strong")`` on the state graph of the whole
model (state s -> every successor of every choice of s). Its csr
arrays are the model's own (the rows of a state are contiguous, so its successors are one slice
of the entries) with duplicates summed (scipy's routine does not terminate on duplicate
entries). Choices the optimisation may not use and the edges of states whose value is known only
make components coarser: the order stays valid (a coarser component is still closed under the
topological order), it merely has fewer, larger bands.

scipy implements Pearce's algorithm, which numbers the components in the order it completes them:
a reverse topological order of the condensation (a component's successors get smaller labels).
The solver never trusts this blindly: a band whose rows reach a state not solved yet is refused
and the whole system is solved at once instead
(:func:`posgmc.engines.topological.solve_topological`).

Layout. Unknown states are ranked by component label (states of one component stay together) and
cut into *bands* of about ``band_states`` states at component boundaries, each band into
``_BLOCKS_PER_BAND`` runs of the label order (the Gauss-Seidel blocks of its solver: a block only
reads itself and the blocks before it). A component of ``_MIN_SPLIT_STATES`` states or more is cut
along the caller's backward-search layers instead (the direction in which values flow inside it;
any order inside a band is sound, the band being closed under successors).

When the order pays (the decision of :func:`topological_blocks`): the system has at least
``2 * MIN_BAND_STATES`` unknown states, the decomposition gives at least two bands, and the
largest component holds at most ``MAX_GIANT_SHARE`` of the unknown states. Otherwise (one giant
component, as in two_robots or pursuit) the system keeps the backward-search layout. On the
compiled path a giant component is looked for before the decomposition: the component of the
first unknown state, by one backward and one forward search (:func:`_seed_is_giant`); if it holds
more than ``MAX_GIANT_SHARE`` of the unknown states, the decomposition is skipped (its answer is
known: the order does not pay). The decision is the same either way; only its cost differs.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from posgmc.engines import kernels

__all__ = [
    "COMPILED_MIN_SIZE",
    "compiled_at",
    "DEFAULT_BANDS",
    "MIN_BAND_STATES",
    "components",
    "topological_blocks",
]

DEFAULT_BANDS = 32
"""Bands aimed at on a large system: one solver call each, so the Python overhead is per band
(never per component) while the bands below a band are final when it is solved."""

MIN_BAND_STATES = 16_384
"""Smallest automatic band: below this a band's solver call costs more than it saves."""

MAX_GIANT_SHARE = 0.5
"""The order pays only if the largest SCC holds at most this share of the unknown states."""

COMPILED_MIN_SIZE = 100_000
"""States (or rows) below which the engines keep their numpy paths although the compiled kernels
are enabled: the first kernel call of a process pays numba's start-up
(:mod:`posgmc.engines.kernels`), more than a kernel saves on a smaller system (the tests lower
it)."""

def compiled_at(size: int) -> bool:
    """Whether the engines take their compiled path on a system (or model) of ``size`` states or
    rows: the kernels are enabled and ``size`` reaches :data:`COMPILED_MIN_SIZE` (read at call
    time: the tests lower it)."""
    return kernels.enabled() and size >= COMPILED_MIN_SIZE


_BLOCKS_PER_BAND = 16
"""Gauss-Seidel blocks per band (each costs a few numpy calls per sweep)."""

_MIN_SPLIT_STATES = 50_000
"""A component this large is cut into blocks along the caller's backward-search layers."""


def components(
    transitions: sp.csr_matrix, row_groups: np.ndarray, within: np.ndarray | None = None
) -> np.ndarray:
    """int32[S]: the SCC label of every model state in the graph of all its choices, labels in a
    reverse topological order of the condensation (see the module docstring).

    Args:
        transitions: csr [C, S] whose rows are grouped by state.
        row_groups: int64[S + 1]: the choices of state s are rows ``row_groups[s]:row_groups[s+1]``.
        within: bool[S] or None: only the labels of these states are asked for. The compiled
            path then decomposes the subgraph they induce (finer components, the same order
            guarantee, -1 elsewhere); the numpy path decomposes the whole graph regardless.
    """
    size = row_groups.size - 1 if within is None else int(np.count_nonzero(within))
    if compiled_at(size):
        from posgmc.engines.kernels.components import tarjan

        mask = np.ones(row_groups.size - 1, dtype=bool) if within is None else within
        labels, _ = tarjan(transitions.indptr, transitions.indices, row_groups, mask)
        compiled_labels: np.ndarray = labels
        return compiled_labels
    S = row_groups.size - 1
    idx_dtype = np.int32 if transitions.nnz < 2**31 and S < 2**31 else np.int64
    # the rows of a state are contiguous, so its successors are one slice of the entries
    indptr = transitions.indptr[row_groups].astype(idx_dtype)
    indices = transitions.indices.astype(idx_dtype, copy=True)
    graph = sp.csr_matrix(
        (np.ones(indices.size, dtype=np.int8), indices, indptr), shape=(S, S), copy=False
    )
    graph.sum_duplicates()  # several choices into one successor (the routine needs no duplicates)
    _, labels = connected_components(graph, directed=True, connection="strong")
    out: np.ndarray = labels
    return out


def _seed_is_giant(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    transpose: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    within: np.ndarray,
    unk: np.ndarray,
) -> bool:
    """Whether the component of the first unknown state (the one explored first, nearest the
    initial states) holds more than ``MAX_GIANT_SHARE`` of the unknown states: then the
    decomposition would only confirm that the order does not pay (Tarjan's pass over the unknown
    states costs several times the two searches of
    :func:`~posgmc.engines.kernels.components.seed_component`). Only on the compiled path, where
    that decomposition is a kernel too; a False answer says nothing (the decomposition decides)."""
    n = int(unk.size)
    if transpose is None or not compiled_at(n):
        return False
    from posgmc.engines.kernels.components import seed_component

    back_ptr, back_choices, choice_state = transpose
    threshold = int(MAX_GIANT_SHARE * n)
    size = seed_component(
        transitions.indptr, transitions.indices, row_groups, back_ptr, back_choices,
        choice_state, within, int(unk[0]), threshold,
    )
    return bool(size > threshold)


def topological_blocks(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    unk: np.ndarray,
    *,
    layer: np.ndarray | None,
    band_states: int | None,
    transpose: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Blocks and bands of a topological layout of the unknown states ``unk``, or None when the
    order does not pay (see the module docstring).

    Args:
        transitions, row_groups: as for :func:`components`.
        unk: int64[n] the unknown model states.
        layer: int64[n] or None: the caller's backward-search layer of each unknown state (-1:
            last), the Gauss-Seidel order inside a very large component.
        band_states: states per band (None: ``max(n / DEFAULT_BANDS, MIN_BAND_STATES)``); 1 makes
            every component its own band and block (tests).
        transpose: ``(back_ptr, back_choices, choice_state)``, the transposed pattern of
            ``transitions`` (:class:`~posgmc.engines.graph.Structure`), or None: with it, a
            giant component is looked for first (:func:`_seed_is_giant`).

    Returns:
        ``(block, band_of_block, label)``: int64[n] the block of each unknown state, in solving
        order (0 first); int64[num_blocks] the band of each block, non-decreasing from 0; int64[n]
        the component label of each unknown state (labels in solving order, not dense).
    """
    n = int(unk.size)
    if n == 0:
        return None
    if band_states is None and n < 2 * MIN_BAND_STATES:
        return None
    within = np.zeros(row_groups.size - 1, dtype=bool)
    within[unk] = True
    if band_states is None and _seed_is_giant(transitions, row_groups, transpose, within, unk):
        return None
    labels = components(transitions, row_groups, within)
    lab = labels[unk]
    sizes = np.bincount(lab)
    if band_states is None:
        if int(sizes.max()) > MAX_GIANT_SHARE * n:
            return None
        band_states = max(-(-n // DEFAULT_BANDS), MIN_BAND_STATES)
    # states of earlier components (label order), counted over the unknown states only
    before = np.cumsum(sizes) - sizes
    rank = before[lab]
    band = rank // band_states
    if int(band.max()) == 0:
        return None
    # blocks inside a band: runs of the label order (a topological order, so a block only reads
    # itself and earlier blocks); inside a very large component the caller's backward-search
    # layers instead (the direction values flow in there), at most 128 of them
    chunk = max(band_states // _BLOCKS_PER_BAND, 1)
    inner = np.minimum((rank - band * band_states) // chunk, _BLOCKS_PER_BAND - 1)
    piece = band * _BLOCKS_PER_BAND + inner  # blocks nest in bands
    key = piece * 128
    if layer is not None:
        big = sizes[lab] >= _MIN_SPLIT_STATES
        if big.any():
            lay = np.where(layer < 0, int(layer.max(initial=0)) + 1, layer).astype(np.int64)
            top = int(lay[big].max()) + 1
            key[big] += lay[big] * 128 // top
    present = np.zeros(int(key.max()) + 1, dtype=bool)
    present[key] = True
    block = (np.cumsum(present) - 1)[key]
    num_blocks = int(block.max()) + 1
    band_of_block = np.zeros(num_blocks, dtype=np.int64)
    band_of_block[block] = band
    _, band_of_block = np.unique(band_of_block, return_inverse=True)
    return block.astype(np.int64), band_of_block.astype(np.int64), lab.astype(np.int64)

