"""A proven bound on what *any* strategy of a POMDP's agent achieves: the belief MDP
over-approximated on a Freudenthal grid and solved by the sound engines.

The optimum over all strategies (any memory, randomised) of a POMDP is the value V*(b0) of its
belief MDP at the initial belief. For the objectives here (reachability ``P[a U b]``, expected
reward until a target, discounted costs) V* is *convex* in the belief when the agent maximises
(a maximum of functions linear in b: one per strategy) and concave when it minimises. So if a
belief b is the convex combination Σ λ_i v_i of grid beliefs v_i, then V*(b) <= Σ λ_i V*(v_i)
(max; >= for min). Replacing every successor belief of the belief MDP by the grid vertices of
its simplex, with the λ_i as probabilities, gives a finite MDP whose value at b0 bounds V*(b0)
from the optimistic side (Lovejoy, "Computationally feasible bounds for partially observed
Markov decision processes", Oper. Res. 1991; Bork, Junges, Katoen, Quatmann, "Verification of
indefinite-horizon POMDPs", ATVA 2020, Theorem 2: the n-step values are convex too and the
step-bounded values converge to V* from below for reachability, so the bound holds for the
least fixed point). Grid vertices not expanded (the exploration budget ended) are *cut off*:
they get the full-observation bound Σ_s v(s) U(s), which holds for every belief (an agent that
sees the state does at least as well).

The grid is Freudenthal's triangulation at resolution N, taken on each belief's support (states
in their index order): in the coordinates x_i = N Σ_{j>=i} b_j the belief lies in the simplex
whose vertices are ⌊x⌋ plus the unit vectors added in the order of decreasing fractional part;
a vertex is an integer vector, so vertices are identified exactly (no float hashing). Any
decomposition into beliefs would be sound (only convexity is used); this one keeps the number of
distinct vertices small and nests for N, 2N, 4N, ...

The abstraction is an ordinary :class:`~posgmc.model.explicit.ExplicitModel` (an MDP: one state
per vertex, then a target and a sink), so it is checked with the same sound engines as any model
(interval iteration, end components handled) and the bound side of their result is the reported
bound. Its transition probabilities are computed in float64 (posterior beliefs, the weights λ):
they are exact up to rounding at the 1e-15 level, which the reported bound does not absorb.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.checking.dispatch import CheckOptions, PropertyChecker
from posgmc.engines.discounted import discounted_reach_reward
from posgmc.engines.options import SolverOptions
from posgmc.engines.reach import reach_probability
from posgmc.engines.result import EngineResult
from posgmc.engines.rewards import expected_reach_reward
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType
from posgmc.strategies.binding import player_view
from posgmc.synthesis.belief import _can_reach, applies
from posgmc.synthesis.jobs import Problem
from posgmc.synthesis.parametric import Layout

__all__ = ["GridAbstraction", "GridBound", "freudenthal", "grid_abstraction", "grid_bound",
           "full_observation_bounds", "RESOLUTIONS", "MAX_VERTICES", "PRECISION"]

RESOLUTIONS = tuple(2 ** i for i in range(1, 11))
"""The grid resolutions tried in turn while the budget lasts (each grid refines the previous)."""

MAX_VERTICES = 400_000
"""Grid vertices explored at most in one abstraction (the time budget usually ends it first)."""

PRECISION = 1e-8
"""The relative precision the abstraction is solved to (its bound side is what is reported)."""

_SNAP = 1e-9
"""Cumulative coordinates within this (relative to N) of an integer are that integer: float
noise in a posterior must not split a grid belief into a tiny simplex around it."""


def freudenthal(p: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices and weights of ``p`` (float64[m], a distribution, all entries > 0) in
    Freudenthal's triangulation of resolution N: (int64[k, m] counts, each row summing to N, so
    that vertex i is counts[i] / N; float64[k] weights λ > 0 summing to 1) with
    Σ_i λ_i counts[i] / N = p (up to rounding)."""
    m = p.size
    N = int(resolution)
    if m == 1:
        return np.full((1, 1), N, dtype=np.int64), np.ones(1)
    x = N * np.cumsum(p[::-1])[::-1]
    x[0] = N
    near = np.rint(x)
    x = np.where(np.abs(x - near) <= _SNAP * N, near, x)
    v = np.floor(x)
    d = x - v
    order = 1 + np.argsort(-d[1:], kind="stable")
    dd = d[order]
    lam = np.empty(m)
    lam[0] = 1.0 - dd[0]
    lam[1:m - 1] = dd[:-1] - dd[1:]
    lam[m - 1] = dd[-1]
    Y = np.tile(v, (m, 1))
    Y[:, order] += np.tri(m, m - 1, k=-1)
    counts = np.empty((m, m), dtype=np.int64)
    counts[:, :-1] = (Y[:, :-1] - Y[:, 1:]).astype(np.int64)
    counts[:, -1] = Y[:, -1].astype(np.int64)
    keep = lam > 0
    return counts[keep], lam[keep]


@dataclass(frozen=True, eq=False)
class GridAbstraction:
    """The finite over-approximation of a POMDP's belief MDP at one resolution.

    ``model``: the MDP (state i < ``vertices`` is grid vertex i, vertex 0 the initial belief; then
    the target and the sink); ``beliefs``: csr float64[vertices, S], each vertex's belief;
    ``expanded``: bool[vertices], False where the vertex is cut off (one choice giving its
    full-observation bound); ``action``: int64[C], the model's action index of each choice of an
    expanded vertex (-1 for cut-offs and sinks); ``rewards``: float64[C] (None for a
    probability); ``target``: bool[states]; ``discount``; ``maximize``; ``resolution``: N."""

    model: ExplicitModel
    beliefs: sp.csr_matrix
    expanded: np.ndarray
    action: np.ndarray
    rewards: np.ndarray | None
    target: np.ndarray
    discount: float
    maximize: bool
    resolution: int
    exact: bool
    """Complete and every successor belief is a grid vertex: the abstraction *is* the reachable
    belief MDP, so its optimum is the POMDP's (no finer grid can tighten it)."""

    @property
    def vertices(self) -> int:
        return int(self.beliefs.shape[0])

    @property
    def complete(self) -> bool:
        """Every vertex explored was expanded (no cut-off values are used)."""
        return bool(self.expanded.all())

    def solve(self, options: SolverOptions = SolverOptions()) -> EngineResult:
        """The abstraction's optimum per state by the sound engine of its objective."""
        mx = np.full(self.model.num_states, self.maximize)
        if self.rewards is None:
            return reach_probability(self.model, self.target, maximize=mx, options=options)
        if self.discount < 1.0:
            return discounted_reach_reward(self.model, self.rewards, self.target,
                                           discount=self.discount, maximize=mx, options=options)
        return expected_reach_reward(self.model, self.rewards, self.target, maximize=mx,
                                     options=options)


class _Dynamics:
    """The POMDP per action of its agent: continuing transitions, stopping gain, rewards."""

    def __init__(self, problem: Problem) -> None:
        model = problem.model
        self.S = S = model.num_states
        layout = Layout.of(model, problem.player)
        view = player_view(model, problem.player)
        self.mask = layout.mask
        self.actions = layout.used_actions
        obs_index = np.full(view.num_observations, -1, dtype=np.int64)
        obs_index[layout.used_obs] = np.arange(layout.used_obs.size)
        self.obs = obs_index[view.state_obs]
        self.Z = layout.used_obs.size
        if problem.rewards is None:
            # mass that cannot reach the target any more (within ``remain``) is worth 0
            self.cont = problem.remain & ~problem.target & _can_reach(model, problem.target,
                                                                      problem.remain)
        else:
            self.cont = ~problem.target
        act_index = np.full(len(model.action_names), -1, dtype=np.int64)
        act_index[layout.used_actions] = np.arange(layout.used_actions.size)
        c_act = act_index[model.choice_actions]
        cs = model.choice_states
        keep = sp.diags(self.cont.astype(np.float64))
        tgt = problem.target.astype(np.float64)
        self.P: list[sp.csr_matrix] = []
        self.stop: list[np.ndarray] = []
        self.reward: list[np.ndarray] = []
        for a in range(layout.used_actions.size):
            c = np.flatnonzero(c_act == a)
            T = model.transitions[c].tocoo()
            Pa = sp.csr_matrix((T.data, (cs[c][T.row], T.col)), shape=(S, S))
            self.stop.append(np.asarray(Pa @ tgt).ravel())
            self.P.append(sp.csr_matrix(Pa @ keep))
            r = np.zeros(S)
            if problem.rewards is not None:
                r[cs[c]] = problem.rewards[c]
            self.reward.append(r)


class _Grid:
    """The vertices found so far (mutable while exploring)."""

    def __init__(self, S: int, resolution: int) -> None:
        self.S, self.N = S, resolution
        self.key: dict[bytes, int] = {}
        self.rows: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []

    def vertex(self, idx: np.ndarray, counts: np.ndarray) -> int:
        nz = counts > 0
        i, c = idx[nz], counts[nz]
        k = i.tobytes() + c.tobytes()
        found = self.key.get(k)
        if found is None:
            found = len(self.rows)
            self.key[k] = found
            self.rows.append(i)
            self.vals.append(c / self.N)
        return found

    def matrix(self, first: int = 0, last: int | None = None) -> sp.csr_matrix:
        rows, vals = self.rows[first:last], self.vals[first:last]
        n = len(rows)
        indptr = np.zeros(n + 1, dtype=np.int64)
        indptr[1:] = np.cumsum([r.size for r in rows])
        data = np.concatenate(vals) if n else np.zeros(0)
        ind = np.concatenate(rows) if n else np.zeros(0, dtype=np.int64)
        return sp.csr_matrix((data, ind, indptr), shape=(n, self.S))


def full_observation_bounds(problem: Problem, deadline: float | None = None) -> np.ndarray:
    """float64[S]: a proven bound per state on what any strategy achieves — the upper end of the
    full-observation optimum when the agent maximises, the lower end when it minimises (interval
    iteration; an agent that sees the state does at least as well as one that does not)."""
    checker = PropertyChecker(problem.model, coalition_of=problem.coalition_of,
                              scalar=problem.scalar,
                              options=CheckOptions(solver=SolverOptions(deadline=deadline)))
    r = checker.query(problem.query, everywhere=True)
    if not r.sound:
        return np.full(problem.model.num_states, np.inf if problem.maximize else -np.inf)
    return np.asarray(r.upper if problem.maximize else r.lower, dtype=np.float64)


def grid_abstraction(problem: Problem, resolution: int, *, cutoff: np.ndarray,
                     deadline: float | None = None,
                     max_vertices: int = MAX_VERTICES) -> GridAbstraction | None:
    """The abstraction of ``problem`` (a POMDP with one initial state) at ``resolution``,
    explored breadth first from the initial belief until ``max_vertices`` or ``deadline``.

    Args:
        problem: the POMDP and its objective.
        resolution: N >= 1 (grid beliefs are multiples of 1/N).
        cutoff: float64[S], the bound per state used at cut-off vertices
            (:func:`full_observation_bounds`).

    Returns:
        The abstraction, or None when the initial state does not continue (nothing to bound) or
        the problem is not a POMDP.
    """
    if not applies(problem) or problem.model.initial_states.size != 1:
        return None
    dyn = _Dynamics(problem)
    s0 = int(problem.model.initial_states[0])
    if not dyn.cont[s0] or dyn.obs[s0] < 0:
        return None
    grid = _Grid(dyn.S, resolution)
    grid.vertex(np.array([s0], dtype=np.int64), np.array([resolution], dtype=np.int64))
    # choices, in vertex order: (vertex, action, target mass, reward, successor entries)
    c_vertex: list[np.ndarray] = []
    c_action: list[np.ndarray] = []
    c_stop: list[np.ndarray] = []
    c_reward: list[np.ndarray] = []
    e_choice: list[np.ndarray] = []  # entries: global choice id, vertex, probability
    e_vertex: list[np.ndarray] = []
    e_prob: list[np.ndarray] = []
    num_choices = 0
    on_grid = True  # every posterior so far is a vertex itself
    done = 0  # vertices [0, done) expanded
    while done < len(grid.rows) and done < max_vertices:
        if deadline is not None and time.perf_counter() > deadline:
            break
        last = min(len(grid.rows), max_vertices, done + max(64, done))
        B = grid.matrix(done, last)
        ids = np.arange(done, last)
        z = dyn.obs[np.asarray([grid.rows[i][0] for i in range(done, last)])]
        per_action = []
        for a in range(dyn.actions.size):
            sel = np.flatnonzero(dyn.mask[z, a]) if dyn.Z else np.zeros(0, dtype=np.int64)
            if sel.size:
                per_action.append((a, sel))
        # choices of the batch, ordered by vertex then action
        chosen_v = np.concatenate([ids[sel] for _, sel in per_action]) if per_action else \
            np.zeros(0, dtype=np.int64)
        chosen_a = np.concatenate([np.full(sel.size, a) for a, sel in per_action]) if \
            per_action else np.zeros(0, dtype=np.int64)
        order = np.lexsort((chosen_a, chosen_v))
        rank = np.empty(order.size, dtype=np.int64)
        rank[order] = num_choices + np.arange(order.size)
        pos = 0
        for a, sel in per_action:
            Ba = B[sel]
            D = sp.csr_matrix(Ba @ dyn.P[a])
            D.eliminate_zeros()
            cid = rank[pos:pos + sel.size]
            pos += sel.size
            c_stop.append(np.asarray(Ba @ dyn.stop[a]).ravel())
            c_reward.append(np.asarray(Ba @ dyn.reward[a]).ravel())
            c_vertex.append(ids[sel])
            c_action.append(np.full(sel.size, a, dtype=np.int64))
            # split each successor distribution by observation, triangulate each posterior
            coo = D.tocoo()
            if not coo.nnz:
                continue
            zz = dyn.obs[coo.col]
            pair = coo.row.astype(np.int64) * (dyn.Z + 1) + (zz + 1)
            o = np.lexsort((coo.col, pair))
            pair, col, data = pair[o], coo.col[o].astype(np.int64), coo.data[o]
            starts = np.flatnonzero(np.r_[True, pair[1:] != pair[:-1]])
            ends = np.r_[starts[1:], pair.size]
            for lo, hi in zip(starts.tolist(), ends.tolist()):
                w = float(data[lo:hi].sum())
                counts, lam = freudenthal(data[lo:hi] / w, resolution)
                on_grid = on_grid and lam.size == 1
                row = int(pair[lo] // (dyn.Z + 1))
                vs = [grid.vertex(col[lo:hi], c) for c in counts]
                e_choice.append(np.full(lam.size, cid[row], dtype=np.int64))
                e_vertex.append(np.asarray(vs, dtype=np.int64))
                e_prob.append(w * lam)
        num_choices += order.size
        done = last
    return _assemble(problem, dyn, grid, done, resolution, cutoff, c_vertex, c_action, c_stop,
                     c_reward, e_choice, e_vertex, e_prob, on_grid)


def _assemble(problem: Problem, dyn: _Dynamics, grid: _Grid, done: int, resolution: int,
              cutoff: np.ndarray, c_vertex: list[np.ndarray], c_action: list[np.ndarray],
              c_stop: list[np.ndarray], c_reward: list[np.ndarray], e_choice: list[np.ndarray],
              e_vertex: list[np.ndarray], e_prob: list[np.ndarray],
              on_grid: bool) -> GridAbstraction:
    """The abstraction MDP: expanded vertices with their choices, cut-off vertices with one
    choice worth their full-observation bound, then the target and the sink."""
    V = len(grid.rows)
    TARGET, SINK = V, V + 1
    S_abs = V + 2
    prob = problem.rewards is None

    def cat(parts: list[np.ndarray], dtype: type = np.float64) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)

    cv, ca = cat(c_vertex, np.int64), cat(c_action, np.int64)
    order = np.lexsort((ca, cv))
    cv, ca = cv[order], ca[order]
    stop, rew = cat(c_stop)[order], cat(c_reward)[order]
    n_exp = cv.size  # the expanded choices are numbered 0..n_exp-1 in (vertex, action) order
    # the successor entries, with the target and the sink
    ech, ev, ep = cat(e_choice, np.int64), cat(e_vertex, np.int64), cat(e_prob)
    cont_mass = np.bincount(ech, weights=ep, minlength=n_exp)
    rows = [ech, np.arange(n_exp)]
    cols = [ev, np.full(n_exp, TARGET)]
    vals = [ep, stop]
    if prob:
        loss = np.maximum(0.0, 1.0 - stop - cont_mass)
        rows.append(np.arange(n_exp))
        cols.append(np.full(n_exp, SINK))
        vals.append(loss)
    T_exp = sp.csr_matrix((cat(vals), (cat(rows, np.int64), cat(cols, np.int64))),
                          shape=(n_exp, S_abs))
    if not prob:
        # the successor masses sum to 1 up to rounding: renormalised (no mass may leak to a sink,
        # which for an expected reward would mean "never reaches the target")
        sums = np.asarray(T_exp.sum(axis=1)).ravel()
        T_exp = sp.csr_matrix(sp.diags(1.0 / np.where(sums > 0, sums, 1.0)) @ T_exp)
    # cut-off vertices [done, V): one choice worth Σ_s v(s) cutoff(s)
    cut_ids = np.arange(done, V)
    Bc = grid.matrix(done, V)
    finite = np.isfinite(cutoff)
    u = np.asarray(Bc @ np.where(finite, cutoff, 0.0)).ravel()
    unbounded = np.asarray(Bc @ (~finite).astype(np.float64)).ravel() > 0
    n_cut = cut_ids.size
    if prob:
        u = np.clip(u, 0.0, 1.0)
        u = np.where(unbounded, 1.0 if problem.maximize else 0.0, u)
        T_cut = sp.csr_matrix(
            (np.r_[u, 1.0 - u], (np.r_[np.arange(n_cut), np.arange(n_cut)],
                                  np.r_[np.full(n_cut, TARGET), np.full(n_cut, SINK)])),
            shape=(n_cut, S_abs))
        r_cut = np.zeros(n_cut)
    else:
        # an unbounded cut-off (an infinite expected reward) never reaches the target: PRISM's
        # R[F] is then infinite, for either direction
        dest = np.where(unbounded, SINK, TARGET)
        T_cut = sp.csr_matrix((np.ones(n_cut), (np.arange(n_cut), dest)), shape=(n_cut, S_abs))
        r_cut = np.where(unbounded, 0.0, u)
    T_sinks = sp.csr_matrix((np.ones(2), ([0, 1], [TARGET, SINK])), shape=(2, S_abs))
    transitions = sp.vstack([T_exp, T_cut, T_sinks], format="csr")
    per_state = np.zeros(S_abs, dtype=np.int64)
    np.add.at(per_state, cv, 1)
    per_state[cut_ids] = 1
    per_state[[TARGET, SINK]] = 1
    # expanded choices are in vertex order, and expanded vertices precede the cut-off ones
    choice_order = np.r_[np.arange(n_exp), n_exp + np.arange(n_cut), n_exp + n_cut + np.arange(2)]
    owner = np.r_[cv, cut_ids, [TARGET, SINK]]
    perm = np.lexsort((choice_order, owner))
    transitions = transitions[perm]
    row_groups = np.zeros(S_abs + 1, dtype=np.int64)
    row_groups[1:] = np.cumsum(per_state)
    action = np.r_[ca, np.full(n_cut + 2, -1, dtype=np.int64)][perm]
    model = make_model(ModelType.MDP, row_groups, transitions, initial_states=(0,))
    rewards = None
    if not prob:
        rewards = np.r_[rew, r_cut, np.zeros(2)][perm]
    target = np.zeros(S_abs, dtype=bool)
    target[TARGET] = True
    expanded = np.zeros(V, dtype=bool)
    expanded[:done] = True
    return GridAbstraction(model, grid.matrix(), expanded, action, rewards, target,
                           problem.discount, problem.maximize, resolution,
                           on_grid and done == V)


@dataclass(frozen=True)
class GridBound:
    """The best proven bound found: ``value`` bounds the optimum over all strategies from above
    when the agent maximises (below when it minimises); ``resolution``, ``vertices`` and
    ``complete`` describe the abstraction that proved it (``exact``: it is the reachable belief
    MDP itself, so the bound is the optimum up to the solver's precision); ``tried``:
    (resolution, bound) of every abstraction solved; ``seconds``: time spent."""

    value: float
    resolution: int
    vertices: int
    complete: bool
    exact: bool
    tried: tuple[tuple[int, float], ...]
    seconds: float


def grid_bound(problem: Problem, *, deadline: float, target: float | None = None,
               resolutions: tuple[int, ...] = RESOLUTIONS,
               cutoff: np.ndarray | None = None) -> GridBound | None:
    """Abstractions of growing resolution while time remains; the tightest proven bound.

    Args:
        problem: a POMDP with one initial state.
        deadline: ``time.perf_counter()`` value by which to stop (an abstraction whose
            exploration is cut short still proves a bound: its frontier is cut off).
        target: stop as soon as the bound reaches this value (the other side of the bracket).
        cutoff: the per-state bounds for cut-offs (default :func:`full_observation_bounds`).

    Returns:
        The bound, or None when no abstraction applies or none was solved soundly in time.
    """
    t0 = time.perf_counter()
    if not applies(problem) or problem.model.initial_states.size != 1:
        return None
    sign = 1.0 if problem.maximize else -1.0
    if cutoff is None:
        cutoff = full_observation_bounds(problem, deadline)
    best: GridBound | None = None
    tried: list[tuple[int, float]] = []
    for N in resolutions:
        now = time.perf_counter()
        if now > deadline:
            break
        # exploration may use most of what is left; the sound solve gets the rest
        explore_until = now + 0.6 * (deadline - now)
        abstraction = grid_abstraction(problem, N, cutoff=cutoff, deadline=explore_until)
        if abstraction is None:
            return None
        result = abstraction.solve(SolverOptions(precision=PRECISION, relative=True,
                                                 deadline=deadline, want_strategy=False))
        if not result.sound:
            continue
        value = float(result.upper[0] if problem.maximize else result.lower[0])
        tried.append((N, value))
        if best is None or sign * value < sign * best.value:
            best = GridBound(value, N, abstraction.vertices, abstraction.complete,
                             abstraction.exact, (), 0.0)
        if abstraction.exact or (target is not None and sign * best.value <= sign * target):
            break
    if best is None:
        return None
    return GridBound(best.value, best.resolution, best.vertices, best.complete, best.exact,
                     tuple(tried), time.perf_counter() - t0)
