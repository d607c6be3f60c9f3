"""Compiled sound interval iteration component by component (the kernel of
:mod:`posgmc.engines.topological`; the soundness argument is in that module's docstring).

Two kernels over the arrays of a :class:`~posgmc.engines.system.System` (csr ``indptr``,
``indices``, ``data``; ``offset``, ``stays``, ``row_state``) and a component label per local
state, labels in solving order (successors first):

* :data:`prepare`: the rows of every state (a counting sort of ``row_state``), the states of
  every component in label order, whether a component needs iteration (more than one state, or a
  self-loop too likely to eliminate) and the longest chain of such components in the condensation
  (the precision is shared out along it). Fails (``ok`` False) if a row reads a later component.
* :data:`solve_range`: components ``c0:c1`` in order, each against the bounds already computed for
  the components it reads: a component that needs no iteration in closed form, the others by
  Gauss-Seidel lower iteration, an optimistic guess and its Jacobi verification (with the
  component's own cap when ``deflate``), as :mod:`posgmc.engines.iteration` does for a system.

Every value computed is one of the monotone operators of :mod:`posgmc.engines.iteration` and
:mod:`posgmc.engines.topological` (self-loops eliminated as there) applied to a vector; the
floating-point operations are the plain sums and products of a row, in entry order.

The arithmetic of one row against both bounds is written out twice in :data:`solve_range` (the
closed form and the verification sweep) on purpose: the same loop as a shared numba function,
inlined or not, gave bit-identical results but made the kernel measurably slower (a third to
twice the time on a rover model's components), and this loop is the solver's hot path.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled

_U = np.uintp
"""Indices are cast to unsigned in the hot loops: numba then skips its negative-index wraparound
branch on every access (indices here are never negative)."""

OK = 0
"""Status of :data:`solve_range`: every component converged."""
FAILED = 1
"""A component did not converge (iteration cap, stalled gap) or read an unsolved state."""


def _prepare(
    n: int,
    row_state: np.ndarray,
    labels: np.ndarray,
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    limit: float,
) -> tuple[
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int, bool
]:
    """``(row_ptr, row_list, order, comp_ptr, comp_of, iterate, chain, levels, ok)``.

    ``row_ptr``: int32[n + 1], ``row_list``: int32[m]: the rows of state s are
    ``row_list[row_ptr[s]:row_ptr[s+1]]``. ``order``: int32[n] the states by component,
    ``comp_ptr``: int32[K + 1] (component c holds ``order[comp_ptr[c]:comp_ptr[c+1]]``),
    ``comp_of``: int32[n] (the caller keeps n and m below 2**31). ``iterate``: bool[K].
    ``chain``: the most components that need iteration on one path of the condensation (at least
    1); ``levels``: the most components of any kind on one path. ``ok``: every row reads its own
    component or earlier ones."""
    m = row_state.size
    row_ptr = np.zeros(n + 1, dtype=np.int32)
    for r in range(m):
        row_ptr[row_state[r] + 1] += 1
    for s in range(n):
        row_ptr[s + 1] += row_ptr[s]
    fill = row_ptr[:-1].copy()
    row_list = np.empty(m, dtype=np.int32)
    for r in range(m):
        s = row_state[r]
        row_list[fill[s]] = r
        fill[s] += 1
    top = 0
    for s in range(n):
        if labels[s] > top:
            top = labels[s]
    count = np.zeros(top + 2, dtype=np.int32)
    for s in range(n):
        count[labels[s] + 1] += 1
    # dense component numbers in label order (labels of other model states are absent)
    dense = np.full(top + 1, -1, dtype=np.int32)
    num = 0
    for lab in range(top + 1):
        if count[lab + 1] > 0:
            dense[lab] = num
            num += 1
    comp_ptr = np.zeros(num + 1, dtype=np.int32)
    for lab in range(top + 1):
        if dense[lab] >= 0:
            comp_ptr[dense[lab] + 1] = count[lab + 1]
    for c in range(num):
        comp_ptr[c + 1] += comp_ptr[c]
    comp_of = np.empty(n, dtype=np.int32)
    order = np.empty(n, dtype=np.int32)
    at = comp_ptr[:-1].copy()
    for s in range(n):
        c = dense[labels[s]]
        comp_of[s] = c
        order[at[c]] = s
        at[c] += 1
    iterate = np.zeros(num, dtype=np.bool_)
    depth = np.zeros(num, dtype=np.int32)
    height = np.zeros(num, dtype=np.int32)
    chain = 1
    levels = 1
    ok = True
    for c in range(num):
        if comp_ptr[c + 1] - comp_ptr[c] > 1:
            iterate[c] = True
        below = 0
        below_all = 0
        for i in range(comp_ptr[c], comp_ptr[c + 1]):
            s = order[i]
            for j in range(_U(row_ptr[s]), _U(row_ptr[s + 1])):
                r = row_list[j]
                p = 0.0
                for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                    t = indices[e]
                    if t == s:
                        p += data[e]
                    ct = comp_of[_U(t)]
                    if ct > c:
                        ok = False
                    elif ct < c:
                        if depth[ct] > below:
                            below = depth[ct]
                        if height[ct] > below_all:
                            below_all = height[ct]
                if p >= limit:
                    iterate[c] = True
        depth[c] = below + (1 if iterate[c] else 0)
        height[c] = below_all + 1
        if depth[c] > chain:
            chain = depth[c]
        if height[c] > levels:
            levels = height[c]
    return row_ptr, row_list, order, comp_ptr, comp_of, iterate, chain, levels, ok


prepare = compiled(_prepare)


def _solve_range(
    c0: int,
    c1: int,
    num_max: int,
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    offset: np.ndarray,
    stays: np.ndarray,
    row_ptr: np.ndarray,
    row_list: np.ndarray,
    order: np.ndarray,
    comp_ptr: np.ndarray,
    comp_of: np.ndarray,
    iterate: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    scratch: np.ndarray,
    cap: float,
    deflate: bool,
    share: float,
    relative: bool,
    max_iterations: int,
    limit: float,
    noise: float,
    rounding: float,
) -> tuple[int, int, bool]:
    """Components ``c0:c1`` (see the module docstring); ``lower``/``upper``: float64[n], the
    bounds (components before ``c0`` final, ``upper`` = ``cap`` elsewhere), updated in place;
    ``scratch``: float64[k, 2], k at least the largest component's size. ``noise``: the relative
    slack of ``F(U) <= U``; ``rounding``: the relative error of the lower iterate, beyond which an
    upper iterate below it means a guess below the value (as in
    :func:`posgmc.engines.iteration._verify`).

    Returns ``(status, iterations, internal)``: :data:`OK` or :data:`FAILED`; the most sweeps
    one component took; whether a component had an internal row (one that stays inside it with
    offset 0: the maximiser may have end components)."""
    most = 0
    internal_found = False
    for c in range(c0, c1):
        base = comp_ptr[c]
        k = comp_ptr[c + 1] - base
        if not iterate[c]:
            # closed form: one state whose self-loops are eliminated (x_s = (b + A_out x) / (1 - p))
            s = order[base]
            is_max = s < num_max
            best_lo = -np.inf if is_max else np.inf
            best_hi = best_lo
            for j in range(_U(row_ptr[s]), _U(row_ptr[s + 1])):
                r = row_list[j]
                acc_lo = offset[r]
                acc_hi = offset[r]
                p = 0.0
                for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                    t = indices[e]
                    if t == s:
                        p += data[e]
                    else:
                        acc_lo += data[e] * lower[_U(t)]
                        acc_hi += data[e] * upper[_U(t)]
                if p > 0.0:
                    scale = 1.0 / (1.0 - p)
                    acc_lo *= scale
                    acc_hi *= scale
                if is_max:
                    best_lo = max(best_lo, acc_lo)
                    best_hi = max(best_hi, acc_hi)
                else:
                    best_lo = min(best_lo, acc_lo)
                    best_hi = min(best_hi, acc_hi)
            best_hi = min(best_hi, cap)
            if not np.isfinite(best_hi):
                return FAILED, most, internal_found
            upper[s] = best_hi
            lower[s] = min(best_lo, best_hi)
            continue
        # the precision inherited from the components read below
        inherited = 0.0
        for i in range(base, base + k):
            s = order[i]
            for j in range(_U(row_ptr[s]), _U(row_ptr[s + 1])):
                r = row_list[j]
                for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                    t = indices[e]
                    if comp_of[_U(t)] == c:
                        continue
                    gap = upper[_U(t)] - lower[_U(t)]
                    if not np.isfinite(gap):
                        return FAILED, most, internal_found
                    if relative:
                        scale = abs(upper[_U(t)]) + abs(lower[_U(t)])
                        if scale > 0.0 and gap / scale > inherited:
                            inherited = gap / scale
                    elif 0.5 * gap > inherited:
                        inherited = 0.5 * gap
        precision = inherited + share
        spread = inherited
        tau = max(precision - spread, 0.25 * precision)
        if spread > 0.0:
            tau *= 1.0 / 64.0
        iters = 0
        verified = False
        for i in range(base, base + k):
            scratch[i - base, 1] = cap  # the proven upper bound
        converged = False
        while not converged:
            # --- lower iteration, Gauss-Seidel inside the component --------------------------
            phase_start = iters
            r_old = 0.0
            r_new = 0.0
            previous = np.inf
            while True:
                if iters >= max_iterations:
                    return FAILED, max(most, iters), internal_found
                d = 0.0
                for i in range(base, base + k):
                    s = order[i]
                    is_max = s < num_max
                    best = -np.inf if is_max else np.inf
                    for j in range(_U(row_ptr[s]), _U(row_ptr[s + 1])):
                        r = row_list[j]
                        acc = offset[r]
                        p = 0.0
                        for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                            t = indices[e]
                            if t == s:
                                p += data[e]
                            else:
                                acc += data[e] * lower[_U(t)]
                        if p > 0.0:
                            if p < limit:
                                acc *= 1.0 / (1.0 - p)
                            else:
                                acc += p * lower[s]
                        best = max(best, acc) if is_max else min(best, acc)
                    old = lower[s]
                    if best > old:
                        change = best - old
                        if relative and abs(best) > 0.0:
                            change /= abs(best)
                        d = max(d, change)
                        lower[s] = best
                iters += 1
                r_old = r_new
                r_new = min(d / previous, 0.999) if previous > 0.0 else 0.0
                previous = d
                q = max(r_old, r_new)
                if d <= tau and d * q / (1.0 - q) <= tau:
                    break
            # --- the guess --------------------------------------------------------------------
            for i in range(base, base + k):
                s = order[i]
                lo = lower[s]
                if relative:
                    guess = lo + (precision + spread) * abs(lo)
                    if lo == 0.0:
                        guess += precision + spread
                else:
                    guess = lo + precision + spread
                upper[s] = scratch[i - base, 1] if verified else min(guess, scratch[i - base, 1])
            budget = max(16, iters - phase_start)
            steps = 0
            last_gap = np.inf
            failed = False
            # --- verification: the upper bound by Jacobi steps (deflated), the lower by G-S ---
            while True:
                if iters >= max_iterations:
                    return FAILED, max(most, iters), internal_found
                best_exit = 0.0  # max(0, max over exit rows) (the cap of the deflation)
                has_internal = False
                for i in range(base, base + k):
                    s = order[i]
                    is_max = s < num_max
                    best_lo = -np.inf if is_max else np.inf
                    best_hi = best_lo
                    for j in range(_U(row_ptr[s]), _U(row_ptr[s + 1])):
                        r = row_list[j]
                        acc_lo = offset[r]
                        acc_hi = offset[r]
                        p = 0.0
                        inside = True
                        for e in range(_U(indptr[r]), _U(indptr[r + 1])):
                            t = indices[e]
                            if t == s:
                                p += data[e]
                            else:
                                acc_lo += data[e] * lower[_U(t)]
                                acc_hi += data[e] * upper[_U(t)]
                                if comp_of[_U(t)] != c:
                                    inside = False
                        if p > 0.0:
                            if p < limit:
                                scale = 1.0 / (1.0 - p)
                                acc_lo *= scale
                                acc_hi *= scale
                            else:
                                acc_lo += p * lower[s]
                                acc_hi += p * upper[s]
                        if deflate:
                            if inside and stays[r] and offset[r] == 0.0:
                                has_internal = True
                            elif is_max and acc_hi > best_exit:
                                best_exit = acc_hi
                        if is_max:
                            best_lo = max(best_lo, acc_lo)
                            best_hi = max(best_hi, acc_hi)
                        else:
                            best_lo = min(best_lo, acc_lo)
                            best_hi = min(best_hi, acc_hi)
                    scratch[i - base, 0] = best_hi
                    if best_lo > lower[s]:
                        lower[s] = best_lo
                if deflate and has_internal:
                    internal_found = True
                    for i in range(base, base + k):
                        s = order[i]
                        if scratch[i - base, 0] > best_exit:
                            scratch[i - base, 0] = best_exit
                iters += 1
                steps += 1
                if not verified:
                    below = True
                    crossed = False
                    for i in range(base, base + k):
                        s = order[i]
                        slack = noise * abs(upper[s])
                        if not scratch[i - base, 0] <= upper[s] + slack:
                            below = False
                        if scratch[i - base, 0] < lower[s] - rounding * abs(lower[s]):
                            crossed = True
                    if below:
                        verified = True
                        for i in range(base, base + k):
                            s = order[i]
                            new = scratch[i - base, 0]
                            scratch[i - base, 1] = min(scratch[i - base, 1], max(new, upper[s]))
                            upper[s] = new
                    elif crossed:
                        failed = True
                    else:
                        for i in range(base, base + k):
                            s = order[i]
                            upper[s] = scratch[i - base, 0]
                else:
                    for i in range(base, base + k):
                        s = order[i]
                        scratch[i - base, 1] = min(scratch[i - base, 1], scratch[i - base, 0])
                        upper[s] = scratch[i - base, 1]
                if failed:
                    break
                if verified:
                    done = True
                    gap_max = 0.0
                    for i in range(base, base + k):
                        s = order[i]
                        hi = scratch[i - base, 1]
                        lo = lower[s]
                        gap = hi - lo
                        if not (np.isfinite(hi) and np.isfinite(lo)):
                            done = False
                            gap_max = np.inf
                            continue
                        gap_max = max(gap_max, gap)
                        if relative:
                            if gap > precision * (abs(hi) + abs(lo)):
                                done = False
                        elif gap > 2.0 * precision:
                            done = False
                    if done:
                        converged = True
                        break
                    if steps % 1000 == 0:
                        if gap_max >= last_gap * (1.0 - 1e-9):
                            return FAILED, max(most, iters), internal_found
                        last_gap = gap_max
                elif steps >= budget:
                    break
            if not converged:
                tau = max(tau / 4.0, 1e-15)
        for i in range(base, base + k):
            s = order[i]
            hi = scratch[i - base, 1]
            upper[s] = hi
            if lower[s] > hi:
                lower[s] = hi
        most = max(most, iters)
    return OK, most, internal_found


solve_range = compiled(_solve_range)
