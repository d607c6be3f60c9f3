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


def _count_rows(
    indptr: np.ndarray, indices: np.ndarray, rows: np.ndarray, local_of: np.ndarray,
    out_indptr: np.ndarray,
) -> None:
    """``out_indptr`` [m + 1] (zeroed by the caller): the cumulative count of entries of the
    model rows ``rows`` whose column is an unknown state (``local_of >= 0``)."""
    for i in range(rows.size):
        r = rows[i]
        kept = 0
        for e in range(indptr[r], indptr[r + 1]):
            if local_of[indices[e]] >= 0:
                kept += 1
        out_indptr[i + 1] = out_indptr[i] + kept


count_rows = compiled(_count_rows)


def _fill_rows(
    indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, rows: np.ndarray,
    local_of: np.ndarray, fixed: np.ndarray, use_fixed: bool, out_indptr: np.ndarray,
    out_indices: np.ndarray, out_data: np.ndarray, offset: np.ndarray, stays: np.ndarray,
) -> None:
    """The entries of the rows (local columns), ``offset += sum of p * fixed[t]`` over the entries
    into known states (when ``use_fixed``), and ``stays`` (no entry leaves the unknowns)."""
    for i in range(rows.size):
        r = rows[i]
        at = out_indptr[i]
        acc = 0.0
        for e in range(indptr[r], indptr[r + 1]):
            t = indices[e]
            loc = local_of[t]
            if loc >= 0:
                out_indices[at] = loc
                out_data[at] = data[e]
                at += 1
            elif use_fixed:
                acc += data[e] * fixed[t]
        if use_fixed:
            offset[i] += acc
        stays[i] = at - out_indptr[i] == indptr[r + 1] - indptr[r]


fill_rows = compiled(_fill_rows)


def _scatter_rows(
    rows_global: np.ndarray, choice_state: np.ndarray, local_of: np.ndarray, table: np.ndarray,
    state_base: np.ndarray, rows: np.ndarray, row_state: np.ndarray,
) -> None:
    """Row ``rows_global[i]`` (sorted, so grouped by state), the k-th usable row of its state of
    local number l, goes to position ``table[state_base[l] + k] + l`` of ``rows`` and
    ``row_state`` (the numpy path computes the same positions with a rank array)."""
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
        rows[at] = c
        row_state[at] = loc
        rank += 1


scatter_rows = compiled(_scatter_rows)
