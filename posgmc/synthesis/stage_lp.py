"""The omniscient adversary's randomised stage strategy at a belief of a one-sided game, by a
linear program over a solved grid abstraction (Horák, Bošanský, Pěchouček: "Heuristic search
value iteration for one-sided partially observable stochastic games", AAAI 2017, Section 5, and
the journal version, arXiv 2010.11243, where the upper bound's stage game is the same LP).

At a vertex of the game abstraction (:mod:`posgmc.synthesis.belief_grid`) whose support is the
adversary's states, the adversary picks a decision rule π (a distribution over each state's
choices). A *randomised* rule hides the choice from the decision maker: the next belief is the
mixture's posterior, not one rule's. What the rule is worth is the value of the posteriors; with
the solved abstraction's values W_i at its vertices b_i (and the per-state bounds at the unit
beliefs), the lower convex envelope of the points (b_i, W_i) estimates it, and choosing π
against that envelope is a linear program in (π, μ):

    minimise   Σ_c π_c p(s_c) (stop_c + r_c) + γ Σ_i μ_i W_i
    subject to Σ_i μ_i b_i(s') = Σ_c π_c p(s_c) T(c, s')    for every successor state s'
               Σ_{c of s} π_c = 1 for every s of the support,  π >= 0, μ >= 0

(stop_c the target mass, worth 1 for a probability and 0 for a reward, r_c the choice's reward,
γ the discount; maximise when the adversary maximises). The LP's optimum is *not* trusted as a
bound: its float value, and the envelope, only choose which rule to offer the adversary. The
rule is added to the abstraction's choices at that vertex, and the abstraction is solved again
by the sound engines; any rule the adversary may play keeps the abstraction's value a bound on
the game's (restricting the minimiser can only raise the max-min), so the bound stays proven
whatever the LP returns.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

__all__ = ["StageData", "OneStep", "stage_rule", "one_step_rule", "grid_rule", "MAX_POINTS"]

MAX_POINTS = 4_000
"""Abstraction vertices offered to one LP at most (the nearest are not chosen: the first found;
the unit beliefs are always offered, so the LP is feasible)."""


@dataclass(frozen=True, eq=False)
class StageData:
    """What every stage LP of one abstraction shares: ``T_cont`` csr float64[choices, S] the
    continuing successor mass of each choice, ``T_stop`` float64[choices] its target mass;
    ``beliefs`` csr float64[vertices, S] the abstraction's vertices, ``values`` float64[vertices]
    their solved values; ``unit`` float64[S] a value per single-state belief (inf: unknown);
    ``minimise``: whether the adversary minimises; ``reward`` float64[choices] each choice's
    reward, ``stop_value`` what reaching the target is worth (1 for a probability, 0 for a
    reward), ``discount`` the factor on the successors' values (1: none)."""

    T_cont: sp.csr_matrix
    T_stop: np.ndarray
    beliefs: sp.csr_matrix
    values: np.ndarray
    unit: np.ndarray
    minimise: bool
    reward: np.ndarray
    stop_value: float
    discount: float

    @staticmethod
    def of(T_cont: sp.csr_matrix, T_stop: np.ndarray, beliefs: sp.csr_matrix,
           values: np.ndarray, unit: np.ndarray, minimise: bool, *,
           reward: np.ndarray | None = None, stop_value: float = 1.0,
           discount: float = 1.0) -> StageData:
        T = sp.csr_matrix(T_cont)
        r = np.zeros(T.shape[0]) if reward is None else np.asarray(reward, dtype=np.float64)
        return StageData(T, np.asarray(T_stop, dtype=np.float64), sp.csr_matrix(beliefs),
                         np.asarray(values, dtype=np.float64), np.asarray(unit, dtype=np.float64),
                         minimise, r, float(stop_value), float(discount))

    def now(self, cols: np.ndarray, mass: np.ndarray) -> np.ndarray:
        """float64[cols.size]: what each choice is worth in this step (its reward and its
        target mass), weighted by its state's belief mass."""
        out: np.ndarray = mass * (self.stop_value * self.T_stop[cols] + self.reward[cols])
        return out


def stage_rule(data: StageData, states: np.ndarray, p: np.ndarray, cols: np.ndarray,
               owner: np.ndarray) -> np.ndarray | None:
    """The adversary's LP-optimal randomised rule at the belief ``p`` over ``states``: float64
    [cols.size], a probability per choice ``cols`` (global choice ids; ``owner[j]`` is the index
    into ``states`` of choice j's state), summing to 1 over each state's choices. None when the
    LP fails or its rule is deterministic (the abstraction already offers every such rule it
    can)."""
    k = cols.size
    mass = p[owner]
    J = sp.csr_matrix(sp.diags(mass) @ data.T_cont[cols])  # each choice's weighted successors
    succ = np.unique(J.indices)
    if not succ.size:
        return None
    inside = np.zeros(data.T_cont.shape[1], dtype=bool)
    inside[succ] = True
    # the vertices whose support lies in the successors' states (each lies in one group)
    B = data.beliefs
    outside = np.asarray(B @ (~inside).astype(np.float64)).ravel()
    cand = np.flatnonzero((outside == 0) & np.isfinite(data.values[:B.shape[0]]))[:MAX_POINTS]
    unit_ok = np.isfinite(data.unit[succ])
    if not unit_ok.all():
        return None  # a successor state without a bound: the LP would be unbounded
    pos = np.full(inside.size, -1, dtype=np.int64)
    pos[succ] = np.arange(succ.size)
    Bc = B[cand].tocoo()
    n_pts = cand.size + succ.size
    # equality rows: one per successor state; columns: π (k), then the points
    pi_part = J[:, succ].T.tocoo()
    rows = np.r_[pi_part.row, pos[Bc.col], np.arange(succ.size)]
    colz = np.r_[pi_part.col, k + Bc.row, k + cand.size + np.arange(succ.size)]
    vals = np.r_[-pi_part.data, Bc.data, np.ones(succ.size)]
    A_eq = sp.csr_matrix((vals, (rows, colz)), shape=(succ.size, k + n_pts))
    n_states = states.size
    A_rule = sp.csr_matrix((np.ones(k), (owner, np.arange(k))), shape=(n_states, k + n_pts))
    A = sp.vstack([A_eq, A_rule], format="csr")
    b = np.r_[np.zeros(succ.size), np.ones(n_states)]
    cost = np.r_[data.now(cols, mass),
                 data.discount * np.r_[data.values[cand], data.unit[succ]]]
    if not data.minimise:
        cost = -cost
    try:
        res = linprog(cost, A_eq=A, b_eq=b, bounds=(0, None), method="highs")
    except ValueError:
        return None
    if res.status != 0 or res.x is None:
        return None
    return _rule(np.asarray(res.x[:k], dtype=np.float64), owner, n_states)

@dataclass(frozen=True, eq=False)
class OneStep:
    """The one-step estimate of a successor belief's value (the QMDP bound of Littman, Cassandra,
    Kaelbling, ICML 1995, for the decision maker): at the decision maker's states of observation
    group z it commits to one action a and then sees everything, Σ_s β(s) Q[a, s]; at the
    adversary's states (group ``Z``) Σ_s β(s) ``value[s]``. Convex piecewise linear in β (a
    maximum of linear functions; a minimum when the decision maker minimises), so the
    adversary's best rule against it is a linear program too. ``Q`` float64[actions, S] (the
    target mass plus the full-observation value of the successors), ``mask`` bool[Z, actions]
    the actions of each group, ``group`` int64[S]."""

    Q: np.ndarray
    mask: np.ndarray
    group: np.ndarray
    value: np.ndarray
    Z: int


def one_step_rule(data: StageData, step: OneStep, p: np.ndarray, cols: np.ndarray,
                  owner: np.ndarray) -> np.ndarray | None:
    """The adversary's randomised rule that is best against the :class:`OneStep` estimate of
    the posteriors (a rule that keeps the decision maker guessing where its next action
    matters); the same form and contract as :func:`stage_rule`."""
    k = cols.size
    n_states = int(owner.max()) + 1
    mass = p[owner]
    J = sp.csr_matrix(sp.diags(mass) @ data.T_cont[cols])
    succ = np.unique(J.indices)
    if not succ.size or not np.isfinite(step.Q[:, succ]).all() or \
            not np.isfinite(step.value[succ]).all():
        return None
    g = step.group[succ]
    theirs = (g >= step.Z) | (g < 0)  # the adversary's, or states where nobody chooses
    groups = np.unique(g[~theirs])
    Js = J[:, succ].toarray()  # [k, successors]: small (one belief's choices)
    # linear part: target mass now, and the adversary's successors at their value
    linear = data.now(cols, mass) + data.discount * (Js[:, theirs] @ step.value[succ[theirs]])
    sign = 1.0 if data.minimise else -1.0
    cost = np.r_[sign * linear, sign * np.ones(groups.size)]
    rows: list[np.ndarray] = []
    for j, z in enumerate(groups.tolist()):
        at = g == z
        for a in np.flatnonzero(step.mask[z]).tolist():
            row = np.zeros(k + groups.size)
            row[:k] = data.discount * (Js[:, at] @ step.Q[a, succ[at]])
            row[k + j] = -1.0
            rows.append(sign * row)  # minimise: piece <= t; maximise: piece >= t
    A_ub = np.stack(rows) if rows else None
    b_ub = np.zeros(len(rows)) if rows else None
    A_eq = np.zeros((n_states, k + groups.size))
    A_eq[owner, np.arange(k)] = 1.0
    bounds = [(0.0, None)] * k + [(None, None)] * groups.size
    try:
        res = linprog(cost, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=np.ones(n_states),
                      bounds=bounds, method="highs")
    except ValueError:
        return None
    if res.status != 0 or res.x is None:
        return None
    return _rule(np.asarray(res.x[:k], dtype=np.float64), owner, n_states)


def grid_rule(J: sp.csr_matrix, owner: np.ndarray, targets: list[tuple[np.ndarray, np.ndarray]]
              ) -> np.ndarray | None:
    """A randomised rule of the adversary whose posterior is exactly on the grid: float64
    [J.shape[0]] (the same form as :func:`stage_rule`), or None when none exists or it is
    deterministic. ``J`` csr float64[choices, S]: each choice's continuing successors weighted
    by its state's belief mass; ``owner[j]``: the index of choice j's state; ``targets``: per
    observation group of the successors, (int64 state ids, float64 belief on them), and the rule
    must put the group's mass on the states in exactly those proportions (any total mass).

    A successor belief that is a grid vertex itself is not decomposed, so the decision maker
    learns nothing from the abstraction that it would not learn in the game: an adversary that
    keeps the decision maker guessing (a guard that re-randomises its lane after every peek)
    needs such rules, or every decomposition hands the decision maker a little information, and
    a decision maker that may wait collects it all. Found by a feasibility LP (HiGHS); whether
    the rule helps is for the sound solve of the abstraction to say."""
    k = J.shape[0]
    n_states = int(owner.max()) + 1
    Jd = J.tocsc()
    rows: list[np.ndarray] = []
    for g, (states, belief) in enumerate(targets):
        # Σ_c J[c, s] π_c - t_g belief(s) = 0 for every state s of the group
        block = np.zeros((states.size, k + len(targets)))
        block[:, :k] = Jd[:, states].toarray().T
        block[:, k + g] = -belief
        rows.append(block)
    A_rule = np.zeros((n_states, k + len(targets)))
    A_rule[owner, np.arange(k)] = 1.0
    A = np.vstack(rows + [A_rule])
    b = np.r_[np.zeros(A.shape[0] - n_states), np.ones(n_states)]
    try:
        res = linprog(np.zeros(A.shape[1]), A_eq=A, b_eq=b, bounds=(0, None), method="highs")
    except ValueError:
        return None
    if res.status != 0 or res.x is None:
        return None
    rule = _rule(np.asarray(res.x[:k], dtype=np.float64), owner, n_states)
    if rule is None:
        return None
    # HiGHS meets the equations to its tolerance (~1e-9), which would leave the posterior just
    # off the vertex (decomposed, a tiny leak, and a decision maker that may wait collects every
    # leak); the nearest simple fractions usually meet them exactly in floating point
    for denominator in (8, 64, 1000):
        simple = np.asarray([float(Fraction(x).limit_denominator(denominator)) for x in rule])
        total = np.bincount(owner, weights=simple, minlength=n_states)
        if (total <= 0).any():
            continue
        exact: np.ndarray = simple / total[owner]
        if _on_target(np.asarray(J.T @ exact).ravel(), targets):
            return exact
    return rule


def _on_target(y: np.ndarray, targets: list[tuple[np.ndarray, np.ndarray]]) -> bool:
    """Whether the successor mass ``y`` (float64[S]) is, group by group, proportional to the
    target beliefs up to float noise (well inside the grid's snapping of near-integer
    coordinates, so that the posterior is taken as the vertex itself)."""
    for states, belief in targets:
        part = y[states]
        mass = part.sum()
        if mass > 0 and np.abs(part / mass - belief).max() > 1e-14:
            return False
    return True


def _rule(x: np.ndarray, owner: np.ndarray, n_states: int) -> np.ndarray | None:
    """The LP's π cleaned into a rule (per state a distribution), None when deterministic."""
    pi = np.clip(x, 0.0, None)
    total = np.bincount(owner, weights=pi, minlength=n_states)
    if (total <= 0).any():
        return None
    pi = pi / total[owner]
    if np.all((pi < 1e-9) | (pi > 1 - 1e-9)):
        return None
    pi[pi < 1e-9] = 0.0
    out: np.ndarray = pi / np.bincount(owner, weights=pi, minlength=n_states)[owner]
    return out
