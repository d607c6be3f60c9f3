"""A belief-based finite-state controller for a POMDP: explore the belief MDP from the initial
belief, choose actions there by value iteration with achievable cut-off values at the frontier,
and read the result off as an ordinary finite-state strategy (FSS).

The idea is Storm's and SAYNT's under-approximation of a POMDP by belief exploration (Bork,
Katoen, Quatmann, "Under-Approximating Expected Total Rewards in POMDPs", TACAS 2022; Andriushchenko
et al., "Search and Explore: Symbiotic Policy Synthesis in POMDPs", CAV 2023), written here for
posgmc's FSS semantics, where the memory update δ(n, z, a) is chosen *before* the successor's
observation is seen.

* A **memory node** n is a predicted state distribution d_n: where the model may be after the
  actions so far, before the next observation (the initial node: the initial state). Only the
  mass on *continuing* states is kept (a ``P`` objective: ``remain`` and not ``target``; a
  reward: not ``target``) and renormalised; nodes are hashed after rounding their probabilities
  to :data:`PRECISION`.
* A **belief** is a pair (n, z): d_n conditioned on observation z, with weight w(n, z), the
  probability of seeing z. In state s with observation z and node n the FSS plays the belief's
  action a and moves to the node d_n|z · P_a (restricted to continuing states, renormalised).
* At any belief the controller may **hand over** to a given FSS (the cut-off strategy, usually
  the best one the gradient search found): it plays, in that belief, as the cut-off strategy does
  in one of its nodes m, and from then on the cut-off strategy's nodes take over. Handing over in
  node m guarantees Σ_s b(s) V(s, m), with V the cut-off strategy's value from (s, m) — a number
  that is *achievable*, unlike a belief-MDP upper bound. Frontier beliefs (not expanded) only
  hand over.
* **Value iteration** on the explored part starts from the hand-over values and takes an action
  only where it strictly improves (sign-adjusted: maximising), so every belief's number is the
  value of a strategy that exists. Exploration is guided like HSVI: a second value iteration with
  the full-observation values at the frontier (optimistic) picks the frontier nodes that its
  greedy policy reaches with the largest probability times gap.

The belief MDP's numbers are a ranking only: the FSS is checked by the sound product check like
every other candidate (:mod:`posgmc.synthesis.search`), and only that check's bounds are reported.

Limits: POMDPs only (one player; against an adversary the belief would depend on the adversary's
unobserved choices, so a belief node is not a sound summary of the history there). The FSS is
dense (``update`` is float64[k, Z, A, k]), so the memory nodes are capped
(:func:`node_cap`); only the nodes the chosen policy reaches are kept.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.engines.graph import positive_reach, structure_of
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import bind, player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.syntax.ast import ProbQuery, RewardQuery
from posgmc.synthesis.belief_stage import StageDynamics, stage_dynamics
from posgmc.synthesis.parametric import Layout
from posgmc.synthesis.problem import Problem, expired

__all__ = ["BeliefController", "belief_controller", "belief_points", "belief_phase", "applies",
           "cutoff_values", "node_cap", "PRECISION", "can_reach"]

PRECISION = 1e-9
"""Beliefs whose probabilities agree after rounding to this grid are one memory node."""

SHARE = 0.3
"""The part of a pomdp's wall-clock cap kept for the belief phase (after the search)."""

FSS_ELEMENTS = 12_000_000
"""The dense FSS's update array (k² · Z · A entries) is kept below this many entries."""

PRODUCT_ELEMENTS = 12_000_000
"""The product construction lays out choices × k × k entries; kept below this."""

EXPLORE_SHARE = 0.6
"""The part of the belief phase's time spent exploring, under a wall-clock cap."""

MAX_EXPLORED = 300_000
"""Belief nodes explored at most, whatever the work budget asks."""

_VI_SWEEPS = 5_000
_GUIDE_SWEEPS = 300  # the optimistic value iteration only guides exploration
_VI_TOLERANCE = 1e-10
_POLICY = CheckOptions(solver=SolverOptions(method=Method.POLICY, prove=False))


@dataclass(frozen=True, eq=False)
class BeliefController:
    """``strategy``: the FSS (belief nodes first, node 0 the initial belief, then the cut-off
    strategy's nodes); ``estimate``: the belief MDP's value at the initial belief (a float ranking,
    achievable up to rounding, not a proof); ``cutoff_estimate``: the hand-over value there;
    ``belief_nodes``: memory nodes of the explored part that the FSS keeps; ``explored``: belief
    nodes created; ``expanded``: nodes expanded; ``beliefs``: (node, observation) pairs."""

    strategy: FiniteStateStrategy
    estimate: float
    cutoff_estimate: float
    belief_nodes: int
    explored: int
    expanded: int
    beliefs: int


def node_cap(model: ExplicitModel, layout: Layout, cutoff_memory: int) -> int:
    """The most belief nodes a dense FSS of this model holds within the element budgets."""
    Zu, Au = layout.mask.shape
    k_fss = int(np.sqrt(FSS_ELEMENTS / max(1, Zu * Au)))
    k_prod = int(np.sqrt(PRODUCT_ELEMENTS / max(1, model.num_choices)))
    return max(0, min(k_fss, k_prod) - cutoff_memory)


def cutoff_values(
    model: ExplicitModel,
    fss: FiniteStateStrategy,
    query: ProbQuery | RewardQuery,
    *,
    coalition_of: CoalitionResolver,
    scalar: ScalarEvaluator,
) -> np.ndarray:
    """float64[S, k]: the value of ``fss`` started in state s with memory node m (NaN where the
    product from every state with the initial node does not reach (s, m)), by policy iteration on
    the product (a float ranking, not a proof)."""
    everywhere = _replace_initial(model, np.arange(model.num_states, dtype=np.int64))
    prod = strategy_product(everywhere, [bind(everywhere, fss)])
    checker = PropertyChecker(prod.model, coalition_of=coalition_of, scalar=scalar,
                              options=_POLICY)
    values = np.asarray(checker.query(query, everywhere=True).values, dtype=np.float64)
    out = np.full((model.num_states, fss.memory_size), np.nan)
    out[prod.state_of, prod.memory_of[:, 0]] = values
    return out


def _replace_initial(model: ExplicitModel, initial: np.ndarray) -> ExplicitModel:
    import dataclasses

    return dataclasses.replace(model, initial_states=initial)


class _Explorer:
    """The belief MDP while it is explored (mutable; :func:`belief_controller` freezes the
    result into an FSS). Values are sign-adjusted: larger is better."""

    def __init__(
        self,
        model: ExplicitModel,
        layout: Layout,
        dynamics: StageDynamics,
        discount: float,
        cut: np.ndarray,
        upper: np.ndarray,
    ) -> None:
        self.S = model.num_states
        self.mask = layout.mask
        self.Zu, self.Au = layout.mask.shape
        self.obs = dynamics.obs  # int64[S]: the strategy's observation index (-1: none)
        self.discount = discount
        self.cut = cut  # float64[S, kc], signed, -inf where unknown
        self.upper = upper  # float64[S], signed full-observation values
        self.P = dynamics.P  # per action: S x S, continuing columns only
        self.stop = dynamics.stop  # per action: float64[S], signed gain of stopping mass
        self.reward = dynamics.reward  # per action: float64[S], signed action reward
        # nodes: predicted distributions over continuing states
        self.node_key: dict[bytes, int] = {}
        self.num_nodes = 0
        self.expanded: list[bool] = []
        # beliefs (node, z): node, observation, weight, distribution (chunks of csr rows)
        self.b_node: list[np.ndarray] = []
        self.b_z: list[np.ndarray] = []
        self.b_w: list[np.ndarray] = []
        self.b_rows: list[sp.csr_matrix] = []
        self.num_beliefs = 0
        self.beliefs_of: list[np.ndarray] = []  # per node: its belief ids
        # choices of expanded beliefs: belief, action, signed immediate value, continuing mass,
        # successor node (-1: nothing continues)
        self.c_belief: list[np.ndarray] = []
        self.c_action: list[np.ndarray] = []
        self.c_imm: list[np.ndarray] = []
        self.c_mass: list[np.ndarray] = []
        self.c_succ: list[np.ndarray] = []

    # -- construction -----------------------------------------------------------------------------

    def add_nodes(self, rows: sp.csr_matrix) -> np.ndarray:
        """The node of each (normalised) row, new ones created with their beliefs."""
        rows = sp.csr_matrix(rows)
        out = np.empty(rows.shape[0], dtype=np.int64)
        new: list[int] = []
        for i in range(rows.shape[0]):
            lo, hi = rows.indptr[i], rows.indptr[i + 1]
            idx = rows.indices[lo:hi].astype(np.int64)
            q = np.rint(rows.data[lo:hi] / PRECISION).astype(np.int64)
            key = idx.tobytes() + q.tobytes()
            n = self.node_key.get(key)
            if n is None:
                n = self.num_nodes + len(new)
                self.node_key[key] = n
                new.append(i)
            out[i] = n
        if new:
            fresh = rows[np.asarray(new)]
            first = self.num_nodes
            self.num_nodes += fresh.shape[0]
            self.expanded.extend([False] * fresh.shape[0])
            self._split(fresh, first)
        return out

    def _split(self, fresh: sp.csr_matrix, first: int) -> None:
        """The beliefs (node, z) of new nodes ``first``..: one per observation in the support."""
        coo = fresh.tocoo()
        z = self.obs[coo.col]
        pair = coo.row.astype(np.int64) * (self.Zu + 1) + (z + 1)
        uniq, inv = np.unique(pair, return_inverse=True)
        w = np.bincount(inv, weights=coo.data, minlength=uniq.size)
        node = first + uniq // (self.Zu + 1)
        bz = uniq % (self.Zu + 1) - 1
        ids = self.num_beliefs + np.arange(uniq.size)
        self.b_node.append(node)
        self.b_z.append(bz)
        self.b_w.append(w)
        self.b_rows.append(sp.csr_matrix((coo.data / w[inv], (inv, coo.col)),
                                         shape=(uniq.size, self.S)))
        self.num_beliefs += uniq.size
        order = np.argsort(node, kind="stable")
        bounds = np.searchsorted(node[order], first + np.arange(fresh.shape[0] + 1))
        for j in range(fresh.shape[0]):
            self.beliefs_of.append(ids[order[bounds[j]:bounds[j + 1]]])

    def expand(self, nodes: np.ndarray) -> None:
        """Every action of every belief of ``nodes``: its value now and its successor node."""
        ids = np.concatenate([self.beliefs_of[n] for n in nodes.tolist()])
        for n in nodes.tolist():
            self.expanded[n] = True
        z_all = self.arrays()[1]
        ids = ids[z_all[ids] >= 0]  # beliefs on states without observation: none
        if not ids.size:
            return
        B = self.belief_matrix()[ids]
        z = z_all[ids]
        for a in range(self.Au):
            sel = np.flatnonzero(self.mask[z, a])
            if not sel.size:
                continue
            Ba = B[sel]
            D = sp.csr_matrix(Ba @ self.P[a])
            D.eliminate_zeros()
            imm = np.asarray(Ba @ (self.stop[a] + self.reward[a])).ravel()
            mass = np.asarray(D.sum(axis=1)).ravel()
            succ = np.full(sel.size, -1, dtype=np.int64)
            live = np.flatnonzero(mass > 0)
            if live.size:
                norm = sp.diags(1.0 / mass[live]) @ D[live]
                succ[live] = self.add_nodes(sp.csr_matrix(norm))
            self.c_belief.append(ids[sel])
            self.c_action.append(np.full(sel.size, a, dtype=np.int64))
            self.c_imm.append(imm)
            self.c_mass.append(np.where(succ >= 0, mass, 0.0))
            self.c_succ.append(succ)

    # -- views ------------------------------------------------------------------------------------

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(node, z, weight) of every belief."""
        return (np.concatenate(self.b_node), np.concatenate(self.b_z), np.concatenate(self.b_w))

    def belief_matrix(self) -> sp.csr_matrix:
        if len(self.b_rows) > 1:
            self.b_rows = [sp.csr_matrix(sp.vstack(self.b_rows))]
        return self.b_rows[0]

    def choices(self) -> tuple[np.ndarray, ...]:
        """(belief, action, imm, mass, succ) of every choice, sorted by belief."""
        if not self.c_belief:
            e = np.zeros(0, dtype=np.int64)
            return e, e, np.zeros(0), np.zeros(0), e
        b = np.concatenate(self.c_belief)
        order = np.argsort(b, kind="stable")
        return (b[order], np.concatenate(self.c_action)[order], np.concatenate(self.c_imm)[order],
                np.concatenate(self.c_mass)[order], np.concatenate(self.c_succ)[order])

    def handover(self) -> tuple[np.ndarray, np.ndarray]:
        """Each belief's best hand-over value (signed) and the cut-off node that achieves it."""
        B = self.belief_matrix()
        finite = np.isfinite(self.cut)
        # a node m is open at a belief only if its value is known in every state of the support
        known = np.asarray((B != 0).astype(np.float64) @ (~finite).astype(np.float64)) == 0
        safe = np.where(finite, self.cut, 0.0)
        vals = np.where(known, np.asarray(B @ safe), -np.inf)
        m = vals.argmax(axis=1)
        return vals[np.arange(vals.shape[0]), m], m

    def solve(self, start: np.ndarray, choices: tuple[np.ndarray, ...], *, optimistic: bool,
              deadline: float | None, sweeps: int = _VI_SWEEPS
              ) -> tuple[np.ndarray, np.ndarray]:
        """Value iteration on the explored belief MDP from ``start`` (signed values per belief).

        Pessimistic (``optimistic`` False): a belief takes an action only when it strictly beats
        its current value (which starts at the achievable hand-over value), so the values stay
        achievable. Optimistic: frontier beliefs keep ``start`` (upper bounds) and expanded ones
        take their best action. ``choices``: as :meth:`choices` gives them (or a part).
        Returns (values, chosen index into ``choices`` or -1 per belief)."""
        node, _, w = self.arrays()
        cb, _, imm, mass, succ = choices
        V = start.copy()
        choice = np.full(V.size, -1, dtype=np.int64)
        if not cb.size:
            return V, choice
        starts = np.flatnonzero(np.r_[True, cb[1:] != cb[:-1]])
        owners = cb[starts]
        num_nodes = self.num_nodes
        for _ in range(sweeps):
            U = np.bincount(node, weights=np.where(w > 0, w * V, 0.0), minlength=num_nodes)
            fut = np.where(succ >= 0, U[np.maximum(succ, 0)], 0.0)
            Q = imm + self.discount * np.where(mass > 0, mass * fut, 0.0)
            Q = np.where(np.isnan(Q), -np.inf, Q)
            best = np.maximum.reduceat(Q, starts)
            # the first choice of each belief attaining its best
            hit = Q >= np.repeat(best, np.diff(np.r_[starts, Q.size]))
            first_hit = np.maximum.reduceat(np.where(hit, -np.arange(Q.size), -Q.size), starts)
            arg = -first_hit
            old = V[owners]
            if optimistic:
                change = np.abs(np.where(np.isfinite(best) & np.isfinite(old), best - old, 0.0))
                V[owners] = best
                choice[owners] = arg
                if change.max(initial=0.0) <= _VI_TOLERANCE or expired(deadline):
                    break
                continue
            margin = np.where(np.isfinite(old), _VI_TOLERANCE * np.maximum(1.0, np.abs(old)), 0.0)
            better = best > old + margin
            if not better.any():
                break
            V[owners[better]] = best[better]
            choice[owners[better]] = arg[better]
            if expired(deadline):
                break
        return V, choice

    def occupancy(self, choice: np.ndarray, choices: tuple[np.ndarray, ...],
                  steps: int = 200) -> np.ndarray:
        """How much probability each node receives from the initial node under ``choice``
        (expected visits, truncated after ``steps`` steps)."""
        node, _, w = self.arrays()
        _, _, _, mass, succ = choices
        num_nodes = self.num_nodes
        acting = np.flatnonzero(choice >= 0)
        c = choice[acting]
        go = succ[c] >= 0
        M = sp.csr_matrix(
            (w[acting][go] * mass[c][go] * self.discount, (node[acting][go], succ[c][go])),
            shape=(num_nodes, num_nodes),
        )
        MT = sp.csr_matrix(M.T)
        x = np.zeros(num_nodes)
        x[0] = 1.0
        total = x.copy()
        for _ in range(steps):
            x = MT @ x
            total += x
            if x.sum() < 1e-9:
                break
        return total


def belief_controller(
    model: ExplicitModel,
    *,
    player: int,
    cutoff: FiniteStateStrategy,
    cut_values: np.ndarray,
    upper: np.ndarray,
    target: np.ndarray,
    remain: np.ndarray,
    rewards: np.ndarray | None,
    discount: float,
    maximize: bool,
    deadline: float | None,
    max_nodes: int | None = None,
    explore: int = MAX_EXPLORED,
    adversary_rule: np.ndarray | None = None,
) -> BeliefController | None:
    """A belief-based FSS for ``player`` (the only player of a POMDP, or the decision maker of a
    turn-based game against one omniscient adversary) that hands over to ``cutoff`` at its
    frontier.

    Args:
        model: the POMDP or the game.
        player: its decision maker.
        cutoff: the strategy handed over to (in the layout of :class:`Layout` for ``model``).
        cut_values: float64[S, k]: ``cutoff``'s value from (s, m) (:func:`cutoff_values`).
        upper: float64[S]: the full-observation values (bounds for any strategy).
        target, remain, rewards, discount: the objective (as :func:`posgmc.synthesis.search.
            problem_of` gives it); ``rewards`` None for a probability.
        maximize: the objective's direction.
        deadline: the wall-clock cap, a ``time.perf_counter()`` value by which the controller
            is built (None: none): exploration stops after :data:`EXPLORE_SHARE` of the time
            left, the final value iteration and the FSS take the rest (value iteration stopped
            early keeps achievable values).
        max_nodes: belief memory nodes at most (default :func:`node_cap`).
        explore: belief nodes explored at most (the work budget; at most
            :data:`MAX_EXPLORED`).
        adversary_rule: on a game, the stage rule the controller assumes for the other
            player (float64[C], :mod:`posgmc.synthesis.belief_stage`); ``cut_values`` and
            ``upper`` are then against the omniscient adversary. None on a POMDP.

    Returns:
        The controller, or None when there is nothing to explore (the initial state does not
        continue, the cut-off strategy is in another layout, or no node fits the caps).
    """
    layout = Layout.of(model, player)
    cap = node_cap(model, layout, cutoff.memory_size) if max_nodes is None else max_nodes
    if cap < 1:
        return None
    ex = _explored(model, player=player, cutoff=cutoff, cut_values=cut_values, upper=upper,
                   target=target, remain=remain, rewards=rewards, discount=discount,
                   maximize=maximize, deadline=deadline, explore=explore,
                   adversary_rule=adversary_rule)
    if ex is None:
        return None
    return _freeze(ex, cutoff, cap, deadline, 1.0 if maximize else -1.0)


def belief_points(
    model: ExplicitModel,
    *,
    player: int,
    cutoff: FiniteStateStrategy,
    cut_values: np.ndarray,
    upper: np.ndarray,
    target: np.ndarray,
    remain: np.ndarray,
    rewards: np.ndarray | None,
    discount: float,
    maximize: bool,
    deadline: float | None,
    explore: int = MAX_EXPLORED,
    adversary_rule: np.ndarray | None = None,
) -> sp.csr_matrix | None:
    """The belief nodes :func:`belief_controller` explores with the same arguments, as rows
    (float64, nodes x S, each the predicted distribution over the continuing states where the
    decision maker acts next, in the order they were found: the initial one first); None when
    there is nothing to explore."""
    ex = _explored(model, player=player, cutoff=cutoff, cut_values=cut_values, upper=upper,
                   target=target, remain=remain, rewards=rewards, discount=discount,
                   maximize=maximize, deadline=deadline, explore=explore,
                   adversary_rule=adversary_rule)
    if ex is None:
        return None
    node, _, w = ex.arrays()
    B = ex.belief_matrix()
    # a node's distribution: its beliefs (one per observation) weighted by their probability
    W = sp.csr_matrix((w, (node, np.arange(node.size))), shape=(ex.num_nodes, node.size))
    return sp.csr_matrix(W @ B)


def _explored(
    model: ExplicitModel,
    *,
    player: int,
    cutoff: FiniteStateStrategy,
    cut_values: np.ndarray,
    upper: np.ndarray,
    target: np.ndarray,
    remain: np.ndarray,
    rewards: np.ndarray | None,
    discount: float,
    maximize: bool,
    deadline: float | None,
    explore: int,
    adversary_rule: np.ndarray | None,
) -> _Explorer | None:
    """The belief MDP explored as :func:`belief_controller` describes (None: nothing to
    explore)."""
    layout = Layout.of(model, player)
    view = player_view(model, player)
    if (cutoff.actions != tuple(model.action_names[a] for a in layout.used_actions)
            or not np.array_equal(cutoff.observation_values, view.obs_values[layout.used_obs])):
        return None
    sign = 1.0 if maximize else -1.0
    if rewards is None:
        # states that cannot reach the target (within ``remain``) are worth 0 whatever happens
        cont = remain & ~target & can_reach(model, target, remain)
        gain = sign * target.astype(np.float64)
    else:
        cont = ~target
        gain = np.zeros(model.num_states)
    if model.initial_states.size != 1 or not cont[int(model.initial_states[0])]:
        return None
    dynamics = stage_dynamics(model, player, cont=cont, gain=gain, rewards=rewards,
                              discount=discount, sign=sign, rule=adversary_rule)
    first = np.flatnonzero(dynamics.initial > 0)
    if not first.size:
        return None
    cut = sign * cut_values
    cut = np.where(np.isnan(cut), -np.inf, cut)
    up = np.where(np.isnan(upper), np.inf, sign * upper)
    ex = _Explorer(model, layout, dynamics, discount, cut, up)
    p0 = dynamics.initial[first]
    ex.add_nodes(sp.csr_matrix((p0 / p0.sum(), (np.zeros(first.size, dtype=np.int64), first)),
                               shape=(1, model.num_states)))
    # explore more nodes than an FSS holds: the policy reaches a part of them
    limit = min(explore, MAX_EXPLORED)
    now = time.perf_counter()
    explore_until = None if deadline is None else now + EXPLORE_SHARE * max(0.0, deadline - now)
    while True:
        frontier = np.flatnonzero(~np.asarray(ex.expanded))
        if not frontier.size or ex.num_nodes >= limit or expired(explore_until):
            break
        if ex.num_nodes == 1:
            ex.expand(frontier)
            continue
        hand, _ = ex.handover()
        node, _, w = ex.arrays()
        B = ex.belief_matrix()
        optimistic = np.asarray(B @ np.where(np.isfinite(up), up, 0.0)).ravel()
        optimistic = np.where(np.asarray(B @ np.isinf(up).astype(np.float64)).ravel() > 0,
                              np.inf, optimistic)
        everything = ex.choices()
        _, choice = ex.solve(np.maximum(optimistic, hand), everything, optimistic=True,
                             deadline=explore_until, sweeps=_GUIDE_SWEEPS)
        occ = ex.occupancy(choice, everything)
        gap = np.bincount(node, weights=w * np.minimum(optimistic - hand, 1e12),
                          minlength=ex.num_nodes)
        gap = np.where(np.isfinite(gap), gap, 1e12)
        score = occ[frontier] * np.maximum(gap[frontier], 0.0)
        batch = max(1, min(ex.num_nodes // 2, limit - ex.num_nodes) // 2)
        # the most promising frontier nodes first (reached by the optimistic policy, with a gap
        # between the optimistic and the hand-over value), the batch filled up breadth first
        # with the other nodes that have a gap
        order = np.lexsort((frontier, -score))
        ranked = frontier[order[score[order] > 0]]
        rest = frontier[(score <= 0) & (gap[frontier] > 0)]
        pick = np.concatenate([ranked, rest])[:batch]
        if not pick.size:
            break  # the hand-over is as good as the optimistic value everywhere left
        ex.expand(np.sort(pick))
    return ex


def _freeze(ex: _Explorer, cutoff: FiniteStateStrategy, cap: int, deadline: float | None,
            sign: float) -> BeliefController | None:
    """The FSS of the pessimistic policy. Its belief nodes share memory nodes where their
    observations differ (:func:`_slots`); when they still need more than ``cap``, the
    latest-created expanded nodes are treated as frontier until they fit."""
    hand, m_of = ex.handover()
    node, z, _ = ex.arrays()
    everything = ex.choices()
    cb, ca, _, _, csucc = everything
    num_nodes = ex.num_nodes
    allowed = num_nodes
    while True:
        # the beliefs of the first ``allowed`` nodes may act, the others hand over
        index = np.flatnonzero((node[cb] < allowed) & (csucc < allowed))
        sub = tuple(a[index] for a in everything)
        V, choice = ex.solve(hand, sub, optimistic=False, deadline=deadline)
        reach = _reachable(num_nodes, node, choice, sub[4])
        slot = _slots(reach, node, z, ex.Zu, num_nodes)
        kb = int(slot.max()) + 1
        if kb <= cap or allowed <= 1:
            break
        allowed = max(1, int(allowed * 0.8))
    if kb > cap:
        return None
    kc = cutoff.memory_size
    K = kb + kc
    Zu, Au = ex.Zu, ex.Au
    action = np.zeros((K, Zu, Au))
    update = np.zeros((K, Zu, Au, K))
    action[kb:] = cutoff.action
    update[kb:, :, :, kb:] = cutoff.update
    # beliefs of kept nodes: their action, or the hand-over to the best cut-off node
    mine = np.flatnonzero((slot[node] >= 0) & (z >= 0))
    acts = mine[choice[mine] >= 0]
    c = index[choice[acts]]
    n_new, z_b, a_b = slot[node[acts]], z[acts], ca[c]
    action[n_new, z_b, a_b] = 1.0
    nxt = np.where(csucc[c] >= 0, slot[np.maximum(csucc[c], 0)], n_new)
    update[n_new, z_b, a_b, nxt] = 1.0
    hands = mine[choice[mine] < 0]
    m = m_of[hands]
    n_new, z_b = slot[node[hands]], z[hands]
    action[n_new, z_b] = cutoff.action[m, z_b]
    update[n_new, z_b, :, kb:] = cutoff.update[m, z_b]
    # (node, z) pairs no belief has (states that stop there, or other observations): the cut-off
    # strategy's initial node decides; the value never depends on it
    empty = action[:kb].sum(axis=2) == 0
    en, ez = np.nonzero(empty)
    m0 = cutoff.initial_memory
    action[en, ez] = cutoff.action[m0, ez]
    update[en, ez, :, kb:] = cutoff.update[m0, ez]
    fss = FiniteStateStrategy.from_arrays(
        player=cutoff.player, observables=cutoff.observables,
        observation_values=cutoff.observation_values, actions=cutoff.actions,
        action=action, update=update * (action[..., None] > 0), initial_memory=0,
    )
    init = ex.beliefs_of[0]
    w0 = ex.arrays()[2][init]
    return BeliefController(
        fss, sign * float(np.dot(w0, V[init])), sign * float(np.dot(w0, hand[init])), kb,
        num_nodes,
        int(np.sum(ex.expanded)), ex.num_beliefs,
    )


def _slots(reach: np.ndarray, node: np.ndarray, z: np.ndarray, Zu: int,
           num_nodes: int) -> np.ndarray:
    """int64[num_nodes]: the memory node of each reached belief node (-1: not reached). Nodes
    whose beliefs' observations are disjoint share a memory node (first fit, in creation order,
    node 0 first): in a state with observation z the memory node then names the one belief
    node with a belief on z, and an update to a shared memory node names its belief node for
    every observation the successor can show. The rules of distinct belief nodes never
    collide."""
    slot = np.full(num_nodes, -1, dtype=np.int64)
    reached = np.zeros(num_nodes, dtype=bool)
    reached[reach] = True
    mine = np.flatnonzero(reached[node] & (z >= 0))
    order = np.argsort(node[mine], kind="stable")
    bn, bz = node[mine][order], z[mine][order]
    starts = np.searchsorted(bn, reach)
    ends = np.searchsorted(bn, reach, side="right")
    used = np.zeros((0, Zu), dtype=bool)
    for n, lo, hi in zip(reach.tolist(), starts.tolist(), ends.tolist()):
        zs = bz[lo:hi]
        free = np.flatnonzero(~used[:, zs].any(axis=1)) if used.shape[0] else np.zeros(0, int)
        if free.size:
            k = int(free[0])
        else:
            k = used.shape[0]
            used = np.vstack([used, np.zeros((1, Zu), dtype=bool)])
        used[k, zs] = True
        slot[n] = k
    return slot


def can_reach(model: ExplicitModel, target: np.ndarray, remain: np.ndarray) -> np.ndarray:
    """bool[S]: the states from which some path through ``remain`` states reaches ``target``
    (the engines' positive reachability with every state choosing)."""
    S = model.num_states
    return positive_reach(structure_of(model), target, remain, existential=np.ones(S, dtype=bool))


def _reachable(n: int, node: np.ndarray, choice: np.ndarray, csucc: np.ndarray) -> np.ndarray:
    """The nodes (of ``n``) the policy ``choice`` (indices into choices whose successor nodes are
    ``csucc``) reaches from node 0."""
    acting = np.flatnonzero(choice >= 0)
    s = csucc[choice[acting]]
    go = s >= 0
    G = sp.csr_matrix((np.ones(int(go.sum())), (node[acting][go], s[go])), shape=(n, n))
    order = csgraph.breadth_first_order(G, 0, directed=True, return_predecessors=False)
    return np.sort(np.asarray(order, dtype=np.int64))


def applies(problem: Problem) -> bool:
    """Whether the belief phase applies: a POMDP (one player, no adversary)."""
    return problem.adversary is None and len(problem.model.player_names) <= 1


def belief_phase(problem: Problem, cutoff: FiniteStateStrategy,
                 deadline: float | None, *, explore: int = MAX_EXPLORED
                 ) -> BeliefController | None:
    """:func:`belief_controller` for ``problem`` (a POMDP) handing over to ``cutoff``: its cut-off
    values and the full-observation values computed here (policy iteration, floats)."""
    model = problem.model
    cut = cutoff_values(model, cutoff, problem.query, coalition_of=problem.coalition_of,
                        scalar=problem.scalar)
    checker = PropertyChecker(model, coalition_of=problem.coalition_of, scalar=problem.scalar,
                              options=_POLICY)
    upper = np.asarray(checker.query(problem.query, everywhere=True).values, dtype=np.float64)
    return belief_controller(
        model, player=problem.player, cutoff=cutoff, cut_values=cut, upper=upper,
        target=problem.target, remain=problem.remain, rewards=problem.rewards,
        discount=problem.discount, maximize=problem.maximize, deadline=deadline,
        explore=explore,
    )
