"""Exact solution by linear algebra: direct solves for chains, policy iteration for mdps and games.

A strategy (one row per unknown state) turns a :class:`~posgmc.engines.system.System` into a
linear system ``x = b_sigma + A_sigma x``. :func:`evaluate` solves it with a sparse LU
(``scipy.sparse.linalg.spsolve``) after settling by graph search the states that never leave the
unknowns: there the value is 0 if no row with a positive constant is reachable inside, and infinite
otherwise (a reward collected forever); states that reach an infinite state are infinite too.

:func:`policy_iteration` improves one player's strategy by strict switches only (so ties never
cycle). In a game the *outer* player's strategy is improved against the *inner* player's exact best
response, itself computed by policy iteration on the mdp left when the outer strategy is fixed
(Hoffman-Karp). Which player is outer, and how the inner player is started, depends on the objective
and is chosen by the caller:

* least-fixpoint objectives (reachability, total reward): outer = maximiser. The inner minimiser
  first gets, by graph search, the states where it can avoid every row with a positive constant
  forever (value 0), because policy iteration cannot discover such end components by itself.
* "infinite unless reached" rewards: outer = minimiser, started from a proper strategy (one that
  reaches the target almost surely against everything). Strict improvements keep it proper.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from posgmc.engines.graph import Structure, almost_sure_reach, attractor, positive_buchi
from posgmc.engines.support_cache import SupportCache, digest
from posgmc.engines.system import System

__all__ = ["Grouped", "grouped", "evaluate", "policy_iteration", "policy_values_to_rows"]


@dataclass(frozen=True, eq=False)
class Grouped:
    """A system with rows grouped by state (the layout policy iteration needs).

    ``matrix``: csr [m, n]; ``offset``: float64[m]; ``stays``: bool[m];
    ``row_groups``: int64[n + 1];
    ``row_state``: int64[m]; ``maximize``: bool[n]; ``source``: int64[m], the row of the original
    :class:`System` each row comes from.
    """

    matrix: sp.csr_matrix
    offset: np.ndarray
    stays: np.ndarray
    row_groups: np.ndarray
    row_state: np.ndarray
    maximize: np.ndarray
    source: np.ndarray

    @property
    def n(self) -> int:
        return int(self.row_groups.size - 1)

    @cached_property
    def support(self) -> bytes:
        """The digest of the matrix's pattern (stored entries, and which of them are zero) and
        row groups: what the graph searches of :func:`evaluate` and :func:`_prepare_min` read
        of it (:mod:`posgmc.engines.support_cache`)."""
        m = self.matrix
        return digest(m.indptr, m.indices, m.data != 0, self.row_groups, int(m.shape[1]))

    def restrict(self, keep: np.ndarray) -> Grouped:
        """The rows with ``keep`` (every state must keep at least one)."""
        idx = np.flatnonzero(keep)
        counts = np.bincount(self.row_state[idx], minlength=self.n)
        rg = np.zeros(self.n + 1, dtype=np.int64)
        np.cumsum(counts, out=rg[1:])
        return Grouped(
            matrix=self.matrix[idx],
            offset=self.offset[idx],
            stays=self.stays[idx],
            row_groups=rg,
            row_state=self.row_state[idx],
            maximize=self.maximize,
            source=self.source[idx],
        )


def grouped(sys: System) -> Grouped:
    """The rows of ``sys`` regrouped by state."""
    perm = np.argsort(sys.row_state, kind="stable")
    counts = np.bincount(sys.row_state, minlength=sys.n)
    rg = np.zeros(sys.n + 1, dtype=np.int64)
    np.cumsum(counts, out=rg[1:])
    return Grouped(
        matrix=sys.matrix[perm],
        offset=sys.offset[perm],
        stays=sys.stays[perm],
        row_groups=rg,
        row_state=sys.row_state[perm],
        maximize=sys.maximize,
        source=perm,
    )


def _chain_structure(matrix: sp.csr_matrix) -> Structure:
    n = matrix.shape[0]
    return Structure.build(matrix.tocsr(), np.arange(n + 1, dtype=np.int64))


def evaluate(gr: Grouped, rows: np.ndarray) -> np.ndarray:
    """float64[n]: the value of the strategy choosing row ``rows[s]`` (an index into ``gr``) in s.

    Closed parts never leaving the unknowns get 0 (nothing collected) or inf (a positive constant
    collected forever); see the module docstring.
    """
    n = gr.n
    A = gr.matrix[rows].tocsr()
    b = gr.offset[rows]
    leaks = ~gr.stays[rows]
    infinite, idx = _chain_classes(gr, rows, A, leaks, b > 0)
    x = np.zeros(n)
    x[infinite] = np.inf
    if idx.size:
        sub = A[idx][:, idx]
        M = (sp.identity(idx.size, format="csc") - sub.tocsc()).tocsc()
        sol = spla.spsolve(M, b[idx])
        x[idx] = np.atleast_1d(sol)
    return x


def _chain_classes(gr: Grouped, rows: np.ndarray, A: sp.csr_matrix, leaks: np.ndarray,
                   collects: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(infinite, rest)`` of the chain ``A`` (the rows ``rows`` of ``gr``) for :func:`evaluate`:
    bool[n] the states that reach a closed part collecting a positive constant, int64[k] the
    states whose value needs the linear solve (neither infinite nor in a closed part collecting
    nothing). Graph searches only: remembered per support of the chain (:data:`_CLASSES`)."""
    key = digest(gr.support, rows, leaks, collects)
    found = _CLASSES.get(key)
    if found is None:
        n = gr.n
        st = _chain_structure(A)
        everyone = np.ones(n, dtype=bool)
        none = np.zeros(n, dtype=bool)
        leaving, _ = attractor(
            st, none, existential=everyone, candidates=everyone, initial_choices=leaks
        )
        trapped = ~leaving
        collecting, _ = attractor(
            st, none, existential=everyone, candidates=trapped, initial_choices=trapped & collects
        )
        infinite, _ = attractor(st, collecting & trapped, existential=everyone,
                                candidates=everyone)
        zero = trapped & ~infinite
        found = (infinite, np.flatnonzero(~(infinite | zero)))
        for a in found:
            a.flags.writeable = False
        _CLASSES.put(key, found)
    return found


def _nbytes(arrays: tuple[np.ndarray | None, ...]) -> int:
    return sum(a.nbytes for a in arrays if a is not None)


_CLASSES: SupportCache[tuple[np.ndarray, np.ndarray]] = SupportCache(_nbytes)
"""The classes of :func:`_chain_classes` of recent chains (a cache, not configuration): the best
responses of a synthesis evaluate the same few policies on products of one support."""


def _row_values(gr: Grouped, x: np.ndarray) -> np.ndarray:
    finite = np.isfinite(x)
    y = gr.offset + gr.matrix @ np.where(finite, x, 0.0)
    if not finite.all():
        hits_inf = np.asarray(gr.matrix @ (~finite).astype(np.float64)) > 0
        y = np.where(hits_inf, np.inf, y)
    out: np.ndarray = y
    return out


def _improve(
    gr: Grouped,
    x: np.ndarray,
    rows: np.ndarray,
    players: np.ndarray,
    banned: np.ndarray | None = None,
) -> tuple[np.ndarray, bool]:
    """Strictly improving switches for the states with ``players`` True (never to a row with
    ``banned`` True)."""
    y = _row_values(gr, x)
    st = gr.row_state
    sign = np.where(gr.maximize[st], 1.0, -1.0)
    z = np.where(np.isfinite(y), y * sign, sign * np.inf)
    current = z[rows]
    with np.errstate(invalid="ignore"):
        tol = 1e-10 * (1.0 + np.where(np.isfinite(current), np.abs(current), 0.0))
    better = z > (current + tol)[st]
    better &= players[st]
    if banned is not None:
        better &= ~banned
    if not better.any():
        return rows, False
    cand = np.where(better, z, -np.inf)
    best_val = np.maximum.reduceat(cand, gr.row_groups[:-1])
    is_best = better & (cand == best_val[st])
    idx = np.flatnonzero(is_best)
    states, first = np.unique(st[idx], return_index=True)
    new_rows = rows.copy()
    new_rows[states] = idx[first]
    return new_rows, True


def _augmented(gr: Grouped) -> Structure:
    """The structure of ``gr`` with one extra absorbing state n receiving the probability mass that
    leaves the system, so that graph analyses see every move."""
    n, m = gr.n, gr.matrix.shape[0]
    leak = np.maximum(1.0 - np.asarray(gr.matrix.sum(axis=1)).ravel(), 0.0)
    leak[gr.stays] = 0.0
    extra = sp.csr_matrix((leak, (np.arange(m), np.full(m, n))), shape=(m, n + 1))
    body = sp.csr_matrix((gr.matrix.data, gr.matrix.indices, gr.matrix.indptr), shape=(m, n + 1))
    rows = sp.vstack([body + extra, sp.csr_matrix(([1.0], ([0], [n])), shape=(1, n + 1))]).tocsr()
    rows.eliminate_zeros()
    rg = np.append(gr.row_groups, gr.row_groups[-1] + 1)
    return Structure.build(rows, rg)


def _prepare_min(
    gr: Grouped, rows: np.ndarray, *, unbounded: bool
) -> tuple[np.ndarray, np.ndarray]:
    """For a least-fixpoint objective (non-negative constants): settle the minimiser's states by
    graph search, because policy iteration cannot discover end components by itself.

    * idle: the minimiser avoids every row with a positive constant forever (value 0); such a row;
    * with ``unbounded`` (total rewards): the states where the maximiser collects rewards infinitely
      often with positive probability whatever the minimiser does (value inf), and elsewhere a
      start that reaches the idle states or leaves the system almost surely (finite values), which
      strict improvements keep.

    Returns ``(rows, fixed)``: the start rows and the minimiser states whose row is final.
    Graph searches only: remembered per support of the augmented structure (:data:`_SETTLED`).
    """
    leak = np.maximum(1.0 - np.asarray(gr.matrix.sum(axis=1)).ravel(), 0.0)
    leak[gr.stays] = 0.0
    key = digest(gr.support, leak > 0, gr.maximize, gr.offset > 0, int(unbounded))
    found = _SETTLED.get(key)
    if found is None:
        found = _settle_min(gr, unbounded=unbounded)
        for a in found:
            if a is not None:
                a.flags.writeable = False
        _SETTLED.put(key, found)
    fixed, idle_rows, start, witness = found
    rows = np.where(fixed, idle_rows, rows)
    if start is not None and witness is not None:
        rows = np.where(start, witness, rows)
    return rows, fixed.copy()


_SETTLED: SupportCache[tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]] = (
    SupportCache(_nbytes)
)
"""The answers of :func:`_settle_min` for recent systems (a cache, not configuration)."""


def _settle_min(
    gr: Grouped, *, unbounded: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The graph searches of :func:`_prepare_min`: ``(fixed, idle_rows, start, witness)``, bool[n]
    the minimiser states settled idle and int64[n] their idle row; with ``unbounded`` bool[n] the
    minimiser states started towards the idle states and int64[n] their row (else None)."""
    n = gr.n
    st = _augmented(gr)
    maximize = np.append(gr.maximize, True)
    minimisers = ~maximize
    positive_rows = np.append(gr.offset > 0, False)
    none = np.zeros(n + 1, dtype=bool)
    positive, _ = attractor(
        st,
        none,
        existential=maximize,
        candidates=np.ones(n + 1, dtype=bool),
        initial_choices=positive_rows,
    )
    idle = ~positive
    hits = np.asarray(st.transitions @ positive.astype(np.float64)) > 0
    ok = np.flatnonzero(~hits & ~positive_rows & idle[st.choice_state])
    idle_rows = np.full(n + 1, -1, dtype=np.int64)
    idle_rows[st.choice_state[ok[::-1]]] = ok[::-1]
    fixed = (idle & minimisers & (idle_rows >= 0))[:n]
    if not unbounded:
        return fixed, idle_rows[:n], None, None
    infinite, _ = positive_buchi(
        st, positive_rows, np.ones(n + 1, dtype=bool), existential=maximize
    )
    goal = idle.copy()
    goal[n] = True
    reach, witness = almost_sure_reach(st, goal, ~infinite, existential=minimisers)
    start = (minimisers & reach & ~goal & (witness >= 0))[:n]
    return fixed, idle_rows[:n], start, witness[:n]


def _mdp_pi(
    gr: Grouped, rows: np.ndarray, *, idle_min: bool, unbounded: bool, max_rounds: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """Policy iteration for one player (every state with more than one row belongs to it)."""
    n = gr.n
    players = np.ones(n, dtype=bool)
    if idle_min and not gr.maximize.all():
        rows, fixed = _prepare_min(gr, rows, unbounded=unbounded)
        players &= ~fixed
    rounds = 0
    x = evaluate(gr, rows)
    # the direction of the one player who chooses (the other's states have one row each); every
    # state's value moves that way in exact arithmetic, the other player's states included
    choosing = np.diff(gr.row_groups) > 1
    maximiser = bool(gr.maximize[choosing].all()) if choosing.any() else True
    sign = np.full(n, 1.0 if maximiser else -1.0)
    seen = {rows.tobytes()}
    banned = np.zeros(gr.source.size, dtype=bool)
    while rounds < max_rounds:
        rounds += 1
        new_rows, changed = _improve(gr, x, rows, players, banned)
        if not changed or new_rows.tobytes() in seen:
            break
        new_x = evaluate(gr, new_rows)
        gain, loss = _compare(x, new_x, sign)
        if gain and not loss:
            seen.add(new_rows.tobytes())
            rows, x = new_rows, new_x
            banned[:] = False
            continue
        # A round that loses somewhere (or gains nowhere) switched on rounding noise: ban its
        # switches whose one-step margin is within what the linear solves can get wrong (all of
        # them if none is), and try the others against the same values (see _compare).
        switched = np.flatnonzero(new_rows != rows)
        y = _row_values(gr, x)
        with np.errstate(invalid="ignore"):
            margin = sign[switched] * (y[new_rows[switched]] - y[rows[switched]])
            scale = 1.0 + np.where(np.isfinite(x[switched]), np.abs(x[switched]), 0.0)
        suspect = ~(margin > _NOISE * scale)
        banned[new_rows[switched[suspect] if suspect.any() else switched]] = True
    return x, rows, rounds


_NOISE = 1e-7
"""Relative one-step margin below which a switch that made the values worse is put down to the
linear solves' rounding and banned (nearly singular chains: values within 1e-5 of 1)."""


def _compare(old: np.ndarray, new: np.ndarray, sign: np.ndarray) -> tuple[bool, bool]:
    """``(gain, loss)``: whether ``new`` is better than ``old`` somewhere, and worse somewhere,
    by more than the switching tolerance of :func:`_improve`, in the direction ``sign`` (+1
    maximise, -1 minimise: the improving player's, at every state).

    In exact arithmetic a round of policy iteration gains at the states it switches and loses
    nowhere. In floating point a switch between rows whose values differ only by the linear
    solves' rounding can close an end component (values within 1e-5 of 1 on a nearly singular
    chain, PAYNT's attacker-one-defender during the gradient search): the values then drop, and
    taking such rounds cycled for ever. Whatever strategy policy iteration ends with, the
    callers certify its values or fall back to interval iteration (:mod:`posgmc.engines.solving`),
    so this only decides how good the strategy is, never what is proven."""
    with np.errstate(invalid="ignore"):
        change = sign * (new - old)
        tol = 1e-10 * (1.0 + np.where(np.isfinite(old), np.abs(old), 0.0))
    change = np.where(np.isnan(change), 0.0, change)
    return bool((change > tol).any()), bool((change < -tol).any())


def policy_iteration(
    gr: Grouped,
    initial: np.ndarray,
    *,
    outer_max: bool,
    idle_min: bool,
    unbounded: bool = False,
    max_rounds: int = 100_000,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Optimal values and strategy by (nested) policy iteration.

    Args:
        gr: the system, rows grouped by state.
        initial: int64[n], a starting row (index into ``gr``) per state.
        outer_max: in a game, whether the maximiser is the outer player (see the module docstring).
        idle_min: settle the minimiser's zero-value states by graph search first (least-fixpoint
            objectives).
        unbounded: values may be infinite (total rewards): also settle the infinite states and
            start the minimiser from a strategy with finite values.
        max_rounds: cap on improvement rounds (outer and inner each).

    Returns:
        ``(values, rows, rounds)``: float64[n]; int64[n] the optimal row per state; rounds used.
    """
    n = gr.n
    if n == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64), 0
    if gr.maximize.all() or (~gr.maximize).all():
        return _mdp_pi(
            gr, initial.copy(), idle_min=idle_min, unbounded=unbounded, max_rounds=max_rounds
        )
    outer = gr.maximize if outer_max else ~gr.maximize
    outer_sign = np.full(n, 1.0 if outer_max else -1.0)
    rows = initial.copy()
    seen: set[bytes] = set()
    best: tuple[np.ndarray, np.ndarray] | None = None  # the last round's values and rows
    total = 0
    rounds = 0
    while True:
        rounds += 1
        keep = ~outer[gr.row_state]
        keep[rows[outer]] = True
        sub = gr.restrict(keep)
        # map the current inner rows into the restricted system
        pos_in_sub = np.full(gr.source.size, -1, dtype=np.int64)
        pos_in_sub[np.flatnonzero(keep)] = np.arange(int(keep.sum()))
        sub_rows = pos_in_sub[rows]
        x, sub_rows, inner_rounds = _mdp_pi(
            sub, sub_rows, idle_min=idle_min, unbounded=unbounded, max_rounds=max_rounds
        )
        total += inner_rounds
        rows = np.flatnonzero(keep)[sub_rows]
        if best is not None:
            # the outer switch must gain (exact arithmetic); on rounding noise keep the better
            # of the last two rounds and stop (see _compare)
            gain, loss = _compare(best[0], x, outer_sign)
            if loss:
                return best[0], best[1], total + rounds
            if not gain:
                return x, rows, total + rounds
        seen.add(rows.tobytes())
        best = (x, rows)
        rows, changed = _improve(gr, x, rows, outer)
        if not changed or rounds >= max_rounds or rows.tobytes() in seen:
            return x, rows, total + rounds


def policy_values_to_rows(gr: Grouped, rows: np.ndarray) -> np.ndarray:
    """The rows of the original :class:`System` for grouped row indices."""
    out: np.ndarray = gr.source[rows]
    return out
