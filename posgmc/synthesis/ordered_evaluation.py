"""The float evaluation of a defence on a large product in the order of its strongly connected
components: the adversary's best response and the adjoint of the induced chain by the compiled
Gauss-Seidel kernel (:mod:`posgmc.engines.kernels.ordered_sweeps`).

On the secure-autonomy products (10^5-10^6 states) most states are trivial components and the
rest fall into a few dozen components of at most a few thousand states; value iteration over the
whole product needs hundreds of sweeps there, while successors first most states are final after
one step. The plan (the undecided states' rows and their component order) depends only on the
product's structure, which is the same for every candidate of one support, so it is built once
per structure (:meth:`OrderedPlan.of`) and reused: a candidate only brings new probabilities.

Used by :meth:`posgmc.synthesis.parametric.Parametrisation._evaluate_iterative` when the compiled
kernels are enabled; its values are estimates for the search (the reported numbers come from the
sound engines), to the same stopping rule as the numpy value iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines import scc
from posgmc.engines.kernels.ordered_sweeps import solve_ordered

__all__ = ["OrderedPlan", "solving_order"]


@dataclass(frozen=True, eq=False)
class OrderedPlan:
    """The undecided states ``U`` (int64[n], product states) of one product structure, in solving
    order. ``indptr``/``indices``: the U states' rows of the product's transition matrix (csr,
    columns the product states), ``entries``: int64, the position of each of their entries in the
    matrix's ``data``; ``state_rows``: int64[n + 1], local state i's rows; ``rows``: int64, the
    product rows taken; ``order``/``comp_ptr``: the local states by component, successors first
    (component c is ``order[comp_ptr[c]:comp_ptr[c+1]]``), inside a component in descending
    product index. ``structure``: the matrix's own
    ``indptr`` and ``indices`` and ``unknown``, bool[S] (what the plan is valid for)."""

    U: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    entries: np.ndarray
    state_rows: np.ndarray
    rows: np.ndarray
    order: np.ndarray
    comp_ptr: np.ndarray
    structure: tuple[np.ndarray, np.ndarray]
    unknown: np.ndarray

    @staticmethod
    def of(transitions: sp.csr_matrix, row_groups: np.ndarray, unknown: np.ndarray) -> OrderedPlan:
        """The plan of the states ``unknown`` (bool[S]) of a product (csr ``transitions`` [C, S],
        canonical: the rows of state s are ``row_groups[s]:row_groups[s+1]``)."""
        U = np.flatnonzero(unknown)
        counts = np.diff(row_groups)[U]
        state_rows = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        rows = np.repeat(row_groups[U], counts) + (
            np.arange(int(state_rows[-1])) - np.repeat(state_rows[:-1], counts))
        lengths = np.diff(transitions.indptr)[rows]
        indptr = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
        entries = np.repeat(transitions.indptr[rows], lengths) + (
            np.arange(int(indptr[-1])) - np.repeat(indptr[:-1], lengths))
        order, comp_ptr = solving_order(transitions, row_groups, unknown)
        return OrderedPlan(U, indptr, transitions.indices[entries].astype(np.int64), entries,
                           state_rows, rows, order, comp_ptr,
                           (transitions.indptr, transitions.indices), unknown)

    def fits(self, transitions: sp.csr_matrix, unknown: np.ndarray) -> bool:
        """Whether ``transitions`` has the structure and ``unknown`` (bool[S]) the undecided
        states the plan was built for (a product refilled from a template shares its arrays:
        then no comparison of contents)."""
        indptr, indices = self.structure
        same_matrix = (indptr is transitions.indptr and indices is transitions.indices) or (
            np.array_equal(indptr, transitions.indptr)
            and np.array_equal(indices, transitions.indices))
        return bool(same_matrix and (unknown is self.unknown or np.array_equal(
            self.U, np.flatnonzero(unknown))))

    def values(self, transitions: sp.csr_matrix, x: np.ndarray, offset: np.ndarray | None, *,
               discount: float, minimize: bool, tol: float, scale: float, max_sweeps: int) -> None:
        """Solve ``x[U]`` in place: the adversary's optimum (min if ``minimize``) over each U
        state's rows of ``offset[r] + discount * (row r) . x``, the values outside U fixed; ``x``
        holds the start on U (a warm start or anything)."""
        data = transitions.data[self.entries]
        off = np.zeros(self.rows.size) if offset is None else offset[self.rows]
        solve_ordered(self.indptr, self.indices, data, self.state_rows, self.U, self.order,
                      self.comp_ptr, off, float(discount), np.full(self.U.size, bool(minimize)),
                      float(tol), float(scale), int(max_sweeps), x)

    def adjoint(self, chain_t: sp.csr_matrix, y: np.ndarray, at: int, *, discount: float,
                tol: float, max_sweeps: int) -> None:
        """Solve ``y = discount * chain_t y + e_at`` in place (``chain_t``: the transposed chain
        on U, local numbering; ``y`` float64[n] holds the start): the reverse order, predecessors
        first and inside a component from the initial state forwards, the way the adjoint's mass
        flows."""
        n = self.U.size
        local = np.arange(n, dtype=np.int64)
        offset = np.zeros(n)
        offset[at] = 1.0
        solve_ordered(chain_t.indptr.astype(np.int64), chain_t.indices.astype(np.int64),
                      chain_t.data, np.arange(n + 1, dtype=np.int64), local,
                      self.order[::-1].copy(), (n - self.comp_ptr[::-1]).copy(), offset,
                      float(discount), np.ones(n, dtype=bool), float(tol), 1.0, int(max_sweeps), y)

    def best_rows(self, transitions: sp.csr_matrix, x: np.ndarray, offset: np.ndarray | None, *,
                  discount: float, minimize: bool) -> np.ndarray:
        """int64[n]: each U state's first row (its index among the state's rows) attaining the
        optimum of the rows' values at ``x``."""
        T_U = sp.csr_matrix((transitions.data[self.entries], self.indices, self.indptr),
                            shape=(self.rows.size, transitions.shape[1]))
        vals = discount * (T_U @ x)
        if offset is not None:
            vals = vals + offset[self.rows]
        starts = self.state_rows[:-1]
        reduce = np.minimum if minimize else np.maximum
        best = reduce.reduceat(vals, starts)
        counts = np.diff(self.state_rows)
        attaining = np.flatnonzero(vals == np.repeat(best, counts))
        owner = np.repeat(np.arange(self.U.size), counts)[attaining]
        first = np.unique(owner, return_index=True)[1]  # owners ascending, every state attains
        out: np.ndarray = attaining[first] - starts
        return out


def solving_order(transitions: sp.csr_matrix, row_groups: np.ndarray, states: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(order, comp_ptr) for :data:`~posgmc.engines.kernels.ordered_sweeps.solve_ordered`: the
    positions (int64, into ``np.flatnonzero(states)``) of the ``states`` (bool[S]) by strongly
    connected component of the graph of all their rows, successors first (the labels of
    :func:`posgmc.engines.scc.components`), component c ``order[comp_ptr[c]:comp_ptr[c+1]]``.
    Inside a component the states come in descending index: a model is explored from its
    initial state, so the later states lie nearer the exits the values flow in from (on the
    secure-autonomy products a quarter of the updates of ascending order). The order is checked:
    if some row read a state of a later component, all states form one component instead (plain
    Gauss-Seidel, still convergent)."""
    F = np.flatnonzero(states)
    labels = scc.components(transitions, row_groups, within=states)[F]
    order = np.lexsort((-np.arange(F.size), labels)).astype(np.int64)
    ranked = labels[order]
    cuts = np.flatnonzero(ranked[1:] != ranked[:-1]) + 1
    comp_ptr = np.concatenate([[0], cuts, [F.size]]).astype(np.int64)
    # the check: no entry of a listed state's rows leads to a later component
    comp = np.full(row_groups.size - 1, -1, dtype=np.int64)
    comp[F[order]] = np.repeat(np.arange(comp_ptr.size - 1), np.diff(comp_ptr))
    counts = np.diff(row_groups)[F]
    rows = np.repeat(row_groups[F], counts) + _ranges(counts)
    lengths = np.diff(transitions.indptr)[rows]
    entries = np.repeat(transitions.indptr[rows], lengths) + _ranges(lengths)
    reader = np.repeat(np.repeat(comp[F], counts), lengths)
    if np.any(comp[transitions.indices[entries]] > reader):
        comp_ptr = np.array([0, F.size], dtype=np.int64)
    return order, comp_ptr


def _ranges(counts: np.ndarray) -> np.ndarray:
    """0..c-1 for each count c, concatenated."""
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    out: np.ndarray = np.arange(int(counts.sum())) - starts
    return out
