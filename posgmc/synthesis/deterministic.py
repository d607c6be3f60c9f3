"""A direct search over the decision maker's *deterministic* k-node FSSs against the omniscient
adversary: abstraction refinement on the quotient game of a family of strategies (the idea of
PAYNT's "family" MDPs, Češka et al.; written here from the idea, not from its code).

**Holes and options.** A deterministic k-FSS chooses, for every memory node n and observation z
of the decision maker (a *hole* h = (n, z)), one *option* o = (a, n'): the action a among the
labels z offers and the next node n'. A *family* restricts every hole to a subset of its options
(``allowed``: bool[H, O]); the whole space is the family of all options.

**The quotient game of a family.** States (s, n) for every model state s and node n (the part
reachable from (s0, 0)); in a decision maker's state (s, n) with observation z one row per
allowed option (a, n') of hole (n, z), with a's transitions into (s', n'); in the adversary's
states its own choices, the node unchanged. In this game the decision maker sees (s, n) and may
pick a different option in every state with the same hole, so its value is at least as good as
what any member of the family guarantees against the omniscient adversary (who sees (s, n) in
both): an optimistic **bound** on the whole family. A family whose bound does not beat the best
member found so far is pruned whole.

**Refinement.** The quotient's optimal strategy σ is read on the states reachable under σ and any
adversary choice. If σ picks one option per hole there, the member with those options achieves
the bound (it plays σ wherever the play can go): the family's optimum is found. Otherwise the
member that takes each hole's most used option is evaluated (an incumbent), and the family is
split on the hole σ uses most inconsistently, its options divided so that the two most used ones
fall in different halves. Families are explored best bound first (the most recent on a tie), so
good members come early; when no family is left the search is *exhaustive*: the result is an
optimal deterministic k-FSS (up to the float tolerance of the solves).

Every solve is value iteration on the quotient: vectorised Jacobi sweeps, or on a large quotient
with the compiled kernels the Gauss-Seidel kernel of :mod:`posgmc.engines.kernels.ordered_sweeps`
in the order of the quotient's strongly connected components (:attr:`Quotient.solving_order`,
computed once per quotient: most states are then final after one step). Floats; a family starts
from its parent's values, which lie on the decision maker's good side of its own, so that a
family that provably cannot beat the incumbent is cut (the Jacobi sweeps stop as soon as that
shows, the kernel's result is compared once); σ breaks ties between equally good options towards
the option its hole uses in the most states, so that choices that
do not matter cause no split. This ranks and prunes; the defence it returns is verified
afterwards like every other candidate (:mod:`posgmc.synthesis.search`). The search is deterministic:
no randomness, the order fixed by the bounds and a counter, its extent a number of families
solved (the work budget); only the wall-clock cap can cut it short.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from posgmc.engines import objectives as obj
from posgmc.engines import scc
from posgmc.engines.kernels.ordered_sweeps import solve_ordered
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.row_slots import RowSlots
from posgmc.engines.system import HAVE_KERNELS, accumulate_rows
from posgmc.errors import LimitError, UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.resources import check_allocation
from posgmc.strategies.binding import player_view
from posgmc.syntax.ast import ModelType
from posgmc.synthesis.executors import Executor
from posgmc.synthesis.ordered_evaluation import solving_order
from posgmc.synthesis.parametric import Layout
from posgmc.synthesis.problem import Problem, expired

__all__ = ["Quotient", "quotient_of", "DeterministicResult", "DeterministicJob", "search",
           "deterministic_phase"]


@dataclass(frozen=True, eq=False)
class Quotient:
    """The quotient game of the decision maker's deterministic k-FSSs (all options).

    ``model``: an smg (mdp for a pomdp) over the Q reachable pairs (s, n), rows grouped by state;
    ``state_of``/``memory_of``: int64[Q]; ``row_state``: int64[R], the quotient state of each row;
    ``hole``: int64[R], the hole n * Zu + z of a decision maker's row (-1 for the adversary's);
    ``option``: int64[R], its option a * k + n' (a, z: indices of the :class:`Layout`);
    ``target``/``remain``: bool[Q]; ``rewards``: float64[R] or None; ``maximize``: bool[Q];
    ``initial``: the quotient state (s0, 0); ``offered``: bool[H, O], the options each hole has."""

    memory: int
    layout: Layout
    model: ExplicitModel
    state_of: np.ndarray
    memory_of: np.ndarray
    row_state: np.ndarray
    hole: np.ndarray
    option: np.ndarray
    target: np.ndarray
    remain: np.ndarray
    rewards: np.ndarray | None
    maximize: np.ndarray
    initial: int
    offered: np.ndarray

    @functools.cached_property
    def solving_order(self) -> tuple[np.ndarray, np.ndarray]:
        """(order, comp_ptr): the states outside the target and the avoided states (those whose
        value is not fixed by :func:`_bellman_parts` for either objective: the target of a
        discounted cost, the target or a state leaving ``remain`` of a probability, all values
        the rows only read) by strongly connected component of the quotient with all options,
        successors first, inside a component in descending state index (explored from the
        initial state: the later states lie nearer the exits). A family's graph is a subgraph,
        so the order holds for every family (:mod:`posgmc.engines.scc`)."""
        free = ~(self.target | (~self.remain if self.rewards is None else False))
        order, comp_ptr = solving_order(self.model.transitions, self.model.row_groups, free)
        return np.flatnonzero(free)[order], comp_ptr

    @property
    def num_holes(self) -> int:
        return int(self.offered.shape[0])

    @property
    def num_options(self) -> int:
        return int(self.offered.shape[1])


def quotient_of(problem: Problem, memory: int, *, deadline: float | None = None
                ) -> Quotient | None:
    """The quotient game of ``problem``'s decision maker with ``memory`` nodes, or None when the
    decision maker's states with one observation do not all offer the same labels (a
    deterministic rule then has no single meaning), when ``deadline`` (a ``time.perf_counter()``
    value) passes while it is built, or when it would not fit in the memory available (its
    size grows with k²: k nodes, each choice with k next nodes)."""
    model, k = problem.model, memory
    if expired(deadline) or not _fits(problem, k):
        return None
    layout = Layout.of(model, problem.player)
    view = player_view(model, problem.player)
    S = model.num_states
    owned = (model.state_players == problem.player) if model.player_names else np.ones(S, bool)
    Zu, Au = layout.mask.shape
    obs_index = np.full(view.num_observations, -1, dtype=np.int64)
    obs_index[layout.used_obs] = np.arange(Zu)
    act_index = np.full(len(model.action_names), -1, dtype=np.int64)
    act_index[layout.used_actions] = np.arange(Au)
    cs = model.choice_states
    own_rows = np.flatnonzero(owned[cs])
    zi = obs_index[view.state_obs]
    # every state of an observation offers exactly the observation's labels
    offered_here = np.zeros((S, Au), dtype=bool)
    offered_here[cs[own_rows], act_index[model.choice_actions[own_rows]]] = True
    own_states = np.flatnonzero(owned)
    if not np.array_equal(offered_here[own_states], layout.mask[zi[own_states]]):
        return None
    # rows of the full layout (before reachability): state q = n * S + s; a decision maker's
    # choice c gives k rows (next node n' = 0..k-1), the adversary's one (node unchanged)
    copies = np.where(owned[cs], k, 1)  # rows per choice
    per_node_rows = int(copies.sum())
    c_rep = np.repeat(np.arange(model.num_choices), copies)
    within = np.arange(per_node_rows) - np.repeat(np.cumsum(copies) - copies, copies)
    own_rep = owned[cs[c_rep]]
    row_c = np.tile(c_rep, k)
    row_n = np.repeat(np.arange(k), per_node_rows)
    row_next = np.where(np.tile(own_rep, k), np.tile(within, k), row_n)
    row_q = row_n * S + cs[row_c]
    # rows sorted by quotient state (stable: the model's choice order, then n')
    order = np.argsort(row_q, kind="stable")
    row_c, row_n, row_next, row_q = row_c[order], row_n[order], row_next[order], row_q[order]
    T = model.transitions[row_c]
    T = sp.csr_matrix((T.data, T.indices + np.repeat(row_next * S, np.diff(T.indptr)), T.indptr),
                      shape=(row_c.size, k * S))
    if expired(deadline):
        return None
    # the part reachable from (s0, 0)
    graph = sp.csr_matrix((np.ones(T.nnz, dtype=np.int8),
                           (np.repeat(row_q, np.diff(T.indptr)), T.indices)), shape=(k * S, k * S))
    init_full = int(model.initial_states[0])
    reach = np.zeros(k * S, dtype=bool)
    reach[csgraph.breadth_first_order(graph, init_full, return_predecessors=False)] = True
    if expired(deadline):
        return None
    keep_rows = reach[row_q]
    states = np.flatnonzero(reach)
    renum = np.full(k * S, -1, dtype=np.int64)
    renum[states] = np.arange(states.size)
    T = T[keep_rows][:, states].tocsr()
    row_c, row_n, row_next, row_q = (a[keep_rows] for a in (row_c, row_n, row_next, row_q))
    row_state = renum[row_q]
    counts = np.bincount(row_state, minlength=states.size)
    row_groups = np.concatenate([[0], np.cumsum(counts)])
    state_of, memory_of = states % S, states // S
    is_game = model.model_type.is_game
    qmodel = make_model(
        ModelType.SMG if is_game else ModelType.MDP, row_groups, T,
        initial_states=(int(renum[init_full]),),
        choice_actions=model.choice_actions[row_c], action_names=model.action_names,
        state_players=model.state_players[state_of] if is_game else None,
        player_names=model.player_names,
    )
    own_row = owned[cs[row_c]]
    hole = np.where(own_row, row_n * Zu + zi[cs[row_c]], -1)
    option = np.where(own_row, act_index[model.choice_actions[row_c]] * k + row_next, -1)
    offered = np.tile(np.repeat(layout.mask, k, axis=1), (k, 1))  # [n * Zu + z, a * k + n']
    direction = problem.query.direction
    if direction is None:  # pragma: no cover - problem_of asks for min or max
        raise UnsupportedError("synthesis needs Pmin/Pmax or Rmin/Rmax", problem.query.span)
    maximize = obj.maximize_mask(qmodel, direction=direction,
                                 coalition=problem.coalition if is_game else None)
    rewards = None if problem.rewards is None else problem.rewards[row_c]
    return Quotient(k, layout, qmodel, state_of, memory_of, row_state, hole, option,
                    problem.target[state_of], problem.remain[state_of], rewards, maximize,
                    int(renum[init_full]), offered)


@dataclass(frozen=True)
class _Solved:
    """One quotient solve: the initial value, the values of all states (float64[Q]) and the
    optimal row (global) of every state (-1: none matters); ``cut``: stopped at the cutoff
    (``value`` is then only a bound on the decision maker's good side)."""

    value: float
    values: np.ndarray
    strategy: np.ndarray
    cut: bool = False


_FAMILY_PRECISION = 1e-8
"""Value iteration on a family's quotient stops when no value moves by more than this, on a
member's (the candidates) at 1e-10: rankings, not proofs."""

_MAX_SWEEPS = 20_000

_ENGINE_LIMIT = 2_000
"""Undiscounted expected rewards are solved by the engines' policy iteration, which knows no
deadline: the search runs on them only for quotients up to this many states."""


def _fits(problem: Problem, k: int) -> bool:
    """Whether the full layout of the k-node quotient (before reachability) fits in the memory
    available: about 120 bytes per row and transition."""
    model = problem.model
    owned = (model.state_players == problem.player) if model.player_names else \
        np.ones(model.num_states, bool)
    own_choice = owned[model.choice_states]
    per_choice = np.diff(model.transitions.indptr)
    rows = k * (k * float(own_choice.sum()) + float((~own_choice).sum()))
    entries = k * (k * float(per_choice[own_choice].sum()) + float(per_choice[~own_choice].sum()))
    try:
        check_allocation(120.0 * (rows + entries), "the quotient")
    except LimitError:
        return False
    return True


def _solve(q: Quotient, allowed: np.ndarray, start: np.ndarray | None, problem: Problem, *,
           cutoff: float | None = None, precision: float = 1e-10,
           deadline: float | None = None, ordered: bool = False) -> _Solved:
    """The quotient game restricted to the ``allowed`` options. Probabilities and discounted
    costs by vectorised value iteration from ``start`` (values of all states; None: from the
    fixed values, 0 elsewhere); other objectives by the engines' policy iteration.

    With ``cutoff``, the iteration stops as soon as the initial value is no better for the
    decision maker than ``cutoff`` (``cut`` is then set). That is sound only when ``start`` lies
    on the decision maker's good side of the restricted game's value, so that every iterate
    does too: a parent family's values (a sub-family is no better; the iterates move
    monotonically towards the value), or the optimistic start of :func:`_optimistic`. At
    ``deadline`` the iteration is abandoned (``cut``, the value unusable). ``ordered``: on a
    large quotient with the compiled kernels, the ordered Gauss-Seidel kernel instead of the
    Jacobi sweeps (the search's own solves; the observation-level policy iteration of
    :mod:`posgmc.synthesis.improvement` keeps the sweeps: its greedy step breaks ties on values
    that the two iterations give differently in the last digits, about 1e-11)."""
    enabled = (q.hole < 0) | allowed[np.maximum(q.hole, 0), np.maximum(q.option, 0)]
    rows = np.flatnonzero(enabled)
    Q = q.model.num_states
    counts = np.bincount(q.row_state[rows], minlength=Q)
    rg = np.concatenate([[0], np.cumsum(counts)])
    T = q.model.transitions[rows]
    if q.rewards is not None and problem.discount >= 1.0:
        return _solve_engine(q, rows, rg, T)
    mx = q.maximize
    fixed, fixed_values, base, gamma = _bellman_parts(q, problem)
    base = base[rows]
    x = fixed_values.copy() if start is None else np.where(fixed, fixed_values, start)
    starts = rg[:-1]
    # one maximum per state: the minimising states' rows negated (folded into the matrix, with
    # the discount): v = flip * (base + g T x)
    flip = np.where(np.repeat(mx, counts), 1.0, -1.0)
    state_flip = np.where(mx, 1.0, -1.0)
    A = T.copy()
    A.data *= gamma * np.repeat(flip, np.diff(A.indptr))
    offset = flip * base
    v = np.empty(rows.size)

    def row_values(x: np.ndarray) -> np.ndarray:
        if HAVE_KERNELS:  # scipy's kernel without the operator's dispatch (the engines' way)
            v[:] = offset
            accumulate_rows(A, 0, A.shape[0], x, v)
            return v
        out: np.ndarray = offset + A @ x
        return out

    sign = problem.sign
    init = q.initial
    if ordered and scc.compiled_at(Q):
        x = _solve_ordered(q, T, rg, x, base, gamma, precision)
        cut = cutoff is not None and sign * x[init] <= sign * cutoff + 1e-12
    else:
        x, cut = _jacobi(A, offset, starts, counts, ~fixed, state_flip, x, init, sign, cutoff,
                         precision, deadline)
    v = row_values(x).copy()
    best = np.maximum.reduceat(v, starts)
    # among the rows within the precision of the optimum, the one whose (hole, option) is
    # optimal in the most states of its hole (ties: the first row), so that σ is consistent
    # wherever the choice does not matter
    good = v >= np.repeat(best, counts) - 1e2 * precision
    strategy = np.where(fixed, -1, rows[_consistent_choice(q, rows, good, starts)])
    return _Solved(float(x[init]), x, strategy, cut)


def _jacobi(A: sp.csr_matrix, offset: np.ndarray, starts: np.ndarray, counts: np.ndarray,
            free: np.ndarray, state_flip: np.ndarray, x: np.ndarray, init: int, sign: float,
            cutoff: float | None, precision: float, deadline: float | None
            ) -> tuple[np.ndarray, bool]:
    """The value iteration of :func:`_solve` by vectorised Jacobi sweeps over the family's rows
    ``A`` (every state maximises: the minimising states' rows negated, the discount folded in;
    ``offset`` the rows' constants): (the values, whether cut at ``cutoff`` or ``deadline``)."""
    # the sweeps take the free states' rows only (the fixed states keep their values), laid out
    # by slot (:mod:`posgmc.engines.row_slots`: no reduceat over 10^5 groups per sweep)
    F = np.flatnonzero(free)
    by_slot = RowSlots.of(starts[F], counts[F])
    A_free = A[by_slot.order]
    offset_free = offset[by_slot.order]
    flip_free = state_flip[F]
    v_free = np.empty(by_slot.order.size)

    def optimum(x: np.ndarray) -> np.ndarray:
        """The Bellman update: the best row of every free state, the fixed values elsewhere."""
        if HAVE_KERNELS:
            v_free[:] = offset_free
            accumulate_rows(A_free, 0, A_free.shape[0], x, v_free)
            values = v_free
        else:  # pragma: no cover - depends on the scipy build
            values = offset_free + A_free @ x
        y = x.copy()
        y[F] = by_slot.best(values, np.maximum) * flip_free
        return y

    cut = False
    for sweep in range(_MAX_SWEEPS):
        y = optimum(x)
        if cutoff is not None and sign * y[init] <= sign * cutoff + 1e-12:
            x, cut = y, True
            break
        if sweep % 8 == 7 and np.max(np.abs(y[free] - x[free]), initial=0.0) <= precision:
            x = y
            break
        x = y
        if expired(deadline):  # every sweep: one sweep of a quotient with large memory is long
            cut = True
            break
    return x, cut


def _solve_ordered(q: Quotient, T: sp.csr_matrix, rg: np.ndarray, x: np.ndarray,
                   base: np.ndarray, gamma: float, precision: float) -> np.ndarray:
    """The value iteration of :func:`_solve` on a large quotient: the compiled Gauss-Seidel
    kernel (:mod:`posgmc.engines.kernels.ordered_sweeps`) over the family's rows ``T`` (grouped
    by ``rg``) in the quotient's component order, from ``x`` (updated in place and returned), a
    component done when no value moves by more than ``precision`` (relative to values above 1).
    From a start on one side of the value the iterates stay there, as the Jacobi sweeps' do
    (both apply the same monotone operator, the self-loops eliminated as in
    :mod:`posgmc.engines.topological`): a cutoff applied to the result means the same."""
    order, comp_ptr = q.solving_order
    Q = q.model.num_states
    solve_ordered(T.indptr.astype(np.int64), T.indices.astype(np.int64), T.data,
                  rg.astype(np.int64), np.arange(Q, dtype=np.int64), order, comp_ptr,
                  base.astype(np.float64), float(gamma), ~q.maximize, float(precision), 1.0,
                  _MAX_SWEEPS, x)
    return x


def _consistent_choice(
    q: Quotient, rows: np.ndarray, good: np.ndarray, starts: np.ndarray
) -> np.ndarray:
    """int64[Q]: per state, the index into ``rows`` of the good row whose (hole, option) is good
    in the most states (the first such row on a tie; adversary rows score 0)."""
    hole, option = q.hole[rows], q.option[rows]
    own = hole >= 0
    key = np.where(own, hole * q.num_options + option, 0)
    votes = np.bincount(key[good & own], minlength=q.num_holes * q.num_options)
    n = rows.size
    score = np.where(good, np.where(own, votes[key], 0) + 1, 0)
    packed = score * (n + 1) + (n - np.arange(n))
    top = np.maximum.reduceat(packed, starts)
    return n - top % (n + 1)


def _bellman_parts(
    q: Quotient, problem: Problem
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(fixed: bool[Q], their values, the reward of every row (float64[R]), the discount) of the
    Bellman operator x -> base + g T x of a probability or a discounted cost."""
    Q = q.model.num_states
    if q.rewards is None:
        return (q.target | ~q.remain, q.target.astype(np.float64),
                np.zeros(q.hole.size), 1.0)
    return q.target, np.zeros(Q), q.rewards, problem.discount


def _optimistic(q: Quotient, problem: Problem) -> np.ndarray | None:
    """Values on the decision maker's good side of every family's value (float64[Q]), a sound
    start for :func:`_solve` with a cutoff: 1 (0 for a minimiser) for probabilities, the
    extreme discounted sum for discounted costs; None for other objectives."""
    if q.rewards is not None and problem.discount >= 1.0:
        return None
    fixed, fixed_values, base, gamma = _bellman_parts(q, problem)
    if q.rewards is None:
        good = 1.0 if problem.maximize else 0.0
    else:
        extreme = base.max(initial=0.0) if problem.maximize else base.min(initial=0.0)
        good = (
            max(extreme, 0.0) / (1.0 - gamma)
            if problem.maximize
            else min(extreme, 0.0) / (1.0 - gamma)
        )
    return np.where(fixed, fixed_values, good)


def _solve_engine(q: Quotient, rows: np.ndarray, rg: np.ndarray, T: sp.csr_matrix) -> _Solved:
    """Expected rewards until a target (PRISM's infinity semantics) by the engines."""
    sub = dataclasses.replace(q.model, row_groups=rg, transitions=T,
                              choice_actions=q.model.choice_actions[rows])
    options = SolverOptions(method=Method.POLICY, prove=False)
    assert q.rewards is not None  # noqa: S101 - only called for rewards
    r = obj.expected_reach_reward(sub, q.rewards[rows], q.target, maximize=q.maximize,
                                  options=options)
    strategy = np.full(q.model.num_states, -1, dtype=np.int64)
    if r.strategy is not None:
        chosen = r.strategy >= 0
        strategy[chosen] = rows[r.strategy[chosen]]
    return _Solved(float(r.values[q.initial]), np.asarray(r.values, dtype=np.float64), strategy)


def _used(q: Quotient, allowed: np.ndarray, strategy: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hole, option) pairs σ = ``strategy`` plays in the decision maker's states reachable under
    σ and any adversary choice: int64[U] keys h * O + o, how many states use each, and how early
    each is first met (its rank in breadth-first order from the initial state)."""
    enabled = (q.hole < 0) | allowed[np.maximum(q.hole, 0), np.maximum(q.option, 0)]
    own_state = np.zeros(q.model.num_states, dtype=bool)
    own_state[q.row_state[q.hole >= 0]] = True
    rows = np.arange(q.hole.size)
    # the decision maker's rows: σ's only (where σ has none the value does not depend on it)
    follow = enabled & np.where(own_state[q.row_state], strategy[q.row_state] == rows, True)
    T = q.model.transitions[follow].tocoo()
    src = q.row_state[follow][T.row]
    Q = q.model.num_states
    graph = sp.csr_matrix((np.ones(src.size, dtype=np.int8), (src, T.col)), shape=(Q, Q))
    order = csgraph.breadth_first_order(graph, q.initial, return_predecessors=False)
    rank = np.full(Q, Q, dtype=np.int64)
    rank[order] = np.arange(order.size)
    mine = np.flatnonzero((rank < Q) & own_state & (strategy >= 0))
    r = strategy[mine]
    keys, inverse, counts = np.unique(q.hole[r] * q.num_options + q.option[r], return_inverse=True,
                                      return_counts=True)
    first = np.full(keys.size, Q, dtype=np.int64)
    np.minimum.at(first, inverse, rank[mine])
    return keys, counts, first


def _member(q: Quotient, allowed: np.ndarray, keys: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The member of the family taking each hole's most used option (the first allowed one where
    σ uses none): bool[H, O], one option per hole."""
    O = q.num_options  # noqa: E741 - the number of options, O in bool[H, O]
    choice = np.argmax(allowed, axis=1)  # first allowed option
    votes = np.zeros(allowed.shape, dtype=np.int64)
    votes.flat[keys] = counts
    used = votes.max(axis=1) > 0
    choice[used] = np.argmax(votes[used], axis=1)
    member = np.zeros_like(allowed)
    member[np.arange(allowed.shape[0]), choice] = True
    return member & allowed if O else member


def _split(allowed: np.ndarray, keys: np.ndarray, counts: np.ndarray, first: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray] | None:
    """Two sub-families separating the options of a hole σ uses inconsistently — the one met
    first from the initial state (decisions near the start weigh most) — or None when σ is
    consistent."""
    O = allowed.shape[1]  # noqa: E741 - the number of options, O in bool[H, O]
    holes = keys // O
    distinct = np.bincount(holes, minlength=allowed.shape[0])
    if distinct.max(initial=0) <= 1:
        return None
    met = np.full(allowed.shape[0], np.iinfo(np.int64).max)
    np.minimum.at(met, holes, first)
    met[distinct <= 1] = np.iinfo(np.int64).max
    h = int(np.argmin(met))
    mine = keys[holes == h] % O
    mine_counts = counts[holes == h]
    by_use = mine[np.lexsort((mine, -mine_counts))].tolist()
    rest = [o for o in np.flatnonzero(allowed[h]).tolist() if o not in by_use]
    ordered = by_use + rest
    left, right = allowed.copy(), allowed.copy()
    left[h] = False
    right[h] = False
    left[h, ordered[0::2]] = True
    right[h, ordered[1::2]] = True
    return left, right


def _consistent(keys: np.ndarray, num_options: int) -> bool:
    """Whether σ uses one option per hole."""
    holes = keys // num_options
    return bool(np.unique(holes).size == holes.size)


def _split_member(allowed: np.ndarray, member: np.ndarray, keys: np.ndarray, first: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """When σ is consistent but its member falls short of the bound (value iteration's choices
    at end components): split the hole met first that still has a choice, the member's option
    against the rest; None when the family is one member."""
    O = allowed.shape[1]  # noqa: E741 - the number of options, O in bool[H, O]
    wide = allowed.sum(axis=1) > 1
    if not wide.any():
        return None
    met = np.full(allowed.shape[0], np.iinfo(np.int64).max)
    np.minimum.at(met, keys // O, first)
    met[~wide] = np.iinfo(np.int64).max
    h = (
        int(np.argmin(met))
        if np.any(met < np.iinfo(np.int64).max)
        else int(np.flatnonzero(wide)[0])
    )
    left, right = allowed.copy(), allowed.copy()
    left[h] = member[h] & allowed[h]
    right[h] = allowed[h] & ~member[h]
    return left, right


@dataclass(frozen=True, eq=False)
class DeterministicResult:
    """The best deterministic k-FSS found: ``gamma`` float64[k, Zu, Au] and ``delta``
    float64[k, Zu, Au, k] (one-hot, in the :class:`Layout`'s order), its value against the
    omniscient adversary by policy iteration (a ranking, not a proof), whether the search was
    ``exhaustive`` (then no deterministic k-FSS is better, up to float tolerance), how many
    families were solved, and the seconds spent."""

    memory: int
    gamma: np.ndarray
    delta: np.ndarray
    value: float
    exhaustive: bool
    families: int
    seconds: float

    @classmethod
    def of_member(cls, q: Quotient, member: np.ndarray, *, value: float, exhaustive: bool,
                  families: int, seconds: float) -> DeterministicResult:
        """The deterministic ``q.memory``-node FSS that ``member`` (bool[H, O], one option per
        hole of ``q``) picks, with what was found about it."""
        gamma, delta = _arrays(q, member)
        return cls(q.memory, gamma, delta, value, exhaustive, families, seconds)


def search(problem: Problem, memory: int, *, deadline: float | None,
           max_families: int | None = None,
           incumbent: DeterministicResult | None = None) -> DeterministicResult | None:
    """Abstraction refinement over the deterministic ``memory``-node FSSs (module docstring),
    until every family is decided, ``max_families`` quotients were solved, or ``deadline`` (a
    ``time.perf_counter()`` value). None when the model's observations do not suit deterministic
    rules (see :func:`quotient_of`). ``incumbent``: a smaller defence found before, embedded
    (its extra nodes never entered) as the first incumbent, so that families that cannot beat
    it are pruned from the start."""
    started = time.perf_counter()
    q = quotient_of(problem, memory, deadline=deadline)
    if q is None or (q.rewards is not None and problem.discount >= 1.0
                     and q.model.num_states > _ENGINE_LIMIT):
        return None
    sign = problem.sign
    best: tuple[float, np.ndarray] | None = None
    if incumbent is not None and incumbent.memory <= memory:
        best = (incumbent.value, _member_of(q, incumbent.gamma, incumbent.delta))
    root = q.offered.copy()
    # a parent's values start its sub-families where they lie on the decision maker's good side
    # and iterating from there converges to the value: for a minimiser (from below, the least
    # fixed point) and for discounted costs (a contraction). A maximiser of a probability
    # iterates from below instead (from above the iteration may stop at a larger fixed point,
    # end components), so its bounds are the values as value iteration approximates them
    warm = not (problem.maximize and q.rewards is None)
    top = _solve(
        q,
        root,
        _optimistic(q, problem) if warm else None,
        problem,
        precision=_FAMILY_PRECISION,
        deadline=deadline,
        ordered=True,
    )
    if top.cut:  # out of time before the first bound
        return None if incumbent is None else dataclasses.replace(incumbent, exhaustive=False)
    # depth first (PAYNT's order), each family solved when it is made, so that of two halves
    # the one with the better bound is explored first and a half that cannot beat the
    # incumbent is dropped at once; entries (allowed, its solve)
    stack: list[tuple[np.ndarray, _Solved]] = [(root, top)]
    families = 1
    exhaustive = True

    def better(v: float) -> bool:
        if best is None:
            return True
        tol = 1e-9 * max(1.0, abs(best[0])) if np.isfinite(best[0]) else 0.0
        return sign * v > sign * best[0] + tol

    def cutoff() -> float | None:
        return None if best is None else best[0] + sign * 1e-9 * max(1.0, abs(best[0]))

    while stack:
        if expired(deadline) or (max_families is not None and families >= max_families):
            exhaustive = False
            break
        allowed, solved = stack.pop()
        if solved.cut or (best is not None and not better(solved.value)):
            continue  # nothing in this family beats the incumbent (found since it was solved)
        keys, counts, first = _used(q, allowed, solved.strategy)
        halves = _split(allowed, keys, counts, first)
        member = _member(q, allowed, keys, counts)
        if halves is None:
            halves = _split_member(allowed, member, keys, first)
        # the member from the family's values: optimistic for the member too (cut when it
        # cannot beat the incumbent), except for a maximiser, whose iterates from above may stop
        # at a fixed point above the member's value (end components): from below for it
        checked = _solve(q, member, None if problem.maximize else solved.values, problem,
                         cutoff=None if problem.maximize else cutoff(), deadline=deadline,
                         ordered=True)
        families += 1
        if not checked.cut and better(checked.value):
            best = (checked.value, member)
        if halves is None:
            continue  # one member left
        if checked.cut and expired(deadline):
            exhaustive = False
        elif _consistent(keys, q.num_options) and (
            checked.cut or abs(checked.value - solved.value) <= 1e-7 * max(1.0, abs(solved.value))
        ):
            # σ is a member and achieves the bound (or, cut, provably not the incumbent's): the
            # family's optimum is known
            continue
        children = []
        for half in reversed(halves):
            child = _solve(q, half, solved.values if warm else None, problem,
                           cutoff=cutoff() if warm else None,
                           precision=_FAMILY_PRECISION, deadline=deadline, ordered=True)
            families += 1
            if child.cut and expired(deadline):
                exhaustive = False
            elif not child.cut and better(child.value):
                children.append((half, child))
        # the better bound on top (the first half, with σ's most used option, on a tie)
        children.sort(key=lambda c: sign * c[1].value)
        stack.extend(children)
    if best is None:
        return None
    return DeterministicResult.of_member(q, best[1], value=best[0], exhaustive=exhaustive,
                                         families=families,
                                         seconds=time.perf_counter() - started)


def _member_of(q: Quotient, gamma: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """The member (bool[H, O]) of a deterministic FSS with at most ``q.memory`` nodes; nodes
    beyond its own copy node 0 (they are never entered)."""
    k0, k = gamma.shape[0], q.memory
    Zu = gamma.shape[1]
    a = gamma.argmax(axis=2)  # [k0, Zu]
    nxt = np.take_along_axis(delta.argmax(axis=3), a[..., None], axis=2)[..., 0]
    a = np.concatenate([a, np.repeat(a[:1], k - k0, axis=0)])
    nxt = np.concatenate([nxt, np.repeat(nxt[:1], k - k0, axis=0)])
    member = np.zeros((k * Zu, q.num_options), dtype=bool)
    member[np.arange(k * Zu), (a * k + nxt).ravel()] = True
    return member


def _arrays(q: Quotient, member: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """γ and δ of a member (one option per hole), in the Layout's shapes."""
    k = q.memory
    Zu, Au = q.layout.mask.shape
    o = np.argmax(member, axis=1).reshape(k, Zu)
    a, nxt = o // k, o % k
    gamma = np.zeros((k, Zu, Au))
    np.put_along_axis(gamma, a[..., None], 1.0, axis=2)
    delta = np.zeros((k, Zu, Au, k))
    delta[np.arange(k)[:, None, None], np.arange(Zu)[None, :, None], np.arange(Au)[None, None, :],
          nxt[..., None]] = 1.0
    return gamma, delta


@dataclass(frozen=True, eq=False)
class DeterministicJob:
    """The abstraction-refinement search for each memory size in turn (a job of
    :mod:`posgmc.synthesis.executors`), each seeded with the best smaller defence and stopped
    after its own number of ``families`` (quotient solves), or at ``deadline`` (the wall-clock
    cap, a ``time.perf_counter()`` value). ``seeds``: defences found
    before (by :mod:`posgmc.synthesis.improvement`), each the first incumbent of its size and
    the larger ones when better than the smaller size's result. ``run`` returns the best
    defence with at most k nodes for each size reached."""

    PHASE: ClassVar[str] = "deterministic search"

    memory: tuple[int, ...]
    deadline: float | None
    families: tuple[int, ...]
    seeds: tuple[DeterministicResult, ...] = ()

    def run(self, problem: Problem) -> tuple[DeterministicResult, ...]:
        found: list[DeterministicResult] = []
        best: DeterministicResult | None = None
        deadline = self.deadline
        for k, max_families in zip(self.memory, self.families):
            if expired(deadline):  # no size starts after the cap (its quotient alone has k² rows)
                break
            for seed in self.seeds:
                if seed.memory <= k and (
                        best is None or problem.sign * seed.value > problem.sign * best.value):
                    best = seed
            r = search(problem, k, deadline=deadline, max_families=max_families,
                       incumbent=best if best is not None and best.memory <= k else None)
            if r is None:
                continue
            found.append(r)
            best = r
        return tuple(found)


def deterministic_phase(executor: Executor, memory: tuple[int, ...], deadline: float | None, *,
                        families: int, seeds: tuple[DeterministicResult, ...] = ()
                        ) -> dict[int, DeterministicResult]:
    """Run the deterministic search over ``memory`` with ``families`` quotient solves in all (the
    work budget), cut in parts: one for the first size, three for the second, two for each
    further one (the first is small and often exhaustive at once; the second is where memory
    first helps), each size's search stopping at its part; ``deadline``: the wall-clock cap.
    ``seeds``: first incumbents (:class:`DeterministicJob`). Returns the best defence with at
    most k nodes, by k."""
    weights = np.array([1.0] + [3.0] + [2.0] * (len(memory) - 2))[: len(memory)]
    parts = tuple(max(1, int(families * float(w) / weights.sum())) for w in weights)
    results = executor.map([DeterministicJob(tuple(memory), deadline, parts, seeds=seeds)])[0]
    return {r.memory: r for r in results}
