"""Compiled Gauss-Seidel value iteration component by component, for float estimates.

The synthesis search evaluates thousands of candidate defences on products of 10^5-10^6 states
(:mod:`posgmc.synthesis.parametric`); its values are heuristics (every number reported is
re-checked by the sound engines), so they need no bounds, only to be cheap and deterministic.
Jacobi sweeps over the whole product need hundreds of passes there; taken one strongly connected
component at a time, successors first, most states (the trivial components) are final after one
step and each other component iterates only over its own states with values below it already
final.

:data:`solve_ordered` solves ``x_s = opt_{r in rows(s)} (offset[r] + g * sum_j A[r, j] x[j])``
for the states listed in ``order`` (``opt`` min where ``minimize[s]``, else max), grouped by
``comp_ptr`` into components processed in that order, each by Gauss-Seidel sweeps until no value
of the component changes by more than ``tol * max(scale, its largest |value|)``. A row's entry on
its own state is eliminated (``x_s = (c + g * rest) / (1 - g * p)``, the exact solution of that
state's equation given the others, as :mod:`posgmc.engines.topological` does), so a one-state
component is solved in one step. The order must be topological (a component's rows read only
its own states, earlier components' and states not listed): the callers check it
(:func:`posgmc.synthesis.ordered_evaluation.solving_order`). The floating-point operations are a
row's plain sums in entry order, in
a fixed sequence: the same arrays give the same bits.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled, on_warm_up

__all__ = ["solve_ordered"]


def _solve_ordered(
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    state_rows: np.ndarray,
    column: np.ndarray,
    order: np.ndarray,
    comp_ptr: np.ndarray,
    offset: np.ndarray,
    discount: float,
    minimize: np.ndarray,
    tol: float,
    scale: float,
    max_sweeps: int,
    x: np.ndarray,
) -> int:
    """Solve in place (``x`` indexed by the matrix's columns; local state s is ``x[column[s]]``,
    its rows ``state_rows[s]:state_rows[s+1]`` of the csr arrays). Returns the number of state
    updates made (the work done)."""
    work = 0
    for c in range(comp_ptr.size - 1):
        lo, hi = comp_ptr[c], comp_ptr[c + 1]
        passes = max_sweeps if hi - lo > 1 else 1
        for _ in range(passes):
            change = 0.0
            size = scale
            for i in range(lo, hi):
                s = order[i]
                own = column[s]
                low = minimize[s]
                # the optimum over the state's rows, its own entries eliminated
                best = 0.0
                first = True
                for r in range(state_rows[s], state_rows[s + 1]):
                    rest = 0.0
                    self_p = 0.0
                    for e in range(indptr[r], indptr[r + 1]):
                        j = indices[e]
                        if j == own:
                            self_p += data[e]
                        else:
                            rest += data[e] * x[j]
                    denominator = 1.0 - discount * self_p
                    if denominator > 1e-9:
                        v = (offset[r] + discount * rest) / denominator
                    else:  # (almost) a pure self-loop: one plain step
                        v = offset[r] + discount * (rest + self_p * x[own])
                    if first or (v < best if low else v > best):
                        best = v
                        first = False
                d = abs(best - x[own])
                if d > change:
                    change = d
                if abs(best) > size:
                    size = abs(best)
                x[own] = best
            work += hi - lo
            if change <= tol * size:
                break
    return work


solve_ordered = compiled(_solve_ordered)


def _warm_up() -> None:
    one = np.array([0, 1], dtype=np.int64)
    solve_ordered(one, np.array([0], dtype=np.int64), np.array([0.5]), one,
                  np.array([0], dtype=np.int64), np.array([0], dtype=np.int64), one,
                  np.array([1.0]), 1.0, np.ones(1, dtype=np.bool_), 1e-9, 1.0, 10, np.zeros(1))


on_warm_up(_warm_up)
