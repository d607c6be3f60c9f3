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

The grid is Freudenthal's triangulation at resolution N, taken on each belief's support
(:mod:`posgmc.synthesis.freudenthal`): a vertex is an integer vector, so vertices are identified
exactly (no float hashing), and the grids nest for N, 2N, 4N, ...

The abstraction is an ordinary :class:`~posgmc.model.explicit.ExplicitModel` (an MDP: one state
per vertex, then a target and a sink), so it is checked with the same sound engines as any model
(interval iteration, end components handled) and the bound side of their result is the reported
bound. Its transition probabilities are computed in float64 (posterior beliefs, the weights λ).
A minimiser's choices are scaled below the exact belief successors, and stop masses, rewards and
cut-off values are rounded to the optimistic side (outward for either sign; a minimiser whose
rewards take both signs gets no grid, :func:`applies`), by the bounds of
:mod:`posgmc.synthesis.belief_rounding`. A maximiser's rows cannot dominate the exact ones one by
one in a cycle of beliefs (docs/synthesis.md, "Floating point"): its abstraction carries an
enclosure of the exact rows (certified weights, parts near a face triangulated in exact
arithmetic, :mod:`posgmc.synthesis.belief_exact`), and the engine's upper values are proven for
the exact belief MDP by :func:`~posgmc.synthesis.grid_certificate.certified_upper`. The game per
action of the decision maker and the adversary's rules tried at a vertex are
:mod:`posgmc.synthesis.belief_dynamics`'.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sp

from posgmc.checking.property_checker import CheckOptions, PropertyChecker
from posgmc.engines.discounted import discounted_reach_reward
from posgmc.engines.options import SolverOptions
from posgmc.engines.reach import reach_probability
from posgmc.engines.result import EngineResult
from posgmc.engines.rewards import expected_reach_reward
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType
from posgmc.synthesis import belief, stage_lp
from posgmc.synthesis.belief_dynamics import RULE_CAP, Dynamics, deterministic_picks
from posgmc.synthesis.belief_exact import (
    Source,
    exact_posterior,
    exact_rows,
    part_posterior,
    resolve_exactly,
    shared_parts,
)
from posgmc.synthesis.belief_rounding import (
    UNIT,
    chunks,
    dominate,
    entry_rounding,
    outward,
    reward_magnitude,
    rounding,
    up,
    weight_errors,
)
from posgmc.synthesis.budget import interrupted
from posgmc.synthesis.freudenthal import freudenthal, freudenthal_batch
from posgmc.synthesis.grid_certificate import Enclosure, certified_upper
from posgmc.synthesis.problem import Problem
from posgmc.synthesis.target_rules import TARGET_CAP, Targets, target_rules

__all__ = ["GridAbstraction", "GridBound", "CoarseBounds", "applies", "freudenthal",
           "UNFOLD_SHARE",
           "freudenthal_batch",
           "grid_abstraction", "grid_bound", "full_observation_bounds", "full_observation_floor",
           "RESOLUTIONS",
           "MAX_VERTICES", "PRECISION", "RULE_CAP"]

RESOLUTIONS = tuple(2 ** i for i in range(1, 11))
"""The grid resolutions tried in turn while the budget lasts (each grid refines the previous)."""

UNFOLD_SHARE = 0.25
"""The part of the vertex budget (and of the time) the belief unfolding may use before the
grids: a finite reachable belief set within it gives the optimum itself."""

MAX_VERTICES = 400_000
"""Grid vertices explored at most in one abstraction (the time budget usually ends it first)."""

PRECISION = 1e-8
"""The relative precision the abstraction is solved to (its bound side is what is reported)."""

MIX_CAP = 4
"""Randomised rules from stage LPs kept at one adversary vertex at most (the latest first)."""

LP_SHARE = 500
"""The stage LPs' budget: one adversary vertex's LPs per this many vertices of the grid's
budget (40 without ``--gap``, 800 with it), so that they cost a bounded share of the bound
side's work."""

MIX_ROUNDS = 4
"""Stage-LP rounds (solve, choose the adversary's mixtures, solve again) per resolution at most;
the rounds stop earlier when the bound no longer moves."""

_BATCH = 512
"""Vertices expanded between two looks at the clock."""


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
    """Complete and every successor belief is a grid vertex: on a POMDP the abstraction *is* the
    reachable belief MDP, so its optimum is the POMDP's (no finer grid can tighten it)."""
    adversary: np.ndarray
    """bool[states]: the adversary's vertices (a game's; none on a POMDP)."""
    enclosure: Enclosure | None = None
    """A maximiser's: the exact belief MDP's rows enclosed, to prove the bound for it
    (:func:`~posgmc.synthesis.grid_certificate.certified_upper`)."""

    @property
    def vertices(self) -> int:
        return int(self.beliefs.shape[0])

    @property
    def complete(self) -> bool:
        """Every vertex explored was expanded (no cut-off values are used)."""
        return bool(self.expanded.all())

    def solve(self, options: SolverOptions = SolverOptions()) -> EngineResult:
        """The abstraction's optimum per state by the sound engine of its objective."""
        mx = np.where(self.adversary, not self.maximize, self.maximize)
        if self.rewards is None:
            return reach_probability(self.model, self.target, maximize=mx, options=options)
        if self.discount < 1.0:
            return discounted_reach_reward(self.model, self.rewards, self.target,
                                           discount=self.discount, maximize=mx, options=options)
        return expected_reach_reward(self.model, self.rewards, self.target, maximize=mx,
                                     options=options)


class _Grid:
    """The vertices found so far (mutable while exploring). A vertex is identified by its
    support's state ids and counts (zero counts dropped), as the bytes of the int64 array
    [ids..., counts...]; new vertices are numbered in the order they are first referred to."""

    def __init__(self, S: int, resolution: int) -> None:
        self.S, self.N = S, resolution
        # grid vertices and float beliefs by bytes, exact beliefs by (states' bytes,
        # numerators, denominator)
        self.key: dict[bytes | tuple[bytes, tuple[int, ...], int], int] = {}
        self.rows: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        # the unfolding's exact beliefs where known (state -> numerator, and the common
        # denominator), else None
        self.exact: list[tuple[dict[int, int], int] | None] = []
        # the unfolding's explored beliefs as targets of the adversary's rules (None: not
        # tracked); ``origin``: the vertex whose choice is being added; ``owner_group``: per
        # state its decision maker's observation group, -1 for the adversary's
        self.targets: Targets | None = None
        self.origin = -1
        self.owner_group = np.zeros(0, dtype=np.int64)

    def exact_belief(self, idx: np.ndarray, nums: tuple[int, ...], den: int) -> int:
        """The vertex of the exact rational belief nums/den on states ``idx`` (resolution 0;
        nums and den without a common divisor): identified by its exact value, so paths that
        reach one belief share it; its float64 values are the correctly rounded quotients."""
        k = (idx.tobytes(), nums, den)
        found = self.key.get(k)
        if found is None:
            found = len(self.rows)
            self.key[k] = found
            self.rows.append(idx)
            self.vals.append(np.asarray([n / den for n in nums], dtype=np.float64))
            self.exact.append((dict(zip(idx.tolist(), nums)), den))
            if self.targets is not None:
                self.targets.found(found, self.origin, int(self.owner_group[idx[0]]),
                                   idx.tolist())
        return found

    def fractions(self, vertex: int) -> dict[int, Fraction] | None:
        """The unfolding's exact belief of ``vertex`` as fractions (None: not known exactly)."""
        e = self.exact[vertex] if vertex < len(self.exact) else None
        if e is None:
            return None
        nums, den = e
        return {s: Fraction(n, den) for s, n in nums.items()}

    def belief(self, key: bytes, idx: np.ndarray, p: np.ndarray, lo: int, hi: int) -> int:
        """The vertex of belief ``p[lo:hi]`` on states ``idx[lo:hi]`` (float64 and int64 arrays)
        itself (resolution 0: the belief unfolding), identified by its float64 bits: beliefs
        equal up to rounding but reached along different paths stay apart (no merging, so no
        belief is replaced by another). ``key``: the states' bytes then the posterior's, as the
        caller sliced them from the arrays' bytes (arrays are sliced only for a new vertex)."""
        found = self.key.get(key)
        if found is None:
            found = len(self.rows)
            self.key[key] = found
            self.rows.append(idx[lo:hi])
            self.vals.append(p[lo:hi].copy())
            self.exact.append(None)
            if self.targets is not None:
                self.targets.found(found, self.origin, -1, None)
        return found

    def vertex(self, idx: np.ndarray, counts: np.ndarray) -> int:
        nz = counts > 0
        i, c = idx[nz].astype(np.int64), counts[nz].astype(np.int64)
        k = i.tobytes() + c.tobytes()
        found = self.key.get(k)
        if found is None:
            found = len(self.rows)
            self._append(k, i, c)
        return found

    def _append(self, key: bytes, idx: np.ndarray, counts: np.ndarray) -> None:
        self.key[key] = len(self.rows)
        self.rows.append(idx)
        self.vals.append(counts / self.N)
        self.exact.append(None)

    def lookup(self, parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
               total: int) -> np.ndarray:
        """int64[total], the vertex of every reference, the new ones added: ``parts`` are
        (int64[r] ranks, int64[r, m] state ids, int64[r, m] counts), the ranks together a
        permutation of 0..total-1, the order the references are taken in. New vertices are
        numbered in that order, as one :meth:`vertex` call per reference in rank order would
        number them; but references to one vertex are merged first (sorting their keys), so
        the table is consulted once per distinct vertex, not once per reference."""
        ids = np.empty(total, dtype=np.int64)
        by_width: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
        for ranks, idx, counts in parts:
            nz = counts > 0
            q = nz.sum(axis=1)
            for width in np.unique(q).tolist():
                s = q == width
                keep = nz[s]
                by_width.setdefault(width, []).append((ranks[s], np.concatenate(
                    [idx[s][keep].reshape(-1, width), counts[s][keep].reshape(-1, width)],
                    axis=1)))
        fresh: list[tuple[int, bytes, int, np.ndarray]] = []  # (rank, key, unique, its table)
        solved: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        for width, group in by_width.items():
            ranks = np.concatenate([g[0] for g in group])
            K = np.concatenate([g[1] for g in group]).astype(np.int64)
            o = np.argsort(ranks, kind="stable")
            ranks, K = ranks[o], np.ascontiguousarray(K[o])
            view = K.view(np.dtype((np.void, 16 * width))).ravel()
            # first: the lowest-ranked reference to each distinct vertex (ranks are sorted)
            _, first, inverse = np.unique(view, return_index=True, return_inverse=True)
            found = np.empty(first.size, dtype=np.int64)
            for u, f in enumerate(first.tolist()):
                k = K[f].tobytes()
                v = self.key.get(k)
                if v is None:
                    fresh.append((int(ranks[f]), k, u, found))
                    v = -1
                found[u] = v
            solved.append((ranks, inverse.ravel(), found))
        fresh.sort(key=lambda x: x[0])
        for _, k, u, found in fresh:
            row = np.frombuffer(k, dtype=np.int64)
            w = row.size // 2
            found[u] = len(self.rows)
            self._append(k, row[:w].copy(), row[w:].copy())
        for ranks, inverse, found in solved:
            ids[ranks] = found[inverse]
        return ids

    def matrix(self, first: int = 0, last: int | None = None) -> sp.csr_matrix:
        rows, vals = self.rows[first:last], self.vals[first:last]
        n = len(rows)
        indptr = np.zeros(n + 1, dtype=np.int64)
        indptr[1:] = np.cumsum([r.size for r in rows])
        data = np.concatenate(vals) if n else np.zeros(0)
        ind = np.concatenate(rows) if n else np.zeros(0, dtype=np.int64)
        return sp.csr_matrix((data, ind, indptr), shape=(n, self.S))


def full_observation_bounds(problem: Problem,
                            deadline: float | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """A proven bound per state on what any strategy achieves — float64[S], the upper end of the
    full-observation optimum when the decision maker maximises, the lower end when it minimises
    (interval iteration; a decision maker that sees the state does at least as well as one that
    does not) — and the full-observation optimum's choice per state (int64[S], -1 where none;
    None when the solve gives none): the adversary's is the first rule the game abstraction
    tries."""
    checker = PropertyChecker(problem.model, coalition_of=problem.coalition_of,
                              scalar=problem.scalar,
                              options=CheckOptions(keep_strategy=True, solver=SolverOptions(
                                  deadline=deadline, stiff_certificate=deadline is None)))
    r = checker.query(problem.query, everywhere=True)
    strategy = None if r.engine is None or r.engine.strategy is None else \
        np.asarray(r.engine.strategy, dtype=np.int64)
    if not r.sound:
        return np.full(problem.model.num_states,
                       np.inf if problem.maximize else -np.inf), strategy
    return np.asarray(r.upper if problem.maximize else r.lower, dtype=np.float64), strategy


def _signed(problem: Problem) -> bool:
    """Whether the objective's rewards take both signs (some negative)."""
    return problem.rewards is not None and bool((np.asarray(problem.rewards) < 0).any())


def full_observation_floor(problem: Problem, deadline: float | None = None) -> np.ndarray:
    """A proven lower bound per state on the value of every strategy profile — float64[S], the
    lower end of the full-observation value when *both* players minimise (a strategy of the
    partially observing decision maker, started in state s, is one of the full-observation
    model's history-dependent randomised strategies, so its value from s is at least that
    minimum); -inf where none was proven (no finite bound, or the solve is unsupported)."""
    S = problem.model.num_states
    nowhere = np.zeros(S, dtype=bool)
    options = SolverOptions(deadline=deadline, want_strategy=False,
                            stiff_certificate=deadline is None)
    rewards = np.asarray(problem.rewards, dtype=np.float64)
    try:
        if problem.discount < 1.0:
            r = discounted_reach_reward(problem.model, rewards, problem.target,
                                        discount=problem.discount, maximize=nowhere,
                                        options=options)
        else:
            r = expected_reach_reward(problem.model, rewards, problem.target, maximize=nowhere,
                                      options=options)
    except UnsupportedError:
        return np.full(S, -np.inf)
    if not r.sound:
        return np.full(S, -np.inf)
    lower = np.asarray(r.lower, dtype=np.float64)
    return np.where(np.isnan(lower), -np.inf, lower)


def applies(problem: Problem) -> bool:
    """Whether the grid abstraction covers ``problem``: a POMDP, or a game of the decision maker
    against one omniscient adversary (any objective here: a probability, an expected reward until
    a target, a discounted cost), except a minimiser's rewards of both signs (its rows are
    scaled below the exact ones and the mass given up is priced at 0, which bounds V* from below
    only where V* >= 0: :func:`~posgmc.synthesis.belief_rounding.dominate`)."""
    if problem.model.initial_states.size != 1:
        return False
    if not problem.maximize and _signed(problem):
        return False
    if belief.applies(problem):
        return True
    return problem.adversary is not None and len(problem.model.player_names) == 2


def _unfolded_vertices(grid: _Grid, col: np.ndarray, post: np.ndarray, starts: np.ndarray,
                       sizes: np.ndarray, rows: np.ndarray, ys: dict[int, dict[int, int]],
                       sigs: list[tuple[int, int, bytes, tuple[tuple[int, int], ...]] | None],
                       beliefs: list[tuple[dict[int, int], int] | None], dyn: Dynamics,
                       origins: list[int] | None = None) -> tuple[list[int], list[int]]:
    """The unfolding's vertex of every part (part j on states ``col[a:a + k]``, int64, with
    float posterior ``post[a:a + k]``, a = ``starts[j]``, k = ``sizes[j]``, of row
    ``rows[j]``), the new ones added in the order of the parts, and the parts whose posterior
    is exact. A part with a signature (:func:`shared_parts`) takes the vertex of the first
    part with the same one (its exact posterior computed once, :func:`part_posterior`); one
    whose row's exact vector is in ``ys`` its exact posterior's (:func:`exact_posterior`);
    where none is kept, its float posterior's (:meth:`_Grid.belief`). Each part's key is looked
    up as byte slices of the arrays' bytes: arrays are sliced only for a new vertex.
    ``origins``: each row's vertex, where the grid tracks the explored beliefs as targets
    (:attr:`_Grid.targets`): a new vertex records the vertex whose choice reached it."""
    col_b, post_b = col.tobytes(), post.tobytes()
    col_l = col.tolist()
    vs: list[int] = []
    settled: list[int] = []  # the parts whose posterior is exact
    add_vertex, find, known = vs.append, ys.get, grid.key.get
    shared: dict[object, int | None] = {}  # a signature's vertex (None: its float posterior's)
    for j, (a, k, r, sig) in enumerate(zip(starts.tolist(), sizes.tolist(), rows.tolist(),
                                           sigs)):
        if sig is not None and sig in shared:
            v = shared[sig]
        else:
            if sig is None:
                y = find(r)
                got = None if y is None else exact_posterior(y, col_l[a:a + k])
            else:
                at_vertex = beliefs[r]
                assert at_vertex is not None  # a signature's row has an exact belief
                got = part_posterior(sig[3], at_vertex, col_l[a:a + k], dyn)
            v = None
            if got is not None:
                v = known((col_b[8 * a:8 * (a + k)], *got))
                if v is None:
                    if origins is not None:
                        grid.origin = origins[r]
                    v = grid.exact_belief(col[a:a + k], *got)
            if sig is not None:
                shared[sig] = v
        if v is not None:
            add_vertex(v)
            settled.append(j)
            continue
        key = col_b[8 * a:8 * (a + k)] + post_b[8 * a:8 * (a + k)]
        v = known(key)
        if v is None:
            if origins is not None:
                grid.origin = origins[r]
            v = grid.belief(key, col, post, a, a + k)
        add_vertex(v)
    return vs, settled


class _Choices:
    """The abstraction's choices while exploring: a key (vertex · span + local index) each, its
    target mass and reward, and its successor entries (by key)."""

    def __init__(self, span: int, cap: np.ndarray | None = None) -> None:
        self.span = span
        # the full-observation bound per state (what an ambiguous part's uncovered mass is worth
        # at most); None: not tracked (a minimiser's abstraction)
        self.cap = cap
        self.e_eta: list[np.ndarray] = []  # per entry: η (inf: an ambiguous part's)
        self.a_key: list[np.ndarray] = []  # per ambiguous part: its choice, leak and slack
        self.a_leak: list[np.ndarray] = []
        self.a_slack: list[np.ndarray] = []
        self.key: list[np.ndarray] = []
        self.action: list[np.ndarray] = []
        self.stop: list[np.ndarray] = []
        self.lost: list[np.ndarray] = []
        self.reward: list[np.ndarray] = []
        self.e_key: list[np.ndarray] = []
        self.e_vertex: list[np.ndarray] = []
        self.e_prob: list[np.ndarray] = []
        self.successors: list[sp.csr_matrix] = []
        self.terms: list[np.ndarray] = []
        self.on_grid = True  # every successor part so far is a vertex itself

    def add(self, keys: np.ndarray, action: np.ndarray, stop: np.ndarray, lost: np.ndarray,
            reward: np.ndarray, D: sp.csr_matrix, terms: np.ndarray, dyn: Dynamics, grid: _Grid,
            block: np.ndarray | None = None,
            source: Source | None = None) -> None:
        """Choices ``keys`` whose continuing successor distributions are the rows of ``D``:
        each row split into its groups (one per observation of the decision maker's states, one
        for the others; a convex decomposition, so the bound stays sound), each part normalised
        and triangulated (on the belief unfolding, resolution 0, each part is a vertex itself).
        ``terms``: int64[len(keys)], the nonnegative products summed into each entry of a row of
        ``D`` (and its stop mass and reward) at most, for the rounding bound (:func:`dominate`);
        ``D`` is kept as the successors the abstraction must dominate. ``block`` (int64 per
        row, ascending; default all 0): rows of different blocks are as if added by separate
        calls, one block after the other (the order new grid vertices are numbered in).
        ``source`` (a maximiser's, for :func:`resolve_exactly`): what ``D`` is made of."""
        self.key.append(keys)
        self.action.append(action)
        self.stop.append(stop)
        self.lost.append(lost)
        self.reward.append(reward)
        D = sp.csr_matrix(D)
        self.successors.append(D)
        self.terms.append(np.asarray(terms, dtype=np.int64))
        coo = D.tocoo()
        if not coo.nnz:
            return
        grp = dyn.group[coo.col]
        pair = coo.row.astype(np.int64) * (dyn.Z + 1) + grp
        o = np.lexsort((coo.col, pair))
        pair, col, data = pair[o], coo.col[o].astype(np.int64), coo.data[o]
        starts = np.flatnonzero(np.r_[True, pair[1:] != pair[:-1]])
        sizes = np.diff(np.r_[starts, pair.size])
        rows = pair[starts] // (dyn.Z + 1)
        row_block = np.zeros(D.shape[0], dtype=np.int64) if block is None else block
        mass = np.add.reduceat(data, starts)
        N = grid.N
        rel = entry_rounding(np.asarray(terms, dtype=np.int64), dyn.input_rel)
        if N == 0:  # the belief unfolding: each posterior is a vertex itself
            exact = self.cap is not None and source is not None and \
                source.beliefs is not None and not dyn.owned.all()
            amb = np.ones(rows.size, dtype=bool)
            # only where the row loses nothing (as on the grids: a row that does is in no
            # end component, and its leak costs at most the expected steps times itself)
            ys: dict[int, dict[int, int]] = {}
            sigs: list[tuple[int, int, bytes, tuple[tuple[int, int], ...]] | None] = \
                [None] * starts.size
            beliefs: list[tuple[dict[int, int], int] | None] = []
            if exact and source is not None and source.beliefs is not None:
                # and the rows whose exact rule lands on an explored belief, lossy or not
                given = np.zeros(D.shape[0], dtype=bool)
                if source.exact_rules:
                    given[np.fromiter(source.exact_rules, dtype=np.int64)] = True
                live = np.unique(rows[(lost[rows] == 0) | given[rows]]).astype(np.int64)
                beliefs = source.beliefs
                known = [beliefs[r] is not None for r in live.tolist()]
                live = live[known] if live.size else live
                sigs, live = shared_parts(source, live, rows, starts, sizes, col,
                                          keys // self.span, dyn)
                ys = exact_rows(source, live, dyn)
            vs, settled = _unfolded_vertices(
                grid, col, data / np.repeat(mass, sizes), starts, sizes, rows, ys, sigs, beliefs,
                dyn, None if grid.targets is None else (keys // self.span).tolist())
            amb[settled] = False
            self.e_key.append(keys[rows].astype(np.int64))
            self.e_vertex.append(np.asarray(vs, dtype=np.int64))
            self.e_prob.append(mass)
            if self.cap is not None:
                # an exact posterior's part weighs its float mass, within rel of the exact one;
                # a float posterior is not the exact one: the part is ambiguous,
                # |y*_s - w fl(y_s / w)| <= y_s (rel + 2u)
                r = rel[rows]
                self.e_eta.append(np.where(amb, np.inf,
                                           (r + (sizes + 4) * UNIT) * 1.02 + 4.0 * UNIT))
                loose = np.flatnonzero(amb)
                if loose.size:
                    self.a_key.append(keys[rows[loose]].astype(np.int64))
                    self.a_leak.append(up(np.add.reduceat(
                        data * self.cap[col] * (rel[pair // (dyn.Z + 1)] + 2.0 * UNIT) * 1.02,
                        starts)[loose]))
                    self.a_slack.append(up(mass * (r + (sizes + 2) * UNIT) * 1.02)[loose])
            return
        # the parts of one support size together: one vectorised triangulation each; the
        # references to grid vertices are then taken in the order of one call per block, per
        # support size, per part, per vertex of its simplex
        order_keys: list[tuple[np.ndarray, ...]] = []
        refs: list[tuple[np.ndarray, np.ndarray]] = []
        e_key: list[np.ndarray] = []
        e_prob: list[np.ndarray] = []
        e_eta: list[np.ndarray] = []
        for m, sel in chunks(sizes):
            at = starts[sel][:, None] + np.arange(m)[None, :]
            w = mass[sel]
            P = data[at] / w[:, None]
            counts, lam = freudenthal_batch(P, N)
            cols = col[at]
            keep = lam > 0
            if self.cap is not None:
                eta, amb, dmax = weight_errors(P, lam, rel[rows[sel]], N)
                # only where the row loses nothing: a row that does is in no end component, and
                # a leak there costs at most the expected number of steps times itself
                todo = np.flatnonzero(amb & (lost[rows[sel]] == 0))
                if todo.size and source is not None and N & (N - 1) == 0:
                    resolve_exactly(todo, rows[sel], cols, counts, lam, eta, amb,
                                    rel[rows[sel]], source, dyn, N)
                    keep = lam > 0
                self._enclose(P, w, cols, rel[rows[sel]], keys[rows[sel]], N, keep, e_eta,
                              eta, amb, dmax)
            self.on_grid = self.on_grid and bool((keep.sum(axis=1) == 1).all())
            i, k = np.nonzero(keep)
            r = rows[sel][i]
            order_keys.append((k, starts[sel][i], np.full(i.size, m), row_block[r]))
            refs.append((cols[i], counts[i, k]))
            e_key.append(keys[r].astype(np.int64))
            e_prob.append(w[i] * lam[i, k])
        total = sum(k.size for k, *_ in order_keys)
        seq = np.lexsort(tuple(np.concatenate(c) for c in zip(*order_keys)))
        rank = np.empty(total, dtype=np.int64)
        rank[seq] = np.arange(total)
        parts, at0 = [], 0
        for cols, counts in refs:
            parts.append((rank[at0:at0 + cols.shape[0]], cols, counts))
            at0 += cols.shape[0]
        self.e_key.append(np.concatenate(e_key)[seq])
        self.e_vertex.append(grid.lookup(parts, total))  # in rank order
        self.e_prob.append(np.concatenate(e_prob)[seq])
        if self.cap is not None:
            self.e_eta.append(np.concatenate(e_eta)[seq])

    def _enclose(self, P: np.ndarray, w: np.ndarray, cols: np.ndarray,
                 rel: np.ndarray, keys: np.ndarray, N: int, keep: np.ndarray,
                 e_eta: list[np.ndarray], eta: np.ndarray, amb: np.ndarray,
                 dmax: np.ndarray) -> None:
        """The exact weights' enclosure of triangulated parts (:func:`weight_errors`): η per
        kept vertex (inf in an ambiguous part), and per ambiguous part its leak
        Σ_s cap(s) |y*_s - x_s| and slack (how much its float weights may exceed its exact
        mass), x = Σ_k e_k u_k the float weights' combination:
        |y*_s - x_s| <= w ((rel + (m + 1) u) (P_s + 2Δ'/N) + 2Δ'/N), and
        Σ_k e_k - w* <= w (rel + (2m + 2) u)."""
        u = UNIT
        m = P.shape[1]
        assert self.cap is not None
        i, k = np.nonzero(keep)
        e_eta.append(np.where(amb[i], np.inf, eta[i, k]))
        if not amb.any():
            return
        a = np.flatnonzero(amb)
        shift = 2.0 * dmax[a, None] / N
        r = (rel[a, None] + (m + 1) * u) * 1.02
        c = self.cap[cols[a]]
        per = (r * (P[a] + shift) + shift) * 1.02
        with np.errstate(invalid="ignore"):
            leak = np.where(per > 0, per * c, 0.0).sum(axis=1)
        self.a_key.append(keys[a].astype(np.int64))
        self.a_leak.append(up(w[a] * leak * (1.0 + 2.0 * (m + 2) * u)))
        self.a_slack.append(up(w[a] * (rel[a] + (2 * m + 2) * u) * 1.02))


@dataclass(frozen=True, eq=False)
class CoarseBounds:
    """A solved coarser abstraction, as bounds for a finer one's cut-offs: ``resolution`` N,
    ``values`` float64[vertices] (the bound side of each vertex's value, proven: each vertex is
    the initial belief of the same abstraction started there), and ``key`` the vertex of each
    (support, counts) pair."""

    resolution: int
    values: np.ndarray
    key: dict[bytes, int]

    @staticmethod
    def of(abstraction: GridAbstraction, values: np.ndarray) -> CoarseBounds:
        B = abstraction.beliefs
        N = abstraction.resolution
        key = {}
        for i in range(B.shape[0]):
            lo, hi = B.indptr[i], B.indptr[i + 1]
            counts = np.rint(B.data[lo:hi] * N).astype(np.int64)
            key[B.indices[lo:hi].astype(np.int64).tobytes() + counts.tobytes()] = i
        return CoarseBounds(N, values[:B.shape[0]], key)

    def bounds(self, idx: list[np.ndarray], p: list[np.ndarray],
               cap: np.ndarray | None) -> np.ndarray:
        """float64[len(idx)]: for each belief (``p[j]`` on states ``idx[j]``) a proven bound on
        its optimum by convexity over the coarse grid's simplex around it: Σ λ_i W(u_i), made to
        hold under floating point as in :func:`dominate` (the weights scaled so that the
        combination stays below the belief, and when maximising what it leaves uncovered added
        at ``cap`` per state; ``cap`` None: minimising). NaN where one of the simplex's vertices
        is not in the coarse abstraction."""
        out = np.full(len(idx), np.nan)
        sizes = np.asarray([i.size for i in idx], dtype=np.int64)
        N = self.resolution
        for m, sel in chunks(sizes):
            P = np.stack([p[j] for j in sel.tolist()])
            cols = np.stack([idx[j] for j in sel.tolist()])
            counts, lam = freudenthal_batch(P, N)
            used = lam > 0
            r, k = np.nonzero(used)
            vid = np.full(lam.shape, -1, dtype=np.int64)
            vid[r, k] = [self.key.get(cols[a][c > 0].tobytes() + c[c > 0].tobytes(), -1)
                         for a, c in zip(r.tolist(), counts[r, k])]
            known = ~(used & (vid < 0)).any(axis=1)
            vals = np.where(used, self.values[np.maximum(vid, 0)], 0.0)
            total = (lam * vals).sum(axis=1)
            x = np.einsum("nk,nks->ns", lam, counts / N)
            grow = rounding(used.sum(axis=1) + 1)[:, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(x > 0, P * (1.0 - 2.0 * UNIT) / (x * (1.0 + grow)), np.inf)
            kappa = np.clip(ratio.min(axis=1) * (1.0 - 4.0 * UNIT), 0.0, 1.0)
            g = grow[:, 0]
            if cap is None:
                bound = np.maximum(0.0, kappa * total * (1.0 - g - 4.0 * UNIT))
            else:
                c = cap[cols]
                left = np.maximum(P - kappa[:, None] * x, 0.0) * (1.0 + 2.0 * UNIT) \
                    + grow * (x + P)
                extra = np.where(left > 0, left * np.where(np.isfinite(c), c, 0.0), 0.0).sum(
                    axis=1)
                extra[((left > 0) & ~np.isfinite(c)).any(axis=1)] = np.inf
                bound = up(kappa * total * (1.0 + g) + extra * (1.0 + rounding(m)))
            out[sel[known]] = bound[known]
        return out


def grid_abstraction(problem: Problem, resolution: int, *, cutoff: np.ndarray,
                     deadline: float | None = None, max_vertices: int = MAX_VERTICES,
                     adversary_rules: np.ndarray | None = None,
                     coarse: CoarseBounds | None = None,
                     mixtures: Mixtures | None = None,
                     floor: np.ndarray | None = None,
                     targets: bool = False) -> GridAbstraction | None:
    """The abstraction of ``problem`` at ``resolution``, explored breadth first from the initial
    belief until ``max_vertices`` or ``deadline``.

    On a POMDP the vertices are the agent's beliefs and the abstraction is an MDP. On a game
    (:func:`applies`) there are two kinds of vertices: the decision maker's beliefs over its
    states of one observation, where it chooses an action, and distributions over the other
    states, where the adversary chooses a decision rule (a choice per state of the support; at
    most :data:`RULE_CAP` rules, tried from ``adversary_rules``); the abstraction is a game.
    The value of a one-sided game (a partially observing maximiser against an omniscient
    adversary) is convex in the decision maker's belief (Horák, Bošanský, Pěchouček, AAAI
    2017: for a fixed strategy of the decision maker the adversary best-responds state by
    state, so the value is linear in the belief), and fixing the adversary's rule for one step
    can only help the decision maker, so the abstraction's value bounds the game's optimum.

    Args:
        problem: the POMDP or game and its objective.
        resolution: N >= 1 (grid beliefs are multiples of 1/N), or 0: the belief unfolding
            (every posterior is a vertex itself; complete, it is the reachable belief MDP).
        cutoff: float64[S], the bound per state used at cut-off vertices
            (:func:`full_observation_bounds`).
        adversary_rules: int64[S], the adversary's preferred choice per state (the
            full-observation optimum's), or None.
        coarse: a solved coarser abstraction; a cut-off vertex then gets the tighter of its
            full-observation bound and its coarse simplex's interpolated bound.
        mixtures: randomised rules offered to the adversary at some of its vertices besides
            the deterministic ones (:func:`stage_mixtures`).
        floor: float64[S], a maximiser's proven lower bound per state on every strategy's
            value (:func:`full_observation_floor`), needed with rewards of both signs only
            (computed when None).
        targets: on a game's unfolding (resolution 0), also offer the adversary the randomised
            rules whose posterior is exactly a belief already explored
            (:mod:`posgmc.synthesis.target_rules`), so that the unfolding may close where the
            adversary keeps the decision maker guessing.

    Returns:
        The abstraction, or None when it does not apply (:func:`applies`) or the initial state
        does not continue (nothing to bound).
    """
    if not applies(problem):
        return None
    dyn = Dynamics(problem, adversary_rules)
    s0 = int(problem.model.initial_states[0])
    if not dyn.cont[s0] or (dyn.owned[s0] and dyn.group[s0] < 0):
        return None
    grid = _Grid(dyn.S, resolution)
    if resolution == 0 and targets and not dyn.owned.all():
        grid.targets = Targets()
        grid.owner_group = np.where(dyn.owned, dyn.group, -1)
    if resolution == 0:
        grid.exact_belief(np.array([s0], dtype=np.int64), (1,), 1)
    else:
        grid.vertex(np.array([s0], dtype=np.int64), np.array([resolution], dtype=np.int64))
    Au = dyn.actions.size
    cap = None
    if problem.maximize:
        # an ambiguous part's uncovered mass is worth at most cap(s) per state; with negative
        # rewards what it covers in excess may be worth less than nothing, unbounded: no leak
        # is finite then
        cap = _caps(cutoff, problem.rewards is None)
        if _signed(problem):
            # with rewards of both signs what it covers in excess is worth at least floor(s)
            # per state, so |y*_s - x_s| is worth max(cap(s), -floor(s), 0)
            if floor is None:
                floor = full_observation_floor(problem)
            cap = np.maximum(np.maximum(cap, -floor), 0.0)
    choices = _Choices(Au + RULE_CAP + 1 + MIX_CAP + TARGET_CAP, cap)
    done = 0  # vertices [0, done) expanded, except those in ``skipped``
    skipped: list[int] = []
    while done < len(grid.rows) and done < max_vertices:
        if (deadline is not None and time.perf_counter() > deadline) or interrupted():
            break
        last = min(len(grid.rows), max_vertices, done + min(_BATCH, max(64, done)))
        ids = np.arange(done, last)
        B = grid.matrix(done, last)
        first = B.indices[B.indptr[:-1]]  # each vertex's first state (its rows are not empty)
        mine = dyn.owned[first]
        z = dyn.group[first]
        for a in range(Au):
            sel = np.flatnonzero(mine & (z >= 0))
            sel = sel[dyn.mask[z[sel], a]]
            if not sel.size:
                continue
            Ba = B[sel]
            choices.add(ids[sel] * choices.span + a, np.full(sel.size, a, dtype=np.int64),
                        np.asarray(Ba @ dyn.stop[a]).ravel(), np.asarray(Ba @ dyn.lost[a]).ravel(),
                        np.asarray(Ba @ dyn.reward[a]).ravel(), Ba @ dyn.P[a],
                        np.diff(Ba.indptr) + dyn.row_terms, dyn, grid,
                        source=Source(Ba, dyn.choice_of[a], beliefs=None if resolution else
                                      [grid.exact[v] for v in ids[sel].tolist()]))
        theirs = done + np.flatnonzero(~mine)
        if theirs.size and deadline is not None and time.perf_counter() > deadline:
            skipped.extend(theirs.tolist())  # the adversary's vertices are cut off
        elif theirs.size:
            _adversary_choices(theirs, dyn, grid, choices, Au, mixtures)
        done = last
    expanded = np.zeros(len(grid.rows), dtype=bool)
    expanded[:done] = True
    expanded[skipped] = False
    return _assemble(problem, dyn, grid, expanded, resolution, cutoff, choices, coarse)


def _adversary_choices(vertices: np.ndarray, dyn: Dynamics, grid: _Grid, choices: _Choices,
                       first_local: int, mixtures: Mixtures | None = None) -> None:
    """The choices of the adversary's ``vertices`` (one per decision rule :meth:`Dynamics.rules`
    tries there, then the randomised rules ``mixtures`` offers there), added to ``choices``
    together: one block per vertex, the vertices in the given order and each one's rules in the
    order of :meth:`Dynamics.rules`.

    Vertices whose support states offer the same numbers of choices share the structure of their
    rules, so the entries are laid out for each such group at once (:func:`_rule_entries`);
    only the randomised rules of ``mixtures`` are looked up vertex by vertex."""
    rg = dyn.model.row_groups
    per_state = np.diff(rg)
    states_of = [grid.rows[v] for v in vertices.tolist()]
    mass_of = [grid.vals[v] for v in vertices.tolist()]
    sizes = np.fromiter((s.size for s in states_of), dtype=np.int64, count=len(states_of))
    # per group of vertices: each entry's vertex (its position), rule, global choice, the rule's
    # probability of the choice and its state's belief mass
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    rules_at = np.zeros(vertices.size, dtype=np.int64)
    for m in np.unique(sizes).tolist():
        at_m = np.flatnonzero(sizes == m)
        St = np.stack([states_of[i] for i in at_m.tolist()]).astype(np.int64)
        Pm = np.stack([mass_of[i] for i in at_m.tolist()])
        n_all = per_state[St]
        shapes, which = np.unique(n_all, axis=0, return_inverse=True)
        for j in range(shapes.shape[0]):
            sel = np.flatnonzero(which.ravel() == j)
            k, vi, r, col, prob, p_s = _rule_layout(dyn, shapes[j], St[sel], Pm[sel])
            parts.append((at_m[sel][vi], r, col, prob, p_s))
            rules_at[at_m[sel]] = k
    extras: list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    if mixtures is not None:
        for i, (states, p) in enumerate(zip(states_of, mass_of)):
            extra = mixtures.at(states, p, grid.N)
            if extra is None:
                continue
            cols, _ = dyn.rules(states)
            owner = np.repeat(np.arange(states.size), per_state[states])
            r2, c2 = np.nonzero(extra[:MIX_CAP])
            extras.append((i, r2 + rules_at[i], cols[c2], extra[r2, c2], p[owner[c2]]))
            rules_at[i] += min(extra.shape[0], MIX_CAP)
    # the unfolding's rules that land on explored beliefs, each kept exact (row -> its rule)
    exact_rules: dict[int, dict[int, Fraction]] = {}
    at_row: list[tuple[int, int, dict[int, Fraction]]] = []
    if grid.targets is not None and dyn.cont.any():
        for i, v in enumerate(vertices.tolist()):
            belief_v = grid.fractions(v)
            states = states_of[i]
            if belief_v is None or per_state[states].max() <= 1:
                continue
            cols, _ = dyn.rules(states)
            owner = np.repeat(np.arange(states.size), per_state[states])
            found = target_rules(v, belief_v, cols, owner, states, dyn.integer_row, dyn.cont,
                                 grid.owner_group, grid.targets, grid.fractions, _near_grid)
            for rule in found[:TARGET_CAP]:
                c2 = np.fromiter(sorted(rule), dtype=np.int64)
                q2 = np.asarray([float(rule[c]) for c in c2.tolist()])
                p2 = np.asarray([float(belief_v[int(s)]) for s in
                                 dyn.choice_states[c2].tolist()])
                extras.append((i, np.full(c2.size, rules_at[i]), c2, q2, p2))
                at_row.append((i, int(rules_at[i]), rule))
                rules_at[i] += 1
    # each vertex's rows in the given order of the vertices
    first_row = np.r_[0, np.cumsum(rules_at)[:-1]]
    for pos, local, rule in at_row:
        exact_rules[int(first_row[pos]) + local] = rule
    n_rows = int(rules_at.sum())
    rows = [first_row[pos] + r for pos, r, _, _, _ in parts]
    cols_ = [c for _, _, c, _, _ in parts]
    probs = [q for _, _, _, q, _ in parts]
    masses = [p_s for _, _, _, _, p_s in parts]
    for i, r2, c2, q2, p2 in extras:
        rows.append(first_row[i] + r2)
        cols_.append(c2)
        probs.append(q2)
        masses.append(p2)
    # the same layout three times: each entry's weight, its rule's probability, its state's mass
    r_all, c_all = np.concatenate(rows), np.concatenate(cols_)
    where = sp.csr_matrix((np.arange(1, r_all.size + 1, dtype=np.float64), (r_all, c_all)),
                          shape=(n_rows, dyn.model.num_choices))
    perm = where.data.astype(np.int64) - 1
    q_all, p_all = np.concatenate(probs)[perm], np.concatenate(masses)[perm]
    W_all = sp.csr_matrix((q_all * p_all, where.indices, where.indptr), shape=where.shape)
    rule = sp.csr_matrix((q_all, where.indices, where.indptr), shape=where.shape)
    mass = sp.csr_matrix((p_all, where.indices, where.indptr), shape=where.shape)
    # the rows triangulated again in exact arithmetic on a grid: deterministic rules and the
    # offered mixtures (a grid rule's posterior is a vertex, and a leak in a cycle the decision
    # maker keeps to proves nothing); not the uniform mixture of every vertex, which would
    # multiply the exact work (rover's default bracket 70 % slower) and stays ambiguous
    resolve = np.ones(n_rows, dtype=bool)
    n_parts = sum(r.size for r in rows[:len(parts)])
    np.logical_and.at(resolve, r_all[:n_parts], np.concatenate(probs[:len(parts)]) == 1.0)
    owner_row = np.repeat(np.arange(vertices.size), rules_at)
    local = np.arange(n_rows) - first_row[owner_row]
    choices.add(vertices[owner_row] * choices.span + first_local + local,
                np.full(n_rows, -1, dtype=np.int64),
                np.asarray(W_all @ dyn.T_stop).ravel(), np.asarray(W_all @ dyn.T_lost).ravel(),
                np.asarray(W_all @ dyn.choice_reward).ravel(), W_all @ dyn.T_cont,
                np.diff(W_all.indptr) + dyn.row_terms, dyn, grid, block=vertices[owner_row],
                source=Source(W_all, np.arange(dyn.model.num_choices), mass, rule,
                              None if grid.N else
                              [grid.exact[v] for v in vertices[owner_row].tolist()],
                              resolve, exact_rules or None))


TARGET_RESOLUTION = 2
"""The grid whose vertices around the uniform mixture's posterior the unfolding's adversary may
also aim at exactly (:func:`_near_grid`)."""


def _near_grid(states: np.ndarray, y: np.ndarray) -> list[dict[int, Fraction]]:
    """The vertices of the :data:`TARGET_RESOLUTION` grid's simplex around the posterior ``y``
    (a mass on ``states``) as exact beliefs, heaviest weight first."""
    if y.sum() <= 0:
        return []
    counts, lam = freudenthal(y / y.sum(), TARGET_RESOLUTION)
    out: list[dict[int, Fraction]] = []
    for i in np.argsort(-lam, kind="stable").tolist():
        if lam[i] <= 0:
            continue
        out.append({int(s): Fraction(int(c), TARGET_RESOLUTION)
                    for s, c in zip(states.tolist(), counts[i].tolist()) if c > 0})
    return out


def _caps(cutoff: np.ndarray, probability: bool) -> np.ndarray:
    """The proven bound per state used where a belief's value is bounded state by state: the
    cut-off bound, +inf where none; a probability's clipped to [0, 1]."""
    finite = np.isfinite(cutoff)
    cap = np.where(finite, cutoff, np.inf)
    if probability:
        cap = np.clip(np.where(finite, cap, 1.0), 0.0, 1.0)
    return np.asarray(cap, dtype=np.float64)


def _enclosure(ch: _Choices, order: np.ndarray, keys: np.ndarray, E: sp.csr_matrix,
               ech: np.ndarray, ev: np.ndarray, ep: np.ndarray, lost: np.ndarray,
               top: np.ndarray, top_mag: np.ndarray, top_rel: np.ndarray, cut_ids: np.ndarray,
               cut_top: np.ndarray, cut_infinite: np.ndarray, adversary: np.ndarray,
               probability: bool, discount: float, input_rel: float,
               signed: bool = False) -> Enclosure:
    """The exact abstraction's rows enclosed (:class:`~posgmc.synthesis.grid_certificate.
    Enclosure`) for a maximiser: each expanded choice's vertex weights raised by their η (the
    float weights where the part is ambiguous), its ``top`` (the stop mass or reward, already
    rounded up for float sums) raised by input rounding, its ambiguous parts' leak and slack;
    then the cut-off rows. ``top_mag``: at least |top| and the magnitude the top's rounding is
    relative to (a reward summed from products of both signs: the largest |reward|)."""
    n_exp, V = E.shape
    eta = np.concatenate(ch.e_eta) if ch.e_eta else np.zeros(0)
    hi = np.where(np.isfinite(eta), up(ep * (1.0 + eta)), ep)
    coef = sp.csr_matrix((hi, (ech, ev)), shape=(n_exp, V))
    coef.sum_duplicates()
    amb_row = np.zeros(n_exp, dtype=bool)
    leak = np.zeros(n_exp)
    slack = np.zeros(n_exp)
    if ch.a_key:
        at = np.searchsorted(keys, np.concatenate(ch.a_key))
        amb_row[at] = True
        np.add.at(leak, at, np.concatenate(ch.a_leak))
        np.add.at(slack, at, np.concatenate(ch.a_slack))
        leak, slack = up(leak * (1.0 + 4.0 * UNIT)), up(slack * (1.0 + 4.0 * UNIT))
    # a lower bound on the exact mass that does not continue (t* + sink*): the exact masses
    # sum to 1, each part's at most its enclosure (certified: coef; ambiguous: its float
    # weights plus slack), and t* <= t for a probability (whose t is counted apart)
    # the stop mass or reward (either sign) within 2 top_rel of its float (rounded already, and
    # the exact model's rows)
    spread = 2.0 * top_rel + input_rel + 4.0 * UNIT
    top_hi = top + top_mag * spread
    top_hi = np.where(top_hi != 0, np.nextafter(top_hi, np.inf), top_hi)
    k = np.diff(coef.indptr).astype(np.float64)
    covered = np.asarray(coef.sum(axis=1)).ravel() + slack
    if probability:
        covered = covered + np.maximum(top_hi, 0.0)
    covered = covered * (1.0 + 2.0 * (k + 4.0) * UNIT)
    gone = np.where(lost > 0, np.maximum(0.0, (1.0 - covered) - 4.0 * UNIT), 0.0)
    # and a lower bound on the exact continuing mass (for a negative value per unit of it)
    lost_hi = up(lost * (1.0 + spread) * (1.0 + 4.0 * UNIT))
    kept_lo = np.where((lost > 0) | (slack > 0),
                       np.maximum(0.0, (1.0 - (lost_hi + slack) * (1.0 + 4.0 * UNIT))
                                  - 4.0 * UNIT), 1.0)
    n_cut = cut_ids.size
    state = np.r_[keys // ch.span, cut_ids].astype(np.int64)
    coef = sp.vstack([coef, sp.csr_matrix((n_cut, V))], format="csr")
    return Enclosure(
        state=state, coef=coef, top=np.r_[top_hi, cut_top], kept_lo=np.r_[kept_lo, np.ones(n_cut)],
        slack=np.r_[slack, np.zeros(n_cut)], leak=np.r_[leak, np.zeros(n_cut)],
        gone=np.r_[gone, np.zeros(n_cut)],
        clean=np.r_[~amb_row & (lost == 0), np.zeros(n_cut, dtype=bool)],
        infinite=np.r_[np.zeros(n_exp, dtype=bool), cut_infinite],
        adversary=adversary, probability=probability, discount=discount, signed=signed)


def _rule_entries(dyn: Dynamics, n: np.ndarray, states: np.ndarray, mass: np.ndarray
                  ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rules of :meth:`Dynamics.rules` at g vertices whose supports ``states`` (int64[g, m])
    offer ``n`` (int64[m]) choices per state, with belief masses ``mass`` (float64[g, m]), as
    entries: the number of rules k per vertex, then per entry (vertex by vertex, rule by rule,
    each rule's choices in their order) its vertex (0..g-1), its rule, its global choice and its
    weight (the rule's probability of the choice times its state's mass)."""
    k, vi, r, col, prob, p_s = _rule_layout(dyn, n, states, mass)
    return k, vi, r, col, prob * p_s


def _rule_layout(dyn: Dynamics, n: np.ndarray, states: np.ndarray, mass: np.ndarray
                 ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_rule_entries` with each entry's weight as its two factors: the rule's
    probability of the choice and the belief mass of the choice's state."""
    rg = dyn.model.row_groups
    g, m = states.shape
    lo = rg[states]
    det = deterministic_picks(n, dyn._base(states, lo, rg[states + 1]))  # [g, k, m]
    k_det = det.shape[1]
    varying = bool((n > 1).any())
    k = k_det + (1 if varying else 0)
    e = int(n.sum()) if varying else m  # entries per rule at most: the uniform mixture's
    col = np.zeros((g, k, e), dtype=np.int64)
    prob = np.zeros((g, k, e))
    w = np.zeros((g, k, e))
    real = np.zeros((k, e), dtype=bool)
    col[:, :k_det, :m] = lo[:, None, :] + det
    prob[:, :k_det, :m] = 1.0
    w[:, :k_det, :m] = mass[:, None, :]
    real[:k_det, :m] = True
    if varying:
        owner = np.repeat(np.arange(m), n)
        within = np.arange(e) - np.r_[0, np.cumsum(n)[:-1]][owner]
        col[:, k_det, :] = lo[:, owner] + within
        prob[:, k_det, :] = (1.0 / n)[owner]
        w[:, k_det, :] = mass[:, owner]
        real[k_det, :] = True
    vi, r, _ = np.nonzero(np.broadcast_to(real, (g, k, e)))
    keep = np.broadcast_to(real, (g, k, e))
    return k, vi, r, col[keep], prob[keep], w[keep]


def _assemble(problem: Problem, dyn: Dynamics, grid: _Grid, expanded: np.ndarray,
              resolution: int, cutoff: np.ndarray, ch: _Choices,
              coarse: CoarseBounds | None) -> GridAbstraction:
    """The abstraction: expanded vertices with their choices, cut-off vertices with one choice
    worth their full-observation bound, then the target and the sink."""
    V = len(grid.rows)
    beliefs = grid.matrix()
    TARGET, SINK = V, V + 1
    S_abs = V + 2
    prob = problem.rewards is None

    def cat(parts: list[np.ndarray], dtype: type = np.float64) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)

    keys = cat(ch.key, np.int64)
    order = np.argsort(keys, kind="stable")
    keys = keys[order]
    cv = keys // ch.span
    ca = cat(ch.action, np.int64)[order]
    stop, rew = cat(ch.stop)[order], cat(ch.reward)[order]
    lost = cat(ch.lost)[order]
    n_exp = keys.size  # the expanded choices, numbered 0..n_exp-1 in key (= vertex) order
    ech = np.searchsorted(keys, cat(ch.e_key, np.int64))
    ev, ep = cat(ch.e_vertex, np.int64), cat(ch.e_prob)
    E = sp.csr_matrix((ep, (ech, ev)), shape=(n_exp, V))
    terms = cat(ch.terms, np.int64)[order]
    finite = np.isfinite(cutoff)
    cap = np.where(finite, cutoff, np.inf)
    if prob:
        cap = np.clip(np.where(finite, cap, 1.0), 0.0, 1.0)
    if not problem.maximize and n_exp:
        Y = sp.vstack(ch.successors, format="csr")[order]
        E = dominate(E, beliefs, Y, terms)
    kept = np.asarray(E.sum(axis=1)).ravel()
    grow = 1.0 + rounding(terms)
    if prob:
        # the stop mass (a sum of nonnegative products) rounded to the optimistic side
        t = up(stop * grow) if problem.maximize else np.maximum(0.0, stop * (2.0 - grow))
        sink = np.maximum(0.0, 1.0 - t - kept)
    else:
        # a reward's stop mass is worth nothing more: what the vertices leave reaches the target
        t = np.maximum(0.0, 1.0 - kept)
        sink = np.zeros(n_exp)
    # a reward (a float sum of products of either sign) moved outward by its rounding bound,
    # relative to the sum of the products' magnitudes (at most the largest |reward| when the
    # rewards take both signs, the sum itself otherwise): up for a maximiser, down for a
    # minimiser, whatever the reward's sign
    rew_mag = np.zeros(n_exp)
    rew_exp = np.zeros(n_exp)
    if not prob:
        rew_mag = reward_magnitude(rew, np.asarray(problem.rewards, dtype=np.float64))
        rew_exp = outward(rew, (grow - 1.0) * rew_mag, problem.maximize)
    Ec = E.tocoo()
    T_exp = sp.csr_matrix(
        (np.r_[Ec.data, t, sink],
         (np.r_[Ec.row, np.arange(n_exp), np.arange(n_exp)].astype(np.int64),
          np.r_[Ec.col, np.full(n_exp, TARGET), np.full(n_exp, SINK)].astype(np.int64))),
        shape=(n_exp, S_abs))
    T_exp.eliminate_zeros()
    # cut-off vertices: one choice worth Σ_s v(s) cutoff(s)
    cut_ids = np.flatnonzero(~expanded)
    Bc = beliefs[cut_ids]
    # Σ_s b(s) cutoff(s) rounded outward (a sum of nonnegative products)
    # (products of either sign: the rounding is relative to the sum of their magnitudes)
    u = np.asarray(Bc @ np.where(finite, cutoff, 0.0)).ravel()
    u_mag = np.asarray(Bc @ np.where(finite, np.abs(cutoff), 0.0)).ravel()
    slack = rounding(np.diff(Bc.indptr))
    u = outward(u, up(u_mag * slack * (1.0 + 4.0 * UNIT)), problem.maximize)
    unbounded = np.asarray(Bc @ (~finite).astype(np.float64)).ravel() > 0
    n_cut = cut_ids.size
    if coarse is not None and n_cut:
        sign = 1.0 if problem.maximize else -1.0
        w = coarse.bounds([grid.rows[v] for v in cut_ids.tolist()],
                          [grid.vals[v] for v in cut_ids.tolist()],
                          cap if problem.maximize else None)
        better = np.isfinite(w) & (unbounded | (sign * w < sign * u))
        u = np.where(better, w, u)
        unbounded &= ~better
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
    # the rows in state order: each state's choices together (expanded choices in key order)
    owner = np.r_[cv, cut_ids, [TARGET, SINK]]
    perm = np.argsort(owner, kind="stable")
    transitions = sp.vstack([T_exp, T_cut, T_sinks], format="csr")[perm]
    per_state = np.bincount(owner, minlength=S_abs)
    row_groups = np.zeros(S_abs + 1, dtype=np.int64)
    row_groups[1:] = np.cumsum(per_state)
    action = np.r_[ca, np.full(n_cut + 2, -1, dtype=np.int64)][perm]
    # the adversary's vertices (expanded ones whose support is not the decision maker's)
    theirs = np.zeros(S_abs, dtype=bool)
    starts = beliefs.indices[beliefs.indptr[:-1]].astype(np.int64)  # each vertex's first state
    theirs[:V] = expanded & ~dyn.owned[starts]
    if theirs.any():
        model = make_model(ModelType.SMG, row_groups, transitions, initial_states=(0,),
                           state_players=theirs.astype(np.int32),
                           player_names=("decision maker", "adversary"))
    else:
        model = make_model(ModelType.MDP, row_groups, transitions, initial_states=(0,))
    rewards = None
    if not prob:
        rewards = np.r_[rew_exp, r_cut, np.zeros(2)][perm]
    target = np.zeros(S_abs, dtype=bool)
    target[TARGET] = True
    enclosure = None
    if problem.maximize:
        enclosure = _enclosure(
            ch, order, keys, E, ech, ev, ep, lost, t if prob else rew_exp,
            t if prob else np.maximum(np.abs(rew_exp), rew_mag), rounding(terms), cut_ids,
            u if prob else r_cut, np.zeros(n_cut, dtype=bool) if prob else unbounded,
            theirs[:V], prob, problem.discount, dyn.input_rel, _signed(problem))
    return GridAbstraction(model, beliefs, expanded, action, rewards, target,
                           problem.discount, problem.maximize, resolution,
                           ch.on_grid and bool(expanded.all()), theirs, enclosure)


class Mixtures:
    """Randomised decision rules of the adversary per belief (mutable while refining): each a
    probability per choice of the belief's support states, in the order of ``Dynamics.rules``.
    Keyed by the belief itself (support and counts reduced by their common divisor with N), so
    the rules carry over to finer grids, which nest."""

    def __init__(self) -> None:
        self.rules: dict[bytes, np.ndarray] = {}

    @staticmethod
    def key(states: np.ndarray, p: np.ndarray, resolution: int) -> bytes:
        counts = np.rint(p * resolution).astype(np.int64)
        g = math.gcd(int(resolution), *counts.tolist())
        key: bytes = states.astype(np.int64).tobytes() + b"/" + (counts // g).tobytes()
        return key

    def at(self, states: np.ndarray, p: np.ndarray, resolution: int) -> np.ndarray | None:
        return self.rules.get(self.key(states, p, resolution))

    def add(self, states: np.ndarray, p: np.ndarray, resolution: int, rule: np.ndarray) -> bool:
        """Offer ``rule`` at the belief (the latest first, at most :data:`MIX_CAP`); False when
        it is already offered there."""
        k = self.key(states, p, resolution)
        old = self.rules.get(k)
        if old is not None and np.abs(old - rule).max(axis=1).min() <= 1e-9:
            return False
        self.rules[k] = rule[None] if old is None else np.vstack([rule, old])[:MIX_CAP]
        return True


def stage_mixtures(problem: Problem, abstraction: GridAbstraction, values: np.ndarray,
                   cutoff: np.ndarray, mixtures: Mixtures, *,
                   deadline: float | None = None, limit: int | None = None) -> tuple[int, int]:
    """Add to ``mixtures`` the adversary's LP-optimal randomised rules at each of the
    abstraction's expanded adversary vertices: against the abstraction's solved ``values`` (its
    bound side per state) and the per-state ``cutoff`` bounds at the unit beliefs
    (:func:`posgmc.synthesis.stage_lp.stage_rule`), and against the one-step estimate from the
    same bounds (:func:`posgmc.synthesis.stage_lp.one_step_rule`: it reaches posteriors the
    abstraction has not explored yet), and the rules whose posterior is a grid vertex itself
    (:func:`_grid_rules`: nothing leaks to the decision maker through a decomposition, where
    both estimates are flat). In breadth-first order until ``deadline`` or ``limit``
    vertices. Returns how many new rules were added and at how many vertices LPs were solved."""
    dyn = Dynamics(problem, None)
    V = abstraction.vertices
    data = stage_lp.StageData.of(dyn.T_cont, dyn.T_stop, abstraction.beliefs,
                                 np.asarray(values, dtype=np.float64)[:V], cutoff,
                                 minimise=problem.maximize, reward=dyn.choice_reward,
                                 stop_value=dyn.stop_value, discount=dyn.discount)
    finite = np.where(np.isfinite(cutoff), cutoff, np.nan)
    Q = np.stack([dyn.reward[a] + dyn.stop_value * dyn.stop[a]
                  + dyn.discount * (dyn.P[a] @ np.nan_to_num(finite, nan=0.0))
                  + dyn.P[a] @ np.where(np.isnan(finite), np.inf, 0.0)
                  for a in range(dyn.actions.size)]) if dyn.actions.size else np.zeros((0, dyn.S))
    step = stage_lp.OneStep(np.nan_to_num(Q, nan=np.inf), dyn.mask, dyn.group, cutoff, dyn.Z)
    rg = dyn.model.row_groups
    B = abstraction.beliefs
    added = solved = 0
    for v in np.flatnonzero(abstraction.adversary[:V]).tolist():
        if (deadline is not None and time.perf_counter() > deadline) or interrupted() or \
                (limit is not None and solved >= limit):
            break
        lo, hi = B.indptr[v], B.indptr[v + 1]
        states = B.indices[lo:hi].astype(np.int64)
        p = B.data[lo:hi]
        cols, _ = dyn.rules(states)
        owner = np.repeat(np.arange(states.size), rg[states + 1] - rg[states])
        if (rg[states + 1] - rg[states]).max() <= 1:
            continue  # nothing to randomise
        solved += 1
        for rule in (*_grid_rules(dyn, cols, owner, p, abstraction.resolution),
                     stage_lp.one_step_rule(data, step, p, cols, owner),
                     stage_lp.stage_rule(data, states, p, cols, owner)):
            if rule is not None and mixtures.add(states, p, abstraction.resolution, rule):
                added += 1
    return added, solved


GRID_TARGETS = 8
"""Combinations of target vertices tried for one adversary vertex's grid rules at most."""


def _grid_rules(dyn: Dynamics, cols: np.ndarray, owner: np.ndarray, p: np.ndarray,
                resolution: int) -> list[np.ndarray | None]:
    """Randomised rules at an adversary vertex (belief ``p`` over the states owning ``cols``)
    whose posterior is a grid vertex in every observation group of the successors
    (:func:`posgmc.synthesis.stage_lp.grid_rule`): the targets are the vertices of the simplex
    around the uniform mixture's posterior (the grid beliefs near what randomising gives), the
    combinations over the groups in the order of their weights, at most :data:`GRID_TARGETS`."""
    if resolution <= 0:
        return []
    J = sp.csr_matrix(sp.diags(p[owner]) @ dyn.T_cont[cols])
    n = np.bincount(owner)
    y = np.asarray(J.T @ (1.0 / n[owner])).ravel()
    succ = np.flatnonzero(y > 0)
    if not succ.size:
        return []
    groups: list[list[tuple[float, np.ndarray, np.ndarray]]] = []
    for g in np.unique(dyn.group[succ]).tolist():
        states = succ[dyn.group[succ] == g]
        part = y[states] / y[states].sum()
        counts, lam = freudenthal(part, resolution)
        order = np.argsort(-lam, kind="stable")
        # the whole group's states: those outside the vertex's support must get no mass
        groups.append([(float(lam[i]), states, counts[i] / resolution) for i in order.tolist()])
    out: list[np.ndarray | None] = []
    for combo in itertools.islice(itertools.product(*groups), GRID_TARGETS):
        targets = [(states, belief) for _, states, belief in combo]
        out.append(stage_lp.grid_rule(J, owner, targets))
    return out


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


def _proven_side(abstraction: GridAbstraction, result: EngineResult,
                 deadline: float | None = None) -> np.ndarray | None:
    """The bound side per vertex, proven for the exact belief MDP: a minimiser's lower values
    (its rows are scaled below the exact ones, :func:`dominate`); a maximiser's upper values
    raised until the exact operator's enclosure is below them
    (:func:`~posgmc.synthesis.grid_certificate.certified_upper`), None when that fails. A
    probability's bound is clipped to 1."""
    if not abstraction.maximize:
        return np.asarray(result.lower, dtype=np.float64)[:abstraction.vertices]
    assert abstraction.enclosure is not None
    W = certified_upper(abstraction.enclosure, np.asarray(result.upper, dtype=np.float64),
                        deadline=deadline)
    if W is None:
        return None
    return np.minimum(W, 1.0) if abstraction.rewards is None else W


def grid_bound(problem: Problem, *, deadline: float | None, target: float | None = None,
               resolutions: tuple[int, ...] = RESOLUTIONS,
               cutoff: np.ndarray | None = None,
               vertices: int = MAX_VERTICES, unfold: bool = True,
               mix: bool = True, settle: bool = False) -> GridBound | None:
    """Abstractions of growing resolution while time remains; the tightest proven bound.

    Args:
        problem: a POMDP, or a one-sided game (:func:`applies`).
        deadline: ``time.perf_counter()`` value by which to stop (an abstraction whose
            exploration is cut short still proves a bound: its frontier is cut off); None: no
            wall-clock cap.
        target: stop as soon as the bound reaches this value (the other side of the bracket).
        cutoff: the per-state bounds for cut-offs (default :func:`full_observation_bounds`).
        vertices: the work budget: grid vertices explored at most, over all resolutions.
        unfold: first explore the beliefs themselves (resolution 0, the belief unfolding) with
            :data:`UNFOLD_SHARE` of the budget: where the reachable belief set is that small the
            abstraction is the belief MDP and the bound its optimum (the grids then stop).
        mix: on a game, offer the adversary randomised rules from stage LPs
            (:func:`stage_mixtures`) in rounds of re-solving; False: its deterministic rules and
            the uniform mixture only (one solve per resolution).
        settle: also stop refining once it has stopped paying: two grids of consecutive
            resolutions both complete (no cut-offs), the coarser one's bound the best found
            (within :data:`PRECISION`, relative) and the finer one not tighter than it beyond
            that. A budget rule for the default bracket (the bound printed is still what the
            abstractions solved prove), deterministic; a plateau that later refinement would
            leave is possible, so ``--gap`` runs do not use it. False: the refinement goes on
            until the budget, the deadline or the target stops it.

    Returns:
        The bound, or None when no abstraction applies or none was solved soundly in time.
    """
    t0 = time.perf_counter()
    if not applies(problem):
        return None
    sign = 1.0 if problem.maximize else -1.0
    rules = None
    if cutoff is None:
        cutoff, rules = full_observation_bounds(problem, deadline)
    floor = full_observation_floor(problem, deadline) if problem.maximize and _signed(problem) \
        else None
    best: GridBound | None = None
    tried: list[tuple[int, float]] = []
    coarse: CoarseBounds | None = None
    left = vertices
    game = problem.adversary is not None
    mixtures = Mixtures() if game and mix else None
    # the stage LPs' work budget, in vertices solved over all rounds (deterministic, like the
    # grid's): one per LP_SHARE vertices of the grid's budget
    lps_left = vertices // LP_SHARE
    # the previous grid resolution's bound, when its abstraction was complete (for ``settle``)
    settled_at: float | None = None
    for N in ((0,) if unfold else ()) + tuple(resolutions):
        side: np.ndarray | None = None
        solved: GridAbstraction | None = None
        at_n: float | None = None
        # a POMDP: one abstraction per resolution; a game: then rounds of stage LPs that offer
        # the adversary randomised rules against the values just solved, and a new solve
        # the unfolding (N = 0) has no grid beliefs to key the adversary's mixtures by
        mixing = mixtures if N > 0 else None
        for _ in range(1 + (MIX_ROUNDS if mixing is not None else 0)):
            now = time.perf_counter()
            if (deadline is not None and now > deadline) or left <= 0 or interrupted():
                break
            # exploration may use most of what is left (the unfolding its share); the sound
            # solve gets the rest
            share = UNFOLD_SHARE if N == 0 else 1.0
            explore_until = None if deadline is None else now + 0.6 * share * (deadline - now)
            abstraction = grid_abstraction(problem, N, cutoff=cutoff, deadline=explore_until,
                                           adversary_rules=rules, coarse=coarse,
                                           max_vertices=max(1, int(share * left)),
                                           mixtures=mixing, floor=floor,
                                           targets=N == 0 and game and mix)
            if abstraction is None:
                return None
            left -= int(abstraction.expanded.sum())
            # policy iteration (the stiff iteration's certificate) has no deadline: only
            # without one
            result = abstraction.solve(SolverOptions(precision=PRECISION, relative=True,
                                                     deadline=deadline, want_strategy=False,
                                                     stiff_certificate=deadline is None))
            if not result.sound:
                break
            proven = _proven_side(abstraction, result, deadline)
            if proven is None:
                break
            value = float(proven[0])
            solved_at = float(result.upper[0] if problem.maximize else result.lower[0])
            # the initial state's own cut-off bound holds too (a certificate may be looser)
            s0 = int(problem.model.initial_states[0])
            if problem.maximize and np.isfinite(cutoff[s0]):
                value = min(value, float(cutoff[s0]))
            tried.append((N, value))
            # the belief MDP itself, and its solution proven as it is (a certificate that had
            # to raise it, or fell back to the cut-off, leaves finer grids something to do)
            exact = abstraction.exact and not abstraction.adversary.any() and \
                sign * value <= sign * solved_at + 1e-9 * max(1.0, abs(solved_at))
            if best is None or sign * value < sign * best.value:
                best = GridBound(value, N, abstraction.vertices, abstraction.complete, exact, (),
                                 0.0)
            if exact or (target is not None and sign * best.value <= sign * target):
                break
            if at_n is None or sign * value < sign * at_n:
                at_n, solved = value, abstraction
                side = proven
            elif at_n is not None and sign * value >= sign * at_n - 1e-9 * max(1.0, abs(at_n)):
                break  # the last rules did not tighten the bound
            # the stage LPs get at most a third of what is left (a finer grid may need the rest)
            lp_until = None if deadline is None else \
                time.perf_counter() + (deadline - time.perf_counter()) / 3
            if mixing is None or not abstraction.adversary.any() or lps_left <= 0:
                break
            added, used = stage_mixtures(problem, abstraction, proven, cutoff, mixing,
                                         deadline=lp_until, limit=lps_left)
            lps_left -= used
            if added == 0:
                break
        if best is not None and (best.exact or (target is not None
                                                and sign * best.value <= sign * target)):
            break
        if solved is None or side is None or N == 0:
            continue
        if settle and at_n is not None and best is not None:
            slack = PRECISION * max(1.0, abs(best.value))
            if solved.complete and settled_at is not None and \
                    sign * at_n >= sign * settled_at - slack and \
                    sign * settled_at <= sign * best.value + slack:
                break  # the best grid refined completely without tightening
            settled_at = at_n if solved.complete else None
        # the next resolution doubles this one: its cut-offs interpolate these values (the
        # grids nest, so a fine vertex's coarse simplex has vertices this abstraction holds
        # wherever it explored that far)
        coarse = CoarseBounds.of(solved, side)
    if best is None:
        return None
    return GridBound(best.value, best.resolution, best.vertices, best.complete, best.exact,
                     tuple(tried), time.perf_counter() - t0)
