"""Point-based backups of a finite-state strategy against an omniscient adversary: new memory
nodes, each chosen at a belief, whose value is known state by state.

Every memory node m of an FSS has a value vector α_m: α_m(s) is what the FSS guarantees from state
s with node m against an adversary that sees everything (the product's value at (s, m)). A new
node n plays, in each observation z of the decision maker, one action a_z and moves to one
existing node m_z; its vector is the one-step backup

    α_n(s) = r(s, a) + γ Σ_t P(s, a, t) W_m(t)   (a = a_z(s), m = m_z(s)),

where W_m(t) = α_m(t) in the decision maker's states, the target's value in stopping states, and
in the adversary's states the adversary's best choice, min over its choices (the adversary moves
until the decision maker moves again; sign-adjusted: the decision maker maximises). This is the
product's own Bellman equation at (s, n), so α_n is exact whenever the α_m are — no assumption
about the adversary's play and no belief update enters the number. A belief only *chooses* the
node: at a belief b, (a_z, m_z) maximise Σ_{s in z} b(s) (r + γ P W)(s, a, m), the point-based
backup of PBVI (Pineau, Gordon, Thrun, "Point-based value iteration", IJCAI 2003), read as a
policy graph (Hansen's policy iteration for POMDPs, 1998); in a one-sided game the adversary's
state-wise minimum is Horák, Bošanský and Pěchouček's backup ("Heuristic search value iteration
for one-sided partially observable stochastic games", AAAI 2017) restricted to a pure action of
the decision maker.

The nodes are added in rounds (the beliefs where the backup beats every node most first) until
none improves or the node budget is spent; the FSS is then ranked and checked by the sound
product check like every other candidate — the α here are floats.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.synthesis.belief import can_reach
from posgmc.synthesis.parametric import Layout
from posgmc.synthesis.problem import expired

__all__ = ["PolicyGraph", "backed_up"]

_ADVERSARY_SWEEPS = 10_000
"""Sweeps of the adversary's minimum at most, where its states follow each other."""

_TOLERANCE = 1e-13
"""The adversary's part has converged when no value moves by more than this in a sweep."""


_MARGIN = 1e-9
"""A backup must beat a belief's best node by this much (relative) to become a node."""


@dataclass(frozen=True, eq=False)
class PolicyGraph:
    """``strategy``: the FSS (the cut-off strategy's nodes first, then the new ones; its initial
    node the best at the initial belief); ``estimate``: the float value there; ``added``: new
    nodes; ``rounds``: backup rounds run."""

    strategy: FiniteStateStrategy
    estimate: float
    added: int
    rounds: int


class _Backups:
    """The model's arrays the backups read (signed: larger is better)."""

    def __init__(self, model: ExplicitModel, player: int, target: np.ndarray,
                 remain: np.ndarray, rewards: np.ndarray | None, discount: float,
                 sign: float) -> None:
        S = model.num_states
        self.S, self.discount, self.sign = S, discount, sign
        layout = Layout.of(model, player)
        view = player_view(model, player)
        self.mask = layout.mask
        self.Z, self.A = layout.mask.shape
        owned = (model.state_players == player) if model.player_names else np.ones(S, bool)
        if rewards is None:
            cont = remain & ~target & can_reach(model, target, remain)
            self.stop_value = np.where(target, sign * 1.0, 0.0)
        else:
            cont = ~target
            self.stop_value = np.zeros(S)
        self.cont = cont
        self.mine = np.flatnonzero(owned & cont)  # the decision maker's continuing states
        self.theirs = np.flatnonzero(~owned & cont)  # the adversary's
        obs_index = np.full(view.num_observations, -1, dtype=np.int64)
        obs_index[layout.used_obs] = np.arange(layout.used_obs.size)
        self.z_of = obs_index[view.state_obs[self.mine]]  # observation of each of mine
        act_index = np.full(len(model.action_names), -1, dtype=np.int64)
        act_index[layout.used_actions] = np.arange(layout.used_actions.size)
        cs = model.choice_states
        c_act = np.where(owned[cs], act_index[model.choice_actions], -1)
        where = np.full(S, -1, dtype=np.int64)
        where[self.mine] = np.arange(self.mine.size)
        r = np.zeros(model.num_choices) if rewards is None else sign * np.asarray(rewards)
        # per action: rows of my continuing states (local index), all columns
        self.P: list[sp.csr_matrix] = []
        self.r: list[np.ndarray] = []
        for a in range(self.A):
            c = np.flatnonzero((c_act == a) & (where[cs] >= 0))
            T = model.transitions[c].tocoo()
            self.P.append(sp.csr_matrix((T.data, (where[cs[c]][T.row], T.col)),
                                        shape=(self.mine.size, S)))
            ra = np.zeros(self.mine.size)
            ra[where[cs[c]]] = r[c]
            self.r.append(ra)
        # the adversary's choices: their transitions and rewards
        ac = np.flatnonzero(np.isin(cs, self.theirs))
        self.adv_choice_state = cs[ac]
        self.adv_T = sp.csr_matrix(model.transitions[ac])
        self.adv_r = r[ac]

    def extend(self, alpha: np.ndarray) -> np.ndarray:
        """W: float64[S, K] from α (float64[mine, K], -inf where unknown): α in my states, the
        stop value where the mass stops, the adversary's minimum in its states (-inf, the worst
        for the decision maker, where a choice may lead to an unknown value; mass the adversary
        keeps among its own states for ever is worth 0, as in the product). Columns are
        independent: new nodes' columns extend the old."""
        K = alpha.shape[1]
        W = np.repeat(self.stop_value[:, None], K, axis=1)
        W[self.mine] = alpha
        if not self.theirs.size:
            return W
        # value iteration of the adversary's part from 0 (nothing reached yet): its minimum
        # over the moves so far, until it no longer changes
        W[self.theirs] = 0.0
        for _ in range(_ADVERSARY_SWEEPS):
            Q = self.adv_r[:, None] + self.discount * _expect(self.adv_T, W)
            best = np.full((self.S, K), np.inf)
            np.minimum.at(best, self.adv_choice_state, Q)
            new = best[self.theirs]
            old = W[self.theirs]
            both = np.isfinite(new) & np.isfinite(old)
            W[self.theirs] = new
            if np.array_equal(np.isfinite(new), np.isfinite(old)) and \
                    np.abs(new[both] - old[both]).max(initial=0.0) <= _TOLERANCE:
                break
        return W

    def q(self, a: int, W: np.ndarray) -> np.ndarray:
        """float64[mine, K]: taking action a in each of my states, then node m's values."""
        out: np.ndarray = self.r[a][:, None] + self.discount * _expect(self.P[a], W)
        return out

    def q_at(self, a: int, rows: np.ndarray, nodes: np.ndarray, W: np.ndarray) -> np.ndarray:
        """float64[rows]: action a in my states ``rows`` (local), then node ``nodes[i]``."""
        P = self.P[a][rows]
        owner = np.repeat(np.arange(rows.size), np.diff(P.indptr))
        w = W[P.indices, nodes[owner]]
        terms = np.where(P.data > 0, P.data * np.where(P.data > 0, w, 0.0), 0.0)
        out: np.ndarray = self.r[a][rows] + self.discount * np.bincount(
            owner, weights=terms, minlength=rows.size)
        return out


def backed_up(model: ExplicitModel, *, player: int, cutoff: FiniteStateStrategy,
              cut_values: np.ndarray, beliefs: sp.csr_matrix, target: np.ndarray,
              remain: np.ndarray, rewards: np.ndarray | None, discount: float,
              maximize: bool, max_nodes: int, deadline: float | None,
              per_round: int = 16) -> PolicyGraph | None:
    """``cutoff`` with up to ``max_nodes`` new nodes backed up at ``beliefs`` (rows over the
    states: :func:`posgmc.synthesis.belief.belief_points`); its initial node the best from the
    initial state.

    ``cut_values``: float64[S, k], ``cutoff``'s value from (s, m) against the omniscient
    adversary (NaN where unknown: such a node is never a successor there); ``per_round``: nodes
    added per round at most. None when the layout does not match or nothing is added."""
    sign = 1.0 if maximize else -1.0
    layout = Layout.of(model, player)
    view = player_view(model, player)
    if (cutoff.actions != tuple(model.action_names[a] for a in layout.used_actions)
            or not np.array_equal(cutoff.observation_values, view.obs_values[layout.used_obs])):
        return None
    bk = _Backups(model, player, target, remain, rewards, discount, sign)
    alpha = sign * np.asarray(cut_values, dtype=np.float64)[bk.mine]
    alpha = np.where(np.isnan(alpha), -np.inf, alpha)
    B = sp.csr_matrix(beliefs)[:, bk.mine]
    # (belief, observation) pairs: a belief's mass on each observation's states
    Bz = B.tocoo()
    pair_key = Bz.row.astype(np.int64) * bk.Z + bk.z_of[Bz.col]
    keys, inv = np.unique(pair_key, return_inverse=True)
    pair_rows = sp.csr_matrix((Bz.data, (inv, Bz.col)), shape=(keys.size, bk.mine.size))
    pair_belief, pair_z = keys // bk.Z, keys % bk.Z
    # the observations no belief weighs: every state of theirs alike
    counts = np.bincount(bk.z_of, minlength=bk.Z).astype(np.float64)
    uniform = sp.csr_matrix((1.0 / counts[bk.z_of], (bk.z_of, np.arange(bk.mine.size))),
                            shape=(bk.Z, bk.mine.size))
    nb = B.shape[0]
    kc = alpha.shape[1]
    # running bests over every (action, node) so far: the values of old nodes never change
    best_pair = np.full(keys.size, -np.inf)
    arg_pair = np.zeros((keys.size, 2), dtype=np.int64)
    best_uni = np.full(bk.Z, -np.inf)
    arg_uni = np.zeros((bk.Z, 2), dtype=np.int64)
    current = np.full(nb, -np.inf)
    W = np.zeros((model.num_states, 0))
    fresh = alpha  # the columns not yet backed up through
    new_action: list[np.ndarray] = []  # per new node: int64[Z] action, int64[Z] successor
    new_next: list[np.ndarray] = []
    seen: set[bytes] = set()
    rounds = 0
    while not expired(deadline):
        first = W.shape[1]
        W = np.concatenate([W, bk.extend(fresh)], axis=1)
        current = np.maximum(current, np.asarray(B @ fresh).max(axis=1))
        if len(new_action) >= max_nodes:
            break
        rounds += 1
        Wf = W[:, first:]
        for a in range(bk.A):
            Q = bk.q(a, Wf)
            V = np.asarray(pair_rows @ Q)
            m = V.argmax(axis=1)
            v = V[np.arange(keys.size), m]
            better = bk.mask[pair_z, a] & (v > best_pair)
            best_pair[better] = v[better]
            arg_pair[better, 0], arg_pair[better, 1] = a, first + m[better]
            # the default rule's ranking: unknown values as a very bad finite one, so that every
            # observation gets an allowed action
            U = np.asarray(uniform @ np.where(np.isfinite(Q), Q, -1e300))
            mu = U.argmax(axis=1)
            u = U[np.arange(bk.Z), mu]
            ub = bk.mask[:, a] & (u > best_uni)
            best_uni[ub] = u[ub]
            arg_uni[ub, 0], arg_uni[ub, 1] = a, first + mu[ub]
        # a pair where nothing is known plays as the observation's default does
        lost = ~np.isfinite(best_pair)
        arg_pair[lost] = arg_uni[pair_z[lost]]
        # each belief's backup value against its current best node's
        backup = np.bincount(pair_belief, weights=best_pair, minlength=nb)
        gain = backup - current
        margin = _MARGIN * np.maximum(1.0, np.abs(current))
        order = np.lexsort((np.arange(nb), -gain))
        pick = order[gain[order] > margin[order]][:min(per_round, max_nodes - len(new_action))]
        # the new nodes' rules and vectors (a rule set already a node is not added again)
        cols: list[np.ndarray] = []
        for b in pick.tolist():
            act, nxt = arg_uni[:, 0].copy(), arg_uni[:, 1].copy()
            mine_pairs = np.flatnonzero(pair_belief == b)
            act[pair_z[mine_pairs]] = arg_pair[mine_pairs, 0]
            nxt[pair_z[mine_pairs]] = arg_pair[mine_pairs, 1]
            key = act.tobytes() + nxt.tobytes()
            if key in seen:
                continue
            seen.add(key)
            new_action.append(act)
            new_next.append(nxt)
            za = act[bk.z_of]
            col = np.empty(bk.mine.size)
            for a in np.unique(za).tolist():
                rows = np.flatnonzero(za == a)
                col[rows] = bk.q_at(a, rows, nxt[bk.z_of[rows]], W)
            cols.append(col)
        if not cols:
            break
        fresh = np.stack(cols, axis=1)
    if not new_action:
        return None
    # the initial node: the best from the initial state itself (the adversary's minimum there
    # when it moves first), not from the first belief, which assumed its rule
    values0 = W[int(model.initial_states[0])]
    initial = int(values0.argmax()) if np.isfinite(values0).any() else cutoff.initial_memory
    fss = _fss(cutoff, kc, new_action, new_next, bk.mask, initial)
    return PolicyGraph(fss, sign * float(values0[initial]), len(new_action), rounds)


def _expect(P: sp.csr_matrix, W: np.ndarray) -> np.ndarray:
    """P @ W where W may hold infinities: -inf wherever a successor with positive probability
    is -inf (unknown, the worst), else +inf wherever one is +inf (not yet known), else the
    finite expectation (no 0 * inf)."""
    out = np.asarray(P @ np.where(np.isfinite(W), W, 0.0))
    pos = np.asarray(P @ np.isposinf(W).astype(np.float64)) > 0
    neg = np.asarray(P @ np.isneginf(W).astype(np.float64)) > 0
    out = np.where(pos, np.inf, out)
    return np.where(neg, -np.inf, out)


def _fss(cutoff: FiniteStateStrategy, kc: int, actions: list[np.ndarray],
         nexts: list[np.ndarray], mask: np.ndarray, initial: int) -> FiniteStateStrategy:
    """The cut-off strategy's rules, then one deterministic rule per observation of each new
    node (kc, kc + 1, ...), as sparse entries."""
    Z = mask.shape[0]
    # the cut-off strategy's rules, entries and updates
    nr = cutoff.rule_memory.size
    ne = cutoff.choice_action.size
    entry_rule = np.repeat(np.arange(nr), np.diff(cutoff.choice_start))
    update_entry = np.repeat(np.arange(ne), np.diff(cutoff.update_start))
    n_new = len(actions)
    A = np.stack(actions)  # [n_new, Z]
    N = np.stack(nexts)
    nodes = kc + np.repeat(np.arange(n_new), Z)
    zs = np.tile(np.arange(Z), n_new)
    ok = mask[zs, A.ravel()]
    nodes, zs, acts, succ = nodes[ok], zs[ok], A.ravel()[ok], N.ravel()[ok]
    rid = nr + np.arange(nodes.size)
    eid = ne + np.arange(nodes.size)
    return FiniteStateStrategy.from_entries(
        player=cutoff.player, memory_size=kc + n_new, initial_memory=initial,
        observables=cutoff.observables, observation_values=cutoff.observation_values,
        actions=cutoff.actions,
        rule_memory=np.concatenate([cutoff.rule_memory, nodes]),
        rule_observation=np.concatenate([cutoff.rule_observation, zs]),
        entry_rule=np.concatenate([entry_rule, rid]),
        entry_action=np.concatenate([cutoff.choice_action, acts]),
        entry_probability=np.concatenate([cutoff.choice_probability, np.ones(nodes.size)]),
        update_entry=np.concatenate([update_entry, eid]),
        update_node=np.concatenate([cutoff.update_node, succ]),
        update_probability=np.concatenate([cutoff.update_probability, np.ones(nodes.size)]),
        boolean=cutoff.boolean,
    )
