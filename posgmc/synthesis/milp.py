"""The exact composition of a deterministic memoryless defence against a set of fixed adversary
strategies, as a mixed-integer linear program (ACJJKT19's orientation: the decision maker
observes the state, the adversary's finite-state strategies are given; scipy's HiGHS).

Variables: a binary d(z, a) per observation z of the decision maker and label a it offers
(exactly one per z: the defence plays a whenever it sees z; with full observation z is the
state), a value x_j(q) per state q = (s, m) of the product of the game with adversary j, and
the objective t. For a decision maker who minimises (``Pmin``, ``Rmin`` of a discounted cost):

    x_j(q) >= r(c) + g Σ_q' P_j(c, q') x_j(q') - U (1 - d(z(s), a(c)))   every choice c of s,
    x_j(q) >= r + g Σ_q' P_j(q, q') x_j(q')                              the adversary's states,
    t >= x_j(init_j) for every j,  minimise t,

with x fixed on the targets (1 for a probability, 0 for a cost) and 0 where a probability's
path leaves ``remain``; U bounds |x - r - g P x| so that an unchosen label constrains nothing.
With the labels fixed, the least solution of these inequalities is the chain's value (the
least fixed point of ``x = r + g P x``; reachability included), so the optimum is exactly
min over deterministic memoryless defences of max_j V_j. For a maximiser the inequalities turn
round (``<=``, maximise t), which is exact only when the fixed point is unique — a discounted
objective; a maximised probability (the greatest solution counts a loop as reaching) or an
undiscounted reward is not offered (:func:`supported`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import Bounds as LinearBounds
from scipy.optimize import LinearConstraint, milp

from posgmc.strategies.binding import bind
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.synthesis.jobs import Problem
from posgmc.synthesis.parametric import Layout, Parametrisation

__all__ = ["MilpComposition", "supported", "compose_milp"]


@dataclass(frozen=True, eq=False)
class MilpComposition:
    """The defence (memoryless, deterministic, laid out with ``memory`` nodes that all play the
    same and never change), its value against the worst of the adversaries (the MILP's optimum;
    floats, verified afterwards like every candidate) and whether HiGHS proved it optimal."""

    strategy: FiniteStateStrategy
    gamma: np.ndarray
    value: float
    optimal: bool


def supported(problem: Problem) -> bool:
    """Whether the MILP is exact for this objective: a minimised probability, or a discounted
    cost in either direction."""
    if problem.rewards is None:
        return not problem.maximize
    return problem.discount < 1.0


def compose_milp(problem: Problem, adversaries: Sequence[FiniteStateStrategy], *, memory: int = 1,
                 deadline: float | None = None) -> MilpComposition | None:
    """The best deterministic memoryless defence against ``adversaries`` (module docstring), or
    None when the objective is not :func:`supported`, there is no adversary, or HiGHS finds no
    solution before ``deadline`` (a ``time.perf_counter()`` value)."""
    if not adversaries or not supported(problem) or problem.adversary is None:
        return None
    model = problem.model
    layout = Layout.of(model, problem.player)
    par = Parametrisation(model, problem.player, 1, problem.query, problem.target, problem.remain,
                          coalition_of=problem.coalition_of, scalar=problem.scalar, layout=layout)
    Zu, Au = layout.mask.shape
    # the binaries d(z, a), one column per offered (z, a)
    offered = np.argwhere(layout.mask)
    d_index = np.full((Zu, Au), -1, dtype=np.int64)
    d_index[offered[:, 0], offered[:, 1]] = np.arange(len(offered))
    num_d = len(offered)
    sign = problem.sign
    gamma_disc = problem.discount
    if problem.rewards is None:
        reward = np.zeros(model.num_choices)
        lo, hi = 0.0, 1.0
    else:
        reward = problem.rewards
        rmax = float(np.max(np.abs(reward), initial=0.0))
        lo, hi = -rmax / (1.0 - gamma_disc), rmax / (1.0 - gamma_disc)
    big = (hi - lo) + float(np.max(np.abs(reward), initial=0.0)) + (hi - lo) + 1.0
    blocks: list[
        tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray]
    ] = []  # per j: A, b, d cols, x bounds
    sizes = []
    inits = []
    owned_model = model.state_players == problem.player
    for adversary in adversaries:
        prod = strategy_product(model, [bind(model, adversary)])
        pm = prod.model
        s_of = prod.state_of
        rg = pm.row_groups
        Q = pm.num_states
        row_state = pm.choice_states
        owned = owned_model[s_of[row_state]]
        # the model choice of a decision maker's row: the same order within the state
        c_model = model.row_groups[s_of[row_state]] + (np.arange(pm.num_choices) - rg[row_state])
        z = par.obs_index[par.view.state_obs[s_of[row_state]]]
        a = par.act_index[model.choice_actions[np.where(owned, c_model, 0)]]
        dcol = np.where(owned, d_index[np.maximum(z, 0), np.maximum(a, 0)], -1)
        prod_reward = (pm.reward_model(problem.query.reward).choice_rewards(rg)  # type: ignore[union-attr]
                       if problem.rewards is not None else np.zeros(pm.num_choices))
        tgt = problem.target[s_of]
        fixed = tgt.copy() if problem.rewards is not None else tgt | ~problem.remain[s_of]
        fixed_value = tgt.astype(np.float64) if problem.rewards is None else np.zeros(Q)
        keep = ~fixed[row_state]
        rows = np.flatnonzero(keep)
        # sign * (x(q) - g P x) - U (1 - d) <= sign * r  ->  sign*x - sign*g*P x + U d <= sign*r + U
        A = (
            sp.csr_matrix(
                (np.ones(rows.size), (np.arange(rows.size), row_state[rows])), shape=(rows.size, Q)
            )
            - gamma_disc * pm.transitions[rows]
        ) * sign
        b = sign * prod_reward[rows]
        blocks.append((A.tocsr(), b, dcol[rows], np.where(fixed, fixed_value, np.nan)))
        sizes.append(Q)
        inits.append(int(prod.initial_map[0]))
    offsets = num_d + np.concatenate([[0], np.cumsum(sizes)])
    num_vars = int(offsets[-1]) + 1  # ..., t
    t_col = num_vars - 1
    mats, lows, highs = [], [], []
    for j, (A, b, dcol, _fixed) in enumerate(blocks):
        n_rows = A.shape[0]
        coo = A.tocoo()
        parts_r = [coo.row]
        parts_c = [coo.col + offsets[j]]
        parts_v = [coo.data]
        chosen = dcol >= 0
        parts_r.append(np.flatnonzero(chosen))
        parts_c.append(dcol[chosen])
        parts_v.append(np.full(int(chosen.sum()), big))
        mats.append(
            sp.csr_matrix(
                (np.concatenate(parts_v), (np.concatenate(parts_r), np.concatenate(parts_c))),
                shape=(n_rows, num_vars),
            )
        )
        lows.append(np.full(n_rows, -np.inf))
        highs.append(b + np.where(chosen, big, 0.0))
        # the objective: sign * t <= sign * x_j(init)  ->  sign*t - sign*x <= 0
        row = sp.csr_matrix(
            ([sign, -sign], ([0, 0], [t_col, offsets[j] + inits[j]])), shape=(1, num_vars)
        )
        mats.append(row)
        lows.append(np.array([-np.inf]))
        highs.append(np.array([0.0]))
    # one label per observation
    pick = sp.csr_matrix((np.ones(num_d), (offered[:, 0], np.arange(num_d))), shape=(Zu, num_vars))
    mats.append(pick)
    lows.append(np.ones(Zu))
    highs.append(np.ones(Zu))
    lower = np.zeros(num_vars)
    upper = np.ones(num_vars)
    for j, (_, _, _, fixed_x) in enumerate(blocks):
        seg = slice(int(offsets[j]), int(offsets[j + 1]))
        lower[seg] = np.where(np.isnan(fixed_x), lo, fixed_x)
        upper[seg] = np.where(np.isnan(fixed_x), hi, fixed_x)
    lower[t_col], upper[t_col] = lo, hi
    cost = np.zeros(num_vars)
    cost[t_col] = -sign  # milp minimises: maximise sign * t
    integrality = np.zeros(num_vars)
    integrality[:num_d] = 1
    options: dict[str, object] = {"disp": False}
    if deadline is not None:
        left = deadline - time.perf_counter()
        if left <= 0:
            return None
        options["time_limit"] = left
    res = milp(cost, integrality=integrality, bounds=LinearBounds(lower, upper),
               constraints=LinearConstraint(sp.vstack(mats).tocsr(), np.concatenate(lows),
                                            np.concatenate(highs)), options=options)
    if res.x is None:
        return None
    d = np.round(res.x[:num_d]) > 0.5
    gamma = np.zeros((memory, Zu, Au))
    for (zz, aa), on in zip(offered.tolist(), d.tolist()):
        if on:
            gamma[:, zz, aa] = 1.0
    delta = np.zeros((memory, Zu, Au, memory))
    delta[..., 0] = 1.0  # never leaves node 0
    fss = Parametrisation(model, problem.player, memory, problem.query, problem.target,
                          problem.remain, coalition_of=problem.coalition_of,
                          scalar=problem.scalar, layout=layout).strategy(gamma, delta)
    return MilpComposition(fss, gamma, float(res.x[t_col]), bool(res.status == 0))
