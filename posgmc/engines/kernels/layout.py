"""Compiled layout passes of :func:`posgmc.engines.system.build_system`: the scatter of the usable
model rows to their slot positions, and the system's csr matrix, offsets and ``stays`` in one
pass over those rows.

The numpy path takes the rows (``T[rows]``, a copy of every entry), multiplies them by the known
values (a second pass), maps the columns to local states (a third) and compacts the entries that
stay among the unknowns (a fourth). Here each model row is read once: an entry into an unknown
state is written with its local column, an entry into a known state adds ``p * fixed[t]`` to the
row's offset. Entries keep their order inside a row and the offset sums them in entry order, as
the matrix product of the numpy path does, so both paths build the same system.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled


def _place_rows(
    rows_global: np.ndarray, choice_state: np.ndarray, local_of: np.ndarray, table: np.ndarray,
    state_base: np.ndarray, indptr: np.ndarray, indices: np.ndarray, rows: np.ndarray,
    row_state: np.ndarray, out_indptr: np.ndarray,
) -> None:
    """Row ``rows_global[i]`` (sorted, so grouped by state), the k-th usable row of its state of
    local number l, goes to position ``at = table[state_base[l] + k] + l`` of ``rows`` and
    ``row_state`` (the numpy path computes the same positions with a rank array), and
    ``out_indptr[at + 1]`` counts its entries into unknown states (``local_of >= 0``). The model
    rows are read in their own order, so the reads are sequential."""
    previous = -1
    rank = 0
    for i in range(rows_global.size):
        c = rows_global[i]
        s = choice_state[c]
        if s != previous:
            previous = s
            rank = 0
        loc = local_of[s]
        at = table[state_base[loc] + rank] + loc
        rank += 1
        rows[at] = c
        row_state[at] = loc
        kept = 0
        for e in range(indptr[c], indptr[c + 1]):
            if local_of[indices[e]] >= 0:
                kept += 1
        out_indptr[at + 1] = kept


place_rows = compiled(_place_rows)


def _fill_rows(
    rows: np.ndarray, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray,
    local_of: np.ndarray, fixed: np.ndarray, use_fixed: bool, out_indptr: np.ndarray,
    out_indices: np.ndarray, out_data: np.ndarray, offset: np.ndarray, stays: np.ndarray,
) -> None:
    """The entries of every system row ``row`` (the model row ``rows[row]``, as
    :data:`place_rows` placed it) with local columns, ``offset[row] += sum of p * fixed[t]``
    over its entries into known states (when ``use_fixed``, in entry order), and ``stays[row]``
    (no entry leaves the unknowns). The system rows are written in their own order, so the
    writes are sequential and the reads jump (random reads cost less than random writes)."""
    for row in range(rows.size):
        c = rows[row]
        at = out_indptr[row]
        acc = 0.0
        for e in range(indptr[c], indptr[c + 1]):
            t = indices[e]
            loc = local_of[t]
            if loc >= 0:
                out_indices[at] = loc
                out_data[at] = data[e]
                at += 1
            elif use_fixed:
                acc += data[e] * fixed[t]
        if use_fixed:
            offset[row] += acc
        stays[row] = at - out_indptr[row] == indptr[c + 1] - indptr[c]


fill_rows = compiled(_fill_rows)
