"""Randomised rules of the omniscient adversary that send the decision maker's posterior *exactly*
onto a belief the game's belief unfolding has already explored, in exact rational arithmetic.

Any rule the adversary may play, offered as one more choice at an adversary vertex of the
unfolding (:mod:`posgmc.synthesis.belief_grid`, resolution 0), keeps the abstraction's value an
upper bound on the game's optimum: restricting the minimising adversary to a subset of its
strategies can only raise the max-min. A randomised rule hides its choice from the decision
maker, and where its posterior is an explored belief exactly the unfolding closes there: no
new belief, no cut-off at the full-observation value and no decomposition into a lottery the
decision maker would learn from. That is what a guard needs against a runner that may shuttle
for ever between cells (PAYNT's dodge games): a family of beliefs the guard's randomised moves
map onto themselves, so that waiting buys the runner nothing.

For a fixed target belief t_g per observation group g of the successors the rule is a linear
feasibility problem in its probabilities π: Σ_c J[c, s] π_c = m_g t_g(s) for every successor
state s of the group (J the choices' successor mass weighted by the belief, m_g >= 0 the group's
mass), Σ_{c of a state} π_c = 1, π >= 0. HiGHS finds a float solution; its support fixes which
probabilities are free, and the same equations solved over the rationals (free variables the
simple fractions nearest the float ones) give the exact rule, kept only when it satisfies every
equation and bound exactly. Nothing here is trusted as a bound: whether the rule helps is for the
sound solve of the abstraction to say.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence
from fractions import Fraction

import numpy as np
from scipy.optimize import linprog

__all__ = ["Targets", "exact_target_rule", "target_rules", "TARGET_CAP"]

TARGET_CAP = 4
"""Rules landing on explored beliefs offered at one adversary vertex at most."""

CANDIDATES = 3
"""Target beliefs tried per observation group at most: the nearest compatible ancestor first
(the belief the decision maker held the last time it stood where it stands now), then beliefs
on the largest compatible supports (the most spread: a guard's slip only spreads a belief)."""

GROUP_MEMORY = 256
"""Explored beliefs remembered per support as targets (the first ones found, and the latest
of those)."""

VERTEX_BUDGET = 500
"""Adversary vertices of one unfolding whose target rules are looked for at most (the first in
breadth-first order: a closing family is found near the initial belief or not at all within
the unfolding's budget), so that the LPs cost a bounded share of it."""

_ANCESTORS = 64
"""Ancestors walked back at most when looking for a target."""

ExactBelief = dict[int, Fraction]
IntegerRow = Callable[[int], tuple[tuple[tuple[int, int], ...], int]]


class Targets:
    """The decision maker's explored exact beliefs, indexed by their support, and each vertex's
    origin (the vertex whose choice first reached it), mutable while unfolding."""

    def __init__(self) -> None:
        self.origin: list[int] = []
        self.group: list[int] = []
        self.left = VERTEX_BUDGET  # adversary vertices whose rules may still be looked for
        # per first (least) state of a support: each support seen and its vertices in order
        self.by_first: dict[int, dict[frozenset[int], list[int]]] = {}

    def found(self, vertex: int, origin: int, group: int, support: Iterable[int] | None) -> None:
        """Record the new ``vertex`` (numbered in order), reached first from ``origin`` (-1:
        the initial one); a decision maker's exact belief in ``group`` (< 0: the adversary's)
        on the states ``support`` (None: its belief is not exact) becomes a target."""
        while len(self.origin) <= vertex:
            self.origin.append(-1)
            self.group.append(-1)
        self.origin[vertex] = origin
        self.group[vertex] = group if support is not None else -1
        if group >= 0 and support is not None:
            states = frozenset(support)
            at = self.by_first.setdefault(min(states), {})
            known = at.setdefault(states, [])
            if len(known) < GROUP_MEMORY:
                known.append(vertex)

    def candidates(self, vertex: int, group: int, states: frozenset[int],
                   exact_of: Callable[[int], ExactBelief | None]) -> list[int]:
        """Explored beliefs of ``group`` whose support lies in ``states`` (the successors an
        adversary vertex's rules can reach there), at most :data:`CANDIDATES`: the nearest
        such ancestor of ``vertex``, then on the largest such supports the latest and the
        first belief explored."""
        out: list[int] = []
        u = self.origin[vertex] if vertex < len(self.origin) else -1
        for _ in range(_ANCESTORS):
            if u < 0:
                break
            if self.group[u] == group:
                b = exact_of(u)
                if b is not None and b.keys() <= states:
                    out.append(u)
                    break
            u = self.origin[u] if u < len(self.origin) else -1
        supports = [(support, known) for s in states
                    for support, known in self.by_first.get(s, {}).items() if support <= states]
        supports.sort(key=lambda x: -len(x[0]))
        for _, known in supports:
            for v in (known[-1], known[0]):
                if len(out) >= CANDIDATES:
                    return out
                if v not in out:
                    out.append(v)
        return out


def _exact_J(belief: ExactBelief, cols: Sequence[int], owner_state: Sequence[int],
             integer_row: IntegerRow, cont: np.ndarray) -> list[dict[int, Fraction]]:
    """Per choice, its exact continuing successor mass weighted by its state's belief."""
    out: list[dict[int, Fraction]] = []
    for c, s in zip(cols, owner_state):
        row, total = integer_row(c)
        m = belief[s]
        out.append({t: m * Fraction(n, total) for t, n in row if cont[t] and n})
    return out


def exact_target_rule(J: list[dict[int, Fraction]], owner: np.ndarray,
                      targets: list[tuple[list[int], ExactBelief]]) -> dict[int, Fraction] | None:
    """A randomised rule (local choice index -> exact probability, zeros left out) whose
    successor mass on each target group's states ``targets[g][0]`` is proportional to the exact
    belief ``targets[g][1]`` (states outside its support get none); None when there is none,
    it is deterministic, or its exact form fails a check."""
    k = len(J)
    n_states = int(owner.max()) + 1
    G = len(targets)
    eqs: list[list[Fraction]] = []  # coefficients over (π_0..π_k-1, m_0..m_G-1), right side
    rhs: list[Fraction] = []
    for g, (states, belief) in enumerate(targets):
        for s in states:
            row = [J[c].get(s, Fraction(0)) for c in range(k)] + [Fraction(0)] * G
            row[k + g] = -belief.get(s, Fraction(0))
            eqs.append(row)
            rhs.append(Fraction(0))
    for i in range(n_states):
        row = [Fraction(1) if owner[c] == i else Fraction(0) for c in range(k)] + \
            [Fraction(0)] * G
        eqs.append(row)
        rhs.append(Fraction(1))
    A = np.asarray([[float(x) for x in row] for row in eqs])
    b = np.asarray([float(x) for x in rhs])
    try:
        res = linprog(np.zeros(k + G), A_eq=A, b_eq=b, bounds=(0, None), method="highs")
    except ValueError:
        return None
    if res.status != 0 or res.x is None:
        return None
    x = np.asarray(res.x, dtype=np.float64)
    pi = x[:k]
    if np.all((pi < 1e-9) | (pi > 1 - 1e-9)):
        return None  # deterministic: already offered
    live = [j for j in range(k + G) if x[j] > 1e-12]
    sol = _solve_exactly(eqs, rhs, live, x)
    if sol is None:
        return None
    full = [Fraction(0)] * (k + G)
    for j, v in zip(live, sol):
        full[j] = v
    if any(v < 0 for v in full):
        return None
    for row, r in zip(eqs, rhs):
        if sum((a * v for a, v in zip(row, full) if a and v), Fraction(0)) != r:
            return None
    rule = {c: full[c] for c in range(k) if full[c]}
    if all(v == 1 for v in rule.values()):
        return None
    return rule


def _solve_exactly(eqs: list[list[Fraction]], rhs: list[Fraction], live: list[int],
                   x: np.ndarray) -> list[Fraction] | None:
    """The unknowns ``live`` (the others 0) solving the equations over the rationals: Gaussian
    elimination; unknowns left free (no pivot) take the simple fraction nearest their float
    value. None when inconsistent."""
    n = len(live)
    M = [[row[j] for j in live] + [r] for row, r in zip(eqs, rhs)]
    pivots: list[int] = []
    r = 0
    for col in range(n):
        p = next((i for i in range(r, len(M)) if M[i][col] != 0), None)
        if p is None:
            continue
        M[r], M[p] = M[p], M[r]
        inv = 1 / M[r][col]
        M[r] = [v * inv for v in M[r]]
        for i in range(len(M)):
            if i != r and M[i][col] != 0:
                f = M[i][col]
                M[i] = [a - f * b for a, b in zip(M[i], M[r])]
        pivots.append(col)
        r += 1
        if r == len(M):
            break
    if any(all(v == 0 for v in M[i][:n]) and M[i][n] != 0 for i in range(r, len(M))):
        return None
    values: list[Fraction] = [Fraction(0)] * n
    free = [j for j in range(n) if j not in pivots]
    for j in free:
        values[j] = Fraction(float(x[live[j]])).limit_denominator(1000)
    for i, col in enumerate(pivots):
        values[col] = M[i][n] - sum((M[i][j] * values[j] for j in free), Fraction(0))
    return values


def target_rules(vertex: int, belief: ExactBelief, cols: np.ndarray, owner: np.ndarray,
                 states: np.ndarray, integer_row: IntegerRow, cont: np.ndarray,
                 group: np.ndarray, targets: Targets,
                 exact_of: Callable[[int], ExactBelief | None],
                 near: Callable[[np.ndarray, np.ndarray], list[ExactBelief]] | None = None
                 ) -> list[dict[int, Fraction]]:
    """The adversary's rules at the unfolding's ``vertex`` (exact ``belief`` over ``states``;
    ``cols`` the global choices of its rules, ``owner[j]`` the index into ``states`` of choice
    j's state) whose posterior is an explored exact belief in every observation group of the
    successors that has a candidate (:meth:`Targets.candidates`): the groups' candidates
    combined in order, at most :data:`TARGET_CAP` rules. ``near(states, y)``: further target
    beliefs for a group, given its states and the uniform mixture's successor mass on them (the
    coarse grid's vertices around it: such a belief, once reached, is explored and becomes a
    target itself, so a guard that re-randomises onto it closes the unfolding). Each rule
    maps a global choice to its exact probability."""
    if targets.left <= 0:
        return []
    targets.left -= 1
    J = _exact_J(belief, cols.tolist(), states[owner].tolist(), integer_row, cont)
    succ = sorted(set().union(*J)) if J else []
    by_group: dict[int, list[int]] = {}
    for t in succ:
        by_group.setdefault(int(group[t]), []).append(t)
    options: list[list[tuple[list[int], ExactBelief]]] = []
    for g, members in sorted(by_group.items()):
        if len(members) < 2:
            continue  # a single state: its posterior is that state whatever the rule
        cand = targets.candidates(vertex, g, frozenset(members), exact_of)
        beliefs = [b for b in (exact_of(u) for u in cand) if b is not None]
        if near is not None:
            idx = np.asarray(members, dtype=np.int64)
            n = np.bincount(owner)
            y = np.asarray([float(sum((J[c].get(t, Fraction(0)) / int(n[owner[c]])
                                       for c in range(len(J))), Fraction(0))) for t in members])
            beliefs += [b for b in near(idx, y) if b not in beliefs]
        if beliefs:
            options.append([(members, b) for b in beliefs])
    out: list[dict[int, Fraction]] = []
    if not options:
        return out
    tried = 0
    for combo in itertools.product(*options):
        if len(out) >= TARGET_CAP or tried >= 2 * TARGET_CAP:
            break
        tried += 1
        rule = exact_target_rule(J, owner, list(combo))
        if rule is not None and rule not in out:
            out.append(rule)
    if not out and len(options) > 1:
        # no rule meets every group's target: each group's alone, the others free
        for opts in options:
            if len(out) >= TARGET_CAP:
                break
            rule = exact_target_rule(J, owner, [opts[0]])
            if rule is not None and rule not in out:
                out.append(rule)
    return [{int(cols[c]): p for c, p in rule.items()} for rule in out]
