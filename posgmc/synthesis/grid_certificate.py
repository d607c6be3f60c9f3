"""A proof that a maximiser's grid abstraction bounds the exact belief MDP despite floating point.

The grid abstraction (:mod:`posgmc.synthesis.belief_grid`) is solved by the sound engines for its
float probabilities as stored; those are the exact abstraction's up to rounding, and a bound of
the float MDP is not one of the exact MDP in general (a tiny shift of mass inside a cycle of
beliefs moves the least fixpoint arbitrarily far). This module proves the bound for the exact
belief MDP instead, by Park induction on the exact operator: every row r of the abstraction
(an expanded vertex's choice, or a cut-off) is described by quantities that enclose the exact
belief successors,

* ``top[r]``: at least the exact stop mass (a probability), or the exact reward;
* ``coef[r]``: per grid vertex k an upper bound on the exact weight e*_k of k in the exact
  decomposition of the successor (*certified* parts: the exact posterior lies in the float
  simplex with every barycentric weight positive, so the exact row has the same vertices), or
  the float weight itself (*ambiguous* parts, near a face of the triangulation);
* ``slack[r]``: how much the float weights of the ambiguous parts may exceed their exact mass;
* ``leak[r]``: Σ_s (y*_s - x_s)^+ cap(s) over the ambiguous parts, x the float combination of
  vertices and cap the full-observation bound (V* is sublinear and monotone, so
  V*(y*) <= V*(x) + V*((y* - x)^+)).

With the exact masses summing to at most one (the stop mass, the continuing mass and what is
lost), for any vector W >= 0 and m = the least W over the row's vertices,

    t* + Σ_k e*_k W_k + (ambiguous parts) <= m + t (1 - m) + Σ_k coef_k (W_k - m)
                                                + m slack + leak                (probability)

(for an expected reward ``top`` is added and the rest scaled by the discount). The right-hand
side, evaluated with rounding to +inf, is ``R(W)``; the exact operator at W is at most ``R(W)``.
If ``R(W) <= W`` at every vertex (the maximiser's: every row; the adversary's: some row; a
probability's W = 1 needs nothing, V*_n <= 1 anyway), then
the n-step values V*_n of the belief MDP satisfy V*_n <= W at every vertex by induction
(V*_{n+1}(v) <= exact operator at V*_n <= R(W) <= W, with V*_n <= cap at the unit beliefs), and
V* = lim V*_n <= W: the grid's bound for the exact POMDP.

W is built from the engine's upper values U (on a game, for the maximiser's rows and one
least row per adversary vertex: the adversary needs only one row to pass, and its other rules
would merge end components across beliefs of different values): on every end component made
of *clean* rows
(certified parts only, nothing to the target) W is the largest U over it, so that the rows that
stay inside give R(W) = m = W exactly (no rounding: m plus an exact zero); elsewhere
W = U + d h, with h the largest expected number of steps before the target, the sink or such an
end component is reached (computed on the abstraction with those end components collapsed, by
the engine), and d the largest violation of U itself, enlarged: since h >= 1 + Σ e h on every
row, the raise absorbs the violations along every path. The check R(W) <= W is then evaluated
as stated; W is returned only when it holds. Where ambiguous rows form a cycle that the maximiser
can keep to, h is infinite and so is the bound: no finite W passes there (a leak in a loop adds
up), and the caller falls back to a coarser proven bound.

Rewards of both signs (``signed``). Monotonicity fails (more mass may be worth less), and the
Park induction from V*_0 = 0 fails (W may be negative, and the n-step values need not stay
below V*). Both are replaced:

* *The leak.* V*(b) = max_σ Σ_s b_s v_σ(s), and v_σ(s), the value of σ started in s, is the
  value of a history-dependent strategy of the full-observation model, so
  floor(s) <= v_σ(s) <= cap(s) (floor: the full-observation minimum, both players minimising).
  With p = (y* - x)^+ and q = (y* - x)^-, V*(y*) = max_σ v_σ (x + p - q)
  <= V*(x) + Σ_s |y*_s - x_s| max(cap(s), -floor(s), 0): the same leak, priced per state at
  max(cap, -floor, 0) (the caller's ``leak``).
* *A contraction instead of the induction.* Let X be V* on the vertices and, per row r,
  ρ_r(Y) = t*_r + Σ_k ê_rk Y_k + leak_r with ê the exact weights of the certified parts and the
  float weights of the ambiguous ones (both at most ``coef``). The Bellman equation of the belief
  MDP and the two bounds above give X_v <= ρ_r(X) for the maximiser's best row r at v (for the
  adversary: for every row offered, the adversary's value being a minimum over at least those;
  its vertices are checked by their usable row only), and R(W) >= ρ_r(W) on every row (the
  inequality above). Suppose h > 0 with
  Σ_k coef_rk h_k < h_v on every usable row of every vertex v (checked by :func:`contracts`,
  h from the same steps solve, without collapsing end components), so
  β = max_r Σ_k ê_rk h_k / h_v < 1. Let δ = max_k (X_k - W_k)^+ / h_k (finite: V* lies between
  floor and cap). If R(W) <= W, then at every vertex
  X_v - W_v <= ρ_r(X) - ρ_r(W) = Σ_k ê_rk (X_k - W_k) <= δ Σ_k ê_rk h_k <= β δ h_v, so
  δ <= β δ, δ = 0 and V* <= W. (Where some W_v is +inf there is nothing to prove, and a finite
  R(W) only uses finite W.) Where no such h exists (a row keeping all its mass among vertices
  that never stop, such as a loop on one vertex), no W is proven.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import end_components
from posgmc.engines.options import SolverOptions
from posgmc.engines.rewards import expected_reach_reward
from posgmc.model.explicit import make_model
from posgmc.model.types import ModelType

__all__ = ["Enclosure", "certified_upper", "contracts"]

_UNIT = 2.0 ** -53

STEP_ITERATIONS = 20_000
"""The iterations of the steps h (interval iteration, stopped there with its upper values, which
still bound h). h is stiff exactly where it is useless: a loop of ambiguous rows that the
maximiser can keep to leaks only rounding-sized mass, so h is of the order of 1e16 steps and the
raise d h reaches the cap anyway; without this count such a loop kept the bracket iterating for
minutes (a 68,000-vertex grid of the case study)."""

_RAISES = (1.0, 4.0, 64.0, 4096.0)
"""The factors tried on the raise d (the largest violation) before the check is given up."""


@dataclass(frozen=True, eq=False)
class Enclosure:
    """The exact abstraction's rows enclosed (see the module docstring): one row per expanded
    choice and per cut-off vertex. ``state``: int64[rows], the vertex of each row; ``coef``:
    csr float64[rows, vertices]; ``top``, ``slack``, ``leak``: float64[rows]; ``clean``:
    bool[rows], every part certified and nothing to the target (rows an end component may keep
    to); ``infinite``: bool[rows], rows worth +inf (an unbounded reward cut-off); ``adversary``:
    bool[vertices]; ``probability``: the objective is a probability (else an expected reward);
    ``discount``; ``signed``: rewards of both signs (``leak`` then priced at
    max(cap, -floor, 0) per state)."""

    state: np.ndarray
    coef: sp.csr_matrix
    top: np.ndarray
    slack: np.ndarray
    leak: np.ndarray
    gone: np.ndarray
    kept_lo: np.ndarray
    clean: np.ndarray
    infinite: np.ndarray
    adversary: np.ndarray
    probability: bool
    discount: float
    signed: bool = False
    """The rewards take both signs: W is proven by the contraction argument (the module
    docstring), which needs no W >= 0 and no collapsed end component."""

    @property
    def vertices(self) -> int:
        return int(self.coef.shape[1])


def _up(v: np.ndarray) -> np.ndarray:
    return np.where(v > 0, np.nextafter(v, np.inf), v)


def _row_min(coef: sp.csr_matrix, W: np.ndarray) -> np.ndarray:
    """The least W over each row's vertices (0 for a row without any)."""
    n = coef.shape[0]
    m = np.zeros(n)
    has = np.diff(coef.indptr) > 0
    if coef.nnz:
        starts = coef.indptr[:-1][has]
        m[has] = np.minimum.reduceat(W[coef.indices], starts)
    return m


def bellman_upper(enc: Enclosure, W: np.ndarray) -> np.ndarray:
    """R(W) per row: an upper bound, rounded to +inf, on the exact belief MDP's row at W
    (float64[vertices] >= 0, +inf allowed)."""
    coef = enc.coef
    m = _row_min(coef, W)
    m_col = np.repeat(m, np.diff(coef.indptr))
    Wk = W[coef.indices]
    with np.errstate(invalid="ignore"):
        diff = np.where(Wk == m_col, 0.0, Wk - m_col)
        diff = np.where(diff > 0, diff * (1.0 + 2.0 * _UNIT), 0.0)
        terms = np.where(diff > 0, coef.data * diff * (1.0 + 2.0 * _UNIT), 0.0)
    S = sp.csr_matrix((terms, coef.indices, coef.indptr), shape=coef.shape)
    k = np.diff(coef.indptr).astype(np.float64)
    with np.errstate(invalid="ignore"):
        spread = np.asarray(S.sum(axis=1)).ravel() * (1.0 + 2.0 * (k + 2.0) * _UNIT)
        extra = spread + enc.leak
        if enc.probability:
            extra = extra + enc.top * np.maximum(1.0 - m, 0.0) * (1.0 + 2.0 * _UNIT)
        extra = np.where(extra > 0, extra * (1.0 + 4.0 * _UNIT), extra)
        # m per unit of the exact continuing mass, at most 1 - gone + slack (m >= 0) and at
        # least kept_lo (m < 0); exact where both are 1
        mass_hi = np.where((enc.gone > 0) | (enc.slack > 0),
                           np.nextafter((1.0 - enc.gone) + enc.slack, np.inf), 1.0)
        mass = np.where(m >= 0, mass_hi, enc.kept_lo)
        base = m * mass
        base = np.where(mass != 1.0, np.nextafter(base, np.inf), base)
        cont = np.where(extra > 0, np.nextafter(base + extra, np.inf), base)
        if enc.probability:
            out = cont
        else:
            if enc.discount < 1.0:
                cont = np.nextafter(cont * enc.discount, np.inf)
            out = np.where(enc.top != 0, np.nextafter(enc.top + cont, np.inf), cont)
    out = np.where(np.isnan(out), np.inf, out)
    return np.where(enc.infinite, np.inf, out)


def _per_state(enc: Enclosure, R: np.ndarray) -> np.ndarray:
    """The operator per vertex: the maximiser's best row, the adversary's least."""
    V = enc.vertices
    hi = np.full(V, -np.inf)
    np.maximum.at(hi, enc.state, R)
    lo = np.full(V, np.inf)
    np.minimum.at(lo, enc.state, R)
    return np.where(enc.adversary, lo, hi)


def _checked(enc: Enclosure, W: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """R(W) per vertex as checked: :func:`_per_state`; with rewards of both signs the adversary
    passes only by a ``usable`` row (the rows the contraction is checked on)."""
    R = bellman_upper(enc, W)
    if enc.signed:
        R = np.where(usable, R, np.inf)
    return _per_state(enc, R)


def _usable_rows(enc: Enclosure, U: np.ndarray) -> np.ndarray:
    """The rows W is built for (bool[rows]): every row of the maximiser, and at each of the
    adversary's vertices one row least at the engine's values U (R(U) rounded as checked). The
    adversary needs only one row with R(W) <= W, so building W for its best one suffices, and
    its other rules (a deterministic one that tells the decision maker everything) neither join
    the end components W is levelled on nor lengthen the steps its raise is scaled by."""
    usable: np.ndarray = ~enc.adversary[enc.state]
    theirs = np.flatnonzero(~usable)
    if not theirs.size:
        return usable
    with np.errstate(invalid="ignore"):
        R = bellman_upper(enc, np.where(np.isfinite(U), U, np.inf))
    R = np.where(np.isnan(R), np.inf, R)
    # per adversary vertex the first of its least rows (rows of a vertex in ascending order)
    order = theirs[np.lexsort((theirs, R[theirs], enc.state[theirs]))]
    first = np.r_[True, enc.state[order][1:] != enc.state[order][:-1]]
    usable[order[first]] = True
    return usable


def _components(enc: Enclosure, usable: np.ndarray) -> tuple[np.ndarray, int]:
    """The end components the clean ``usable`` rows can keep to: (int64[vertices] component or
    -1, count)."""
    V = enc.vertices
    rows = enc.clean & usable
    if not rows.any():
        return np.full(V, -1, dtype=np.int64), 0
    mec_of, count, _ = end_components(enc.coef, enc.state, rows)
    return np.asarray(mec_of, dtype=np.int64), int(count)


def _steps(enc: Enclosure, mec_of: np.ndarray, count: int, usable: np.ndarray,
           deadline: float | None = None) -> np.ndarray | None:
    """h per vertex: the largest expected number of ``usable`` rows taken (either player
    maximising it) before a row without vertices, or an end component of ``mec_of``, is
    reached; those count 0 (an end component's vertices share its own exits' count, found on
    the quotient where it is one state whose rows are its members' rows that leave it)."""
    V = enc.vertices
    rep = np.where(mec_of >= 0, V + mec_of, np.arange(V))  # quotient state of each vertex
    n_q = V + count
    coef = enc.coef.tocoo()
    owner = rep[enc.state]
    col = rep[coef.col]
    # a component's rows that stay inside it are dropped (staying counts nothing)
    inside = np.zeros(enc.state.size, dtype=bool)
    if count:
        leaves = np.zeros(enc.state.size, dtype=bool)
        np.logical_or.at(leaves, coef.row, col != owner[coef.row])
        inside = (mec_of[enc.state] >= 0) & ~leaves & enc.clean
    keep = ~inside & usable
    kept = np.flatnonzero(keep)
    new_row = np.full(enc.state.size, -1, dtype=np.int64)
    new_row[kept] = np.arange(kept.size)
    sel = keep[coef.row]
    # every row is made stochastic by a rest to the absorbing state (its count is 0 there)
    DONE = n_q
    rows_kept = new_row[coef.row[sel]]
    data = coef.data[sel]
    mass = np.bincount(rows_kept, weights=data, minlength=kept.size)
    scale = np.where(mass > 1.0, 1.0 / np.maximum(mass, 1e-300), 1.0)
    data = data * scale[rows_kept]
    rest = np.maximum(0.0, 1.0 - mass * scale)
    # each quotient state also gets a row to DONE (a component may stay; states without rows)
    n_states = n_q + 1
    state_rows = np.r_[owner[kept], np.arange(n_q), [DONE]]
    r_idx = np.r_[rows_kept, np.arange(kept.size), kept.size + np.arange(n_q), [kept.size + n_q]]
    c_idx = np.r_[col[sel], np.full(kept.size, DONE), np.full(n_q + 1, DONE)]
    vals = np.r_[data, rest, np.ones(n_q + 1)]
    stay_row = np.zeros(state_rows.size, dtype=bool)
    stay_row[kept.size:] = True
    perm = np.argsort(state_rows, kind="stable")
    T = sp.csr_matrix((vals, (r_idx, c_idx)), shape=(state_rows.size, n_states))[perm]
    T.eliminate_zeros()
    groups = np.zeros(n_states + 1, dtype=np.int64)
    groups[1:] = np.cumsum(np.bincount(state_rows, minlength=n_states))
    # the stay rows exist only where a state has no other row or is a component: elsewhere
    # they would let the count stop early; the count maximises, so a 0 row is never chosen
    # over a positive one, and it gives the count 0 where nothing else exists
    reward = np.where(stay_row, 0.0, 1.0)[perm]
    model = make_model(ModelType.MDP, groups, T, initial_states=(0,))
    target = np.zeros(n_states, dtype=bool)
    target[DONE] = True
    # by the caller's deadline the iteration stops with its upper values as far as they got,
    # still proven (a looser h, so a larger W, or none); policy iteration (the stiff
    # iteration's certificate) has no deadline, so it runs only without one
    result = expected_reach_reward(model, reward, target, maximize=np.ones(n_states, dtype=bool),
                                   options=SolverOptions(precision=1e-3, relative=True,
                                                         max_iterations=STEP_ITERATIONS,
                                                         deadline=deadline,
                                                         stiff_certificate=deadline is None))
    h = np.asarray(result.upper, dtype=np.float64)
    if not result.sound:
        return None
    return h[rep]


def contracts(enc: Enclosure, usable: np.ndarray, h: np.ndarray) -> bool:
    """Whether h (float64[vertices]) proves the rows ``usable`` (bool[rows]) a contraction in
    the h-weighted sup norm: h > 0 at every vertex and Σ_k coef_k h_k < h_v on every usable row
    of every vertex v, evaluated with rounding to +inf (the module docstring, "Rewards of both
    signs")."""
    h = np.asarray(h, dtype=np.float64)
    if h.size != enc.vertices or not bool((np.isfinite(h) & (h > 0)).all()):
        return False
    coef = enc.coef
    k = np.diff(coef.indptr).astype(np.float64)
    S = np.asarray(coef @ h).ravel()
    S = np.where(S > 0, np.nextafter(S * (1.0 + 2.0 * (k + 2.0) * _UNIT), np.inf), S)
    if enc.discount < 1.0:
        S = np.where(S > 0, np.nextafter(S * enc.discount, np.inf), S)
    return bool((S[usable] < h[enc.state[usable]]).all())


def _capped(enc: Enclosure, W: np.ndarray) -> np.ndarray:
    """Where W needs no check: a probability's 1 (V*_n <= 1 holds anyway, so the induction
    only needs min(1, R(W)) <= W)."""
    if enc.probability:
        return np.asarray(W >= 1.0)
    return np.zeros(W.shape, dtype=bool)


def certified_upper(enc: Enclosure, upper: np.ndarray, *, deadline: float | None = None
                    ) -> np.ndarray | None:
    """A vector W >= ``upper`` (float64[>= vertices], the engine's upper values of the float
    abstraction) over the vertices with R(W) <= W checked (the module docstring): W bounds the
    exact belief MDP's optimum at every vertex. None when no such W was found (a cycle of
    ambiguous rows, or non-finite values where they matter, or ``deadline``, a
    ``time.perf_counter()`` value, passed before the steps h were bounded; with rewards of both
    signs also when the steps prove no contraction, :func:`contracts`)."""
    V = enc.vertices
    U = np.asarray(upper, dtype=np.float64)[:V].copy()
    U = np.where(np.isnan(U), np.inf, U)
    if enc.probability:
        U = np.maximum(U, 0.0)
    usable = _usable_rows(enc, U)
    if enc.signed:
        # the contraction argument collapses nothing (a clean loop that never stops has no
        # finite steps, and then no bound is proven)
        mec_of, count = np.full(V, -1, dtype=np.int64), 0
    else:
        mec_of, count = _components(enc, usable)
    if count:
        best = np.full(count, -np.inf)
        inn = mec_of >= 0
        np.maximum.at(best, mec_of[inn], U[inn])
        U[inn] = best[mec_of[inn]]
    if enc.probability:
        U = np.minimum(U, 1.0)
    R = _checked(enc, U, usable)
    over = np.where((R > U) & ~_capped(enc, U), R - U, 0.0)
    over = np.where(np.isnan(over), np.inf, over)
    if not enc.signed and not (over > 0).any():
        return U
    h = _steps(enc, mec_of, count, usable, deadline)
    if h is None or (enc.signed and not contracts(enc, usable, h)):
        return None
    if not (over > 0).any():
        return U
    d0 = float(over.max())
    for factor in _RAISES:
        d = d0 * factor * (1.0 + 1e-6) + 4.0 * _UNIT * float(np.max(np.where(
            np.isfinite(U), U, 0.0), initial=0.0))
        W = _up(U + d * h * (1.0 + 4.0 * _UNIT))
        W = np.where(np.isnan(W), np.inf, W)
        if enc.probability:
            W = np.minimum(W, 1.0)
        R = _checked(enc, W, usable)
        if bool(((R <= W) | _capped(enc, W)).all()):
            return W
    return None
