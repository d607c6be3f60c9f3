"""The decision maker's one-step dynamics for a belief-based controller: per action, where the
probability mass goes until the decision maker moves again, what stops on the way and what it
earns.

On a POMDP that is the model's transitions themselves. On a turn-based game against one
omniscient adversary the decision maker's belief would also depend on the adversary's moves,
which it does not see; the controller *assumes* a stage rule for them — a randomised choice per
adversary state, ``rule`` (e.g. the full-observation optimum's choice, or the uniform mixture) —
and composes it into the dynamics: from an adversary state the mass follows the rule until it
reaches a decision-maker state (or stops). The assumption only shapes the controller; what it
guarantees is the sound product check of the resulting FSS against *every* adversary, like any
other candidate's (:mod:`posgmc.synthesis.search`). The idea of the adversary's stage rule at a
belief is Horák, Bošanský, Pěchouček's one-sided POSG value iteration ("Heuristic search value
iteration for one-sided partially observable stochastic games", AAAI 2017).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import player_view
from posgmc.synthesis.parametric import Layout

__all__ = ["StageDynamics", "stage_dynamics", "uniform_rule", "deterministic_rule"]

_STAGE_STEPS = 10_000
"""Adversary moves in a row followed at most before the decision maker's next move."""

_NEGLIGIBLE = 1e-14
"""Probabilities below this, left after several adversary moves in a row, are dropped."""


@dataclass(frozen=True, eq=False)
class StageDynamics:
    """Per used action a of the decision maker (the :class:`Layout` order): ``P[a]`` S x S, the
    mass moved from a decision-maker state to the *continuing* decision-maker states where it
    acts next; ``stop[a]`` float64[S], the signed value of the mass that stops (reaches the
    target) on the way; ``reward[a]`` float64[S], the signed reward earned on the way (the
    adversary's part discounted once more than the action's own). ``obs``: int64[S], the
    decision maker's observation index of its states (-1 elsewhere); ``initial``:
    float64[S], the distribution over the decision maker's first states (empty mass: none)."""

    P: tuple[sp.csr_matrix, ...]
    stop: tuple[np.ndarray, ...]
    reward: tuple[np.ndarray, ...]
    obs: np.ndarray
    initial: np.ndarray


def uniform_rule(model: ExplicitModel, adversary: int) -> np.ndarray:
    """float64[C]: the adversary choosing uniformly among its choices in each of its states (0 on
    the other choices)."""
    counts = np.diff(model.row_groups)
    owned = model.state_players == adversary
    return np.where(owned[model.choice_states], 1.0 / counts[model.choice_states], 0.0)


def deterministic_rule(model: ExplicitModel, adversary: int, choice: np.ndarray) -> np.ndarray:
    """float64[C]: the adversary playing ``choice`` (int64[S], a global choice per state, -1 or
    out of range: the state's first choice) in each of its states."""
    rg = model.row_groups
    S = model.num_states
    lo, hi = rg[:S], rg[1:S + 1]
    pick = np.where((choice >= lo) & (choice < hi), choice, lo)
    owned = np.flatnonzero(model.state_players == adversary)
    out = np.zeros(model.num_choices)
    out[pick[owned]] = 1.0
    return out


def stage_dynamics(model: ExplicitModel, player: int, *, cont: np.ndarray, gain: np.ndarray,
                   rewards: np.ndarray | None, discount: float, sign: float,
                   rule: np.ndarray | None) -> StageDynamics:
    """The dynamics of ``player`` (the decision maker) with the other states' choices made by
    ``rule`` (float64[C]; None on a POMDP, where every state is the player's).

    ``cont``: bool[S], the states whose mass continues; ``gain``: float64[S], the signed value of
    mass that stops in each state; ``rewards``: float64[C] per choice (None: none);
    ``discount``: per step; ``sign``: +1 maximising, -1 minimising. Adversary states from which
    the rule never leads back to the decision maker or to a stop keep their mass nowhere (it is
    worth nothing here: only a ranking, the product check has the real value)."""
    S = model.num_states
    layout = Layout.of(model, player)
    view = player_view(model, player)
    owned = (model.state_players == player) if model.player_names else np.ones(S, dtype=bool)
    obs_index = np.full(view.num_observations, -1, dtype=np.int64)
    obs_index[layout.used_obs] = np.arange(layout.used_obs.size)
    act_index = np.full(len(model.action_names), -1, dtype=np.int64)
    act_index[layout.used_actions] = np.arange(layout.used_actions.size)
    cs = model.choice_states
    c_act = np.where(owned[cs], act_index[model.choice_actions], -1)
    mine = cont & owned
    obs = np.where(owned, obs_index[view.state_obs], -1)
    keep = sp.diags(cont.astype(np.float64))
    # the adversary's part: X maps an adversary state to the decision-maker states where its
    # mass arrives (continuing), R its signed value on the way (stops and rewards)
    others = np.flatnonzero(cont & ~owned) if rule is not None else np.zeros(0, np.int64)
    X = sp.csr_matrix((S, S))
    R = np.zeros(S)
    if others.size and rule is not None:
        X, R = _adversary_stage(model, rule, others, mine, cont, gain, rewards, discount, sign)
    P: list[sp.csr_matrix] = []
    stop: list[np.ndarray] = []
    reward: list[np.ndarray] = []
    to_mine = sp.diags(mine.astype(np.float64))
    for a in range(layout.used_actions.size):
        c = np.flatnonzero(c_act == a)
        T = model.transitions[c].tocoo()
        Pa = sp.csr_matrix((T.data, (cs[c][T.row], T.col)), shape=(S, S))
        r = np.zeros(S)
        if rewards is not None:
            r[cs[c]] = sign * rewards[c]
        if others.size:
            # continuing mass lands on the decision maker's states directly or through the
            # adversary's stage (discounted once more per adversary step, in X and R)
            P.append(sp.csr_matrix(Pa @ to_mine + Pa @ X))
            stop.append(np.asarray(Pa @ gain).ravel() + discount * np.asarray(Pa @ R).ravel())
        else:
            P.append(sp.csr_matrix(Pa @ keep))
            stop.append(np.asarray(Pa @ gain).ravel())
        reward.append(r)
    s0 = int(model.initial_states[0])
    initial = np.zeros(S)
    if mine[s0]:
        initial[s0] = 1.0
    elif others.size and cont[s0]:
        initial = np.asarray(X[s0].todense()).ravel()
    return StageDynamics(tuple(P), tuple(stop), tuple(reward), obs, initial)


def _adversary_stage(model: ExplicitModel, rule: np.ndarray, others: np.ndarray,
                     mine: np.ndarray, cont: np.ndarray, gain: np.ndarray,
                     rewards: np.ndarray | None, discount: float, sign: float
                     ) -> tuple[sp.csr_matrix, np.ndarray]:
    """(X S x S, R float64[S]) for the adversary states ``others`` following ``rule``:
    X[t, u] the discounted probability that the mass in t reaches the decision-maker state u
    first, R[t] the signed value collected before (stops, the adversary's rewards)."""
    S = model.num_states
    cs = model.choice_states
    W = sp.csr_matrix((rule, (cs, np.arange(model.num_choices))), shape=(S, model.num_choices))
    T = sp.csr_matrix(W @ model.transitions)  # the rule's transitions, per state
    r = np.zeros(S) if rewards is None else \
        np.bincount(cs, weights=rule * sign * rewards, minlength=S)
    outside = np.ones(S, dtype=bool)
    outside[others] = False
    To = T[others]
    inner = sp.csr_matrix(To[:, others])
    # adversary states from which the rule leaves the adversary's part (else: mass lost)
    leaves = np.asarray(To[:, np.flatnonzero(outside)].sum(axis=1)).ravel() > 0
    keep = np.flatnonzero(_reaches(inner, leaves))
    X = sp.csr_matrix((S, S))
    R = np.zeros(S)
    if not keep.size:
        return X, R
    sub = sp.csr_matrix(discount * inner[keep][:, keep])
    rows = To[keep]
    # X = sum_k sub^k B and R = sum_k sub^k v (the mass that stays among the adversary's states
    # shrinks geometrically once every kept state leaves with positive probability): summed
    # until what is left is negligible, exactly on the usual acyclic adversary stage
    step = sp.csr_matrix(discount * (rows @ sp.diags(mine.astype(np.float64))))
    vstep = r[others[keep]] + np.asarray(rows @ gain).ravel()
    Xk = step.copy()
    Rk = vstep.copy()
    for _ in range(_STAGE_STEPS):
        if not sub.nnz:
            break
        step = sp.csr_matrix(sub @ step)
        step.data[np.abs(step.data) < _NEGLIGIBLE] = 0.0
        step.eliminate_zeros()
        vstep = sub @ vstep
        Xk = Xk + step
        Rk = Rk + vstep
        if not step.nnz and np.abs(vstep).max(initial=0.0) < _NEGLIGIBLE:
            break
    states = others[keep]
    coo = sp.csr_matrix(Xk).tocoo()
    X = sp.csr_matrix((coo.data, (states[coo.row], coo.col)), shape=(S, S))
    R[states] = Rk
    return X, R


def _reaches(inner: sp.csr_matrix, leaves: np.ndarray) -> np.ndarray:
    """bool[n]: the adversary states from which some path through ``inner`` reaches a state in
    ``leaves``."""
    n = leaves.size
    if not leaves.any():
        return np.zeros(n, dtype=bool)
    # backwards search from the leaving states over the reversed graph
    G = sp.csr_matrix(inner.T)
    G = sp.vstack([sp.hstack([G, sp.csr_matrix((n, 1))]),
                   sp.csr_matrix((np.ones(int(leaves.sum())),
                                  (np.zeros(int(leaves.sum()), dtype=np.int64),
                                   np.flatnonzero(leaves))), shape=(1, n + 1))]).tocsr()
    order = csgraph.breadth_first_order(G, n, directed=True, return_predecessors=False)
    out = np.zeros(n + 1, dtype=bool)
    out[order] = True
    return out[:n]
