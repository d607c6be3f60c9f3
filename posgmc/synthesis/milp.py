"""The exact composition of a deterministic memoryless defence against a set of fixed adversary
strategies, as a mixed-integer linear program (ACJJKT19's orientation: the adversary's
finite-state strategies are given; scipy's HiGHS).

The defence is a binary d(z, a) per observation z of the decision maker and label a it offers,
exactly one per z (the defence plays a whenever it sees z; with full observation z is the state).
Against kept adversary j the product of the game with j's strategy is an MDP whose choices in
the decision maker's states are labelled: fixing d leaves one *active* row per state (a state
offers each label once, states of one observation offer the same labels, the adversary's states
have one row), i.e. a Markov chain C_j(d) with value V_j(d). "Open" states are those whose value
is not fixed (not a target, not a state that has left ``remain``). The MILP's optimum t* is

    opt over d of worst over j of V_j(d)      (max-min for a maximiser, min-max for a minimiser),

over *deterministic memoryless* defences only (randomised or finite-memory ones are the gradient
composition's: with a randomised defence the products' rows are products of unknowns, a bilinear
program, which no linear program captures). Four encodings, one per kind of objective:

**Least fixed point** (``Pmin``; discounted costs, either direction). Variables x_j(q) ∈ [lo, hi]
per product state, constraints for every row c of an open state q, with r the reward, g the
discount and U = a bound on |x - r - g P x| so that an inactive row constrains nothing:

    x_j(q) >= r(c) + g Σ_q' P_j(c, q') x_j(q') - U (1 - d(z(q), a(c)))       (minimiser)

and t >= x_j(init_j), minimise t. With d fixed, every solution is >= the least fixed point of
x = r + g P x, which is the chain's value (reachability included: a loop that never reaches gets
0), and the value itself is a solution, so t* is exact. For a discounted objective the fixed point
is unique, so the maximiser's form (``<=``, maximise t) is exact too; x ∈ [-R/(1-g), R/(1-g)].

**Maximised probability with ranking** (``Pmax``). The greatest solution of x <= P x counts an end
component that never reaches the target as reaching (x = 1 on it): the spurious solutions. Fix:
Z = the fixed-0 states (outside ``remain``, or from which no choice of the product MDP reaches the
target: ``positive_reach``), M = the states of the maximal end components of the product MDP
restricted to the open states (``end_components``). Every bottom SCC B of C_j(d) inside the open
states is closed under active rows, hence an end component, hence B ⊆ M. For q ∈ M: a binary p(q)
with x(q) <= p(q), a rank ρ(q) ∈ [0, 1] and, per entry (c, q') of a row c of q with q' ∉ Z, a
binary witness w(c, q'):

    w(c, q') <= d(z(q), a(c))          (the witness row is active; always so for the adversary's)
    w(c, q') <= p(q'),  ρ(q) >= ρ(q') + ε - (1 + ε)(1 - w(c, q'))    when q' ∈ M,   ε = 1/(|M|+1)
    p(q) <= Σ_(c, q') w(c, q')

*Soundness* (every feasible point has x_j <= V_j(d) for its d): on a B as above, p = 1 at q ∈ B
needs an active witness edge to q' ∈ B (B is closed) with ρ(q') < ρ(q): a strictly decreasing
infinite sequence in a finite set, impossible; so p = 0 = x on every such B. All other states of
C_j(d) outside T ∪ Z are transient, so x <= P x there (with x = 1 on T, 0 on Z and on the Bs)
gives (I - P_WW) x_W <= b_W, x_W <= (I - P_WW)^{-1} b_W = V_j(d) (the inverse is non-negative).
*Completeness* (the optimal d with x = V is feasible): p(q) = 1 iff q ∈ M has a path in C_j(d)
to T ∪ (open \\ M) avoiding Z (so V(q) > 0 implies p(q) = 1), ρ(q) = ε · the length of the
shortest such path (<= |M|), the witness its first edge. So t* = max_d min_j V_j(d) exactly.

**Minimised expected reward by flows** (``Rmin [F ψ]``, PRISM's semantics: infinite unless the
target is reached almost surely). Occupation measures λ_j(c) >= 0 per row of an open state:

    Σ_(c of q) λ_j(c) - Σ_c' P_j(c', q) λ_j(c') = [q = init_j]      every open q,
    λ_j(c) <= K d(z(q), a(c)),   t >= Σ_c r(c) λ_j(c),   minimise t.

With d fixed the equations have a non-negative solution iff C_j(d) reaches the target almost
surely from init (summing them over a closed set B of C_j(d) avoiding the target shows that no
flow enters B; on the transient states the solution is unique, the expected numbers of visits,
positive on every reachable state), and then Σ r λ_j = V_j(d): so an infinite value is excluded
*by construction*, no ranking needed. K must bound the expected visits of every active decision
row of an optimal d: with every reward of the decision maker's rows of open states >= r_min > 0,
visits(c) <= V_j(d*) / r_min <= t* / r_min <= ``bound`` / r_min for any ``bound`` >= t* (the
caller's incumbent value). So t* is exact whenever some deterministic defence's value is at most
``bound``; otherwise any solution found is still a true value of its defence. A zero reward on a
decision row leaves the visits unbounded: not offered.

**Maximised expected reward** (``Rmax [F ψ]``). Offered when no product has an end component
inside its open states (checked per product with ``end_components``): then every defence reaches
the target almost surely, (I - P) is invertible for every d, the greatest solution of
x <= r + P x is V_j(d) (the same non-negative-inverse argument), and hi = the largest proven upper
bound of the product MDP's full-information maximum (an engine solve), which bounds V_j(d) at
every state for every d. With an end component a defence may make the value infinite, and the
greatest solution capped at hi is then not exact: not offered.

The answer is a candidate: the caller evaluates its strategy against the kept adversaries (a
linear solve per product) and the reported numbers come from the sound engines
(:mod:`posgmc.synthesis.checker`), never from this float optimum.

**The incumbent's probe.** A caller that already holds a defence of value v against the kept
adversaries only wants a better one. Every defence's worst value is a feasible objective (the
encodings are exact), so when HiGHS's root node, with v as cutoff, proves that no solution does
better than v (less :data:`PROBE_MARGIN`), no branch-and-bound could have proposed a defence the
caller would take: :func:`compose_milp` then returns None at once. The cutoff's presolve,
propagation and cuts often settle this where the LP relaxation of the big-M rows (value 1 for a
probability) cannot; when they do not, the full solve runs exactly as without the probe.
"""

from __future__ import annotations

import enum
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy.optimize import Bounds as LinearBounds
from scipy.optimize import LinearConstraint, milp

from posgmc.engines.graph import end_components, positive_reach, row_of_entries, structure_of
from posgmc.engines.options import SolverOptions
from posgmc.engines.rewards import expected_reach_reward
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import bind
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.synthesis.parametric import Layout, Parametrisation
from posgmc.synthesis.problem import Problem
from posgmc.synthesis.solver_output import c_stdout_silenced

__all__ = ["MilpComposition", "Encoding", "encoding_of", "supported", "compose_milp"]


@dataclass(frozen=True, eq=False)
class MilpComposition:
    """The defence (memoryless, deterministic, laid out with ``memory`` nodes that all play the
    same and never change), its value against the worst of the adversaries (the MILP's optimum;
    floats, verified afterwards like every candidate) and whether HiGHS proved it optimal."""

    strategy: FiniteStateStrategy
    gamma: np.ndarray
    value: float
    optimal: bool


class Encoding(enum.Enum):
    """The encodings of the module docstring."""

    LEAST = "least fixed point"
    RANKING = "greatest fixed point with ranking"
    FLOWS = "occupation measures"
    GREATEST = "greatest fixed point without end components"


def encoding_of(problem: Problem) -> Encoding | None:
    """The encoding for ``problem``'s objective, or None when the MILP is not exact for it."""
    if problem.rewards is None:
        return Encoding.RANKING if problem.maximize else Encoding.LEAST
    if problem.discount < 1.0:
        return Encoding.LEAST
    if np.any(problem.rewards < 0):
        return None  # PRISM's R[F] with negative rewards: not encoded
    if problem.maximize:
        return Encoding.GREATEST
    model = problem.model
    decision = (model.state_players == problem.player)[model.choice_states] \
        & ~problem.target[model.choice_states]
    return Encoding.FLOWS if bool(np.all(problem.rewards[decision] > 0)) else None


def supported(problem: Problem) -> bool:
    """Whether the MILP is exact for this objective (:func:`encoding_of`): probabilities in both
    directions, discounted costs, ``Rmin [F ψ]`` with positive rewards on the decision maker's
    choices, and ``Rmax [F ψ]`` (where no product has an end component; checked when solving)."""
    return encoding_of(problem) is not None


@dataclass(frozen=True, eq=False)
class _Product:
    """The product with one adversary, in the MILP's terms. ``transitions`` csr [R, Q];
    ``row_state`` int64[R]; ``dcol`` int64[R]: the binary d that activates each row (-1: always
    active); ``reward`` float64[R]; ``target``/``zero`` bool[Q]: fixed to the target value / to
    0; ``init``: the initial product state."""

    transitions: sp.csr_matrix
    row_state: np.ndarray
    dcol: np.ndarray
    reward: np.ndarray
    target: np.ndarray
    zero: np.ndarray
    init: int
    probability: bool
    model: ExplicitModel = field(repr=False)
    owned: np.ndarray = field(repr=False)

    @property
    def num_states(self) -> int:
        return int(self.transitions.shape[1])

    @property
    def open(self) -> np.ndarray:
        out: np.ndarray = ~(self.target | self.zero)
        return out

    def end_component_states(self) -> np.ndarray:
        """bool[Q]: the states of the maximal end components inside the open states."""
        inside = self.open
        leaves = np.asarray(self.transitions @ (~inside).astype(np.float64)).ravel() > 0
        mec_of, _, _ = end_components(self.transitions, self.row_state,
                                      inside[self.row_state] & ~leaves)
        out: np.ndarray = mec_of >= 0
        return out


class _Program:
    """A mixed-integer linear program built block by block (columns, then sparse rows)."""

    def __init__(self) -> None:
        self.lower: list[np.ndarray] = []
        self.upper: list[np.ndarray] = []
        self.integer: list[np.ndarray] = []
        self.num_vars = 0
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.row_lo: list[np.ndarray] = []
        self.row_hi: list[np.ndarray] = []
        self.num_rows = 0

    def variables(self, count: int, lo: float | np.ndarray, hi: float | np.ndarray, *,
                  binary: bool = False) -> np.ndarray:
        """``count`` new columns; returns their indices."""
        self.lower.append(np.broadcast_to(np.asarray(lo, dtype=np.float64), (count,)).copy())
        self.upper.append(np.broadcast_to(np.asarray(hi, dtype=np.float64), (count,)).copy())
        self.integer.append(np.full(count, 1 if binary else 0, dtype=np.int64))
        idx = np.arange(self.num_vars, self.num_vars + count, dtype=np.int64)
        self.num_vars += count
        return idx

    def constrain(self, count: int, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray,
                  lo: float | np.ndarray, hi: float | np.ndarray) -> None:
        """``count`` new rows lo <= A x <= hi; entry i sits in new row ``rows[i]``."""
        self.rows.append(np.asarray(rows, dtype=np.int64) + self.num_rows)
        self.cols.append(np.asarray(cols, dtype=np.int64))
        self.vals.append(np.asarray(vals, dtype=np.float64))
        self.row_lo.append(np.broadcast_to(np.asarray(lo, dtype=np.float64), (count,)).copy())
        self.row_hi.append(np.broadcast_to(np.asarray(hi, dtype=np.float64), (count,)).copy())
        self.num_rows += count

    def solve(self, objective: int, sense: float, deadline: float | None,  # type: ignore[no-untyped-def]
              node_limit: int | None = None):
        """Optimise column ``objective`` (maximise for ``sense`` +1, minimise for -1), until
        ``deadline`` (a ``time.perf_counter()`` value) and within ``node_limit``
        branch-and-bound nodes; None when the deadline has passed before HiGHS could start.

        HiGHS (1.12, scipy's) reports "solve error" (status 4, no solution) when the optimum it
        found on its presolved program, feasible there within its tolerance, violates a row of
        the original program by a hair more than that tolerance after postsolve (seen with a
        least fixed point, whose rows are all tight at the optimum: t pushed one tolerance below
        x(init)). That says nothing about the program (HiGHS had found an optimum, within
        tolerance), so the solve is repeated without presolve, on the original rows,
        which are then the rows HiGHS's tolerance applied to (with a fresh ``node_limit``). A solve
        stopped by ``node_limit`` with an incumbent (scipy's same status 4) is returned as it is."""
        res = None
        for presolve in (True, False):
            # HiGHS stops within 1e-4 (relative) of the optimum by default: ask for the optimum
            options: dict[str, object] = {"disp": False, "mip_rel_gap": 1e-9,
                                          "presolve": presolve}
            if deadline is not None:
                left = deadline - time.perf_counter()
                if left <= 0:
                    return res
                options["time_limit"] = left
            if node_limit is not None:
                options["node_limit"] = node_limit
            res = self._highs(objective, sense, options)
            # scipy reports HiGHS's "solution limit reached" (the node budget ran out, with an
            # incumbent) under the same status: that is an answer, not an error
            if res.status != _SOLVE_ERROR or res.x is not None:
                return res
        return res

    def cannot_beat(self, objective: int, sense: float, incumbent: float,
                    deadline: float | None) -> bool:
        """Whether HiGHS proves, at the root node, that no solution has ``sense`` * column
        ``objective`` above ``sense * incumbent`` less a margin of :data:`PROBE_MARGIN`
        (relative): the root with the incumbent as cutoff (HiGHS's ``objective_bound``, which
        prunes every node that cannot do better), whose presolve, propagation and cuts often
        settle this where the LP relaxation of the big-M rows (1 for a probability) cannot.
        False whenever the probe is inconclusive (the root does not settle it, a solve error,
        the deadline): then the full solve must run."""
        if not np.isfinite(incumbent):
            return False
        margin = PROBE_MARGIN * (1.0 + abs(incumbent))
        options: dict[str, object] = {"disp": False, "presolve": True, "node_limit": 1,
                                      "objective_bound": -sense * incumbent + margin}
        if deadline is not None:
            left = deadline - time.perf_counter()
            if left <= 0:
                return False
            options["time_limit"] = left
        with warnings.catch_warnings():
            # scipy passes HiGHS options it does not know verbatim, with a warning saying so
            warnings.filterwarnings("ignore", message="Unrecognized options",
                                    category=RuntimeWarning)
            res = self._highs(objective, sense, options)
        if res.status == _INFEASIBLE:
            return True  # nothing beats the cutoff
        # "optimal" under a cutoff: the tree is exhausted; a solution it reports that does not
        # pass the cutoff (HiGHS then returns a feasible point of no interest) means none does
        return bool(res.status == _OPTIMAL and res.x is not None
                    and sense * float(res.x[objective]) <= sense * incumbent - margin)

    def _highs(self, objective: int, sense: float, options: dict[str, object]):  # type: ignore[no-untyped-def]
        """scipy's HiGHS on this program, optimising column ``objective`` in direction
        ``sense``."""
        cost = np.zeros(self.num_vars)
        cost[objective] = -sense
        matrix = sp.csr_matrix(
            (np.concatenate(self.vals), (np.concatenate(self.rows), np.concatenate(self.cols))),
            shape=(self.num_rows, self.num_vars),
        )
        with c_stdout_silenced():  # HiGHS's MIP prints a debug line to descriptor 1
            return milp(cost, integrality=np.concatenate(self.integer),
                        bounds=LinearBounds(np.concatenate(self.lower),
                                            np.concatenate(self.upper)),
                        constraints=LinearConstraint(matrix, np.concatenate(self.row_lo),
                                                     np.concatenate(self.row_hi)),
                        options=options)


_SOLVE_ERROR = 4  # scipy.optimize.milp's status for HiGHS's "solve error" (_Program.solve)
_OPTIMAL = 0  # scipy.optimize.milp's statuses for an optimum and for an infeasible program
_INFEASIBLE = 2

PROBE_MARGIN = 1e-5
"""Relative margin under the incumbent's value at which :meth:`_Program.cannot_beat` cuts off:
far above HiGHS's tolerances (1e-7 on rows whose big-M coefficients are about 3 for a
probability), so a defence that beats the incumbent is never pruned by rounding."""


def _product(problem: Problem, adversary: FiniteStateStrategy, par: Parametrisation,
             d_index: np.ndarray) -> _Product | None:
    """The product with ``adversary`` (None when a state no binary controls has several rows:
    then the active row is not determined by d)."""
    model = problem.model
    prod = strategy_product(model, [bind(model, adversary)])
    pm = prod.model
    s_of = prod.state_of
    rg = pm.row_groups
    row_state = pm.choice_states
    owned_state = (model.state_players == problem.player)[s_of]
    owned = owned_state[row_state]
    if np.any(np.diff(rg)[~owned_state] > 1):
        return None
    # the model choice of a decision maker's row: the same order within the state
    c_model = model.row_groups[s_of[row_state]] + (np.arange(pm.num_choices) - rg[row_state])
    z = par.obs_index[par.view.state_obs[s_of[row_state]]]
    a = par.act_index[model.choice_actions[np.where(owned, c_model, 0)]]
    dcol = np.where(owned, d_index[np.maximum(z, 0), np.maximum(a, 0)], -1)
    reward = (pm.reward_model(problem.query.reward).choice_rewards(rg)  # type: ignore[union-attr]
              if problem.rewards is not None else np.zeros(pm.num_choices))
    target = problem.target[s_of].copy()
    zero = np.zeros(pm.num_states, dtype=bool) if problem.rewards is not None \
        else ~problem.remain[s_of] & ~target
    return _Product(pm.transitions.tocsr(), row_state, dcol, reward, target, zero,
                    int(prod.initial_map[0]), problem.rewards is None, pm, owned_state)


def compose_milp(problem: Problem, adversaries: Sequence[FiniteStateStrategy], *, memory: int = 1,
                 deadline: float | None = None, bound: float | None = None,
                 nodes: int | None = None, incumbent: float | None = None,
                 ) -> MilpComposition | None:
    """The best deterministic memoryless defence against ``adversaries`` (module docstring).

    Args:
        problem: the synthesis problem; its objective must be :func:`supported`.
        adversaries: the kept adversary strategies (at least one).
        memory: the node count of the returned strategy (all nodes play the same).
        deadline: a ``time.perf_counter()`` value; HiGHS stops there (the wall-clock cap).
        nodes: branch-and-bound nodes at most (the work budget: where HiGHS stops does not
            depend on the machine); None: no limit.
        bound: for ``Rmin [F ψ]``: an upper bound on the optimum (an incumbent's value), needed
            for the flows' big-M; ignored otherwise.
        incumbent: the value against ``adversaries`` of the defence the caller has (None: none):
            when HiGHS's root node proves that no deterministic memoryless defence beats it
            (:meth:`_Program.cannot_beat`), None is returned without branching. Every defence's
            worst value over the products is a solution's objective (the encodings are exact),
            so the full solve could not have returned a better one either: the answer is the
            same, only the branch-and-bound is saved.

    Returns:
        The composition, or None when the objective is not supported, there is no adversary, a
        product has an end component (``Rmax``), no finite ``bound`` was given (``Rmin``), the
        program is infeasible (no defence of finite value within the bound) or HiGHS finds no
        solution before ``deadline``, or nothing can beat ``incumbent``.
    """
    encoding = encoding_of(problem)
    if not adversaries or encoding is None or problem.adversary is None:
        return None
    if encoding == Encoding.FLOWS and (bound is None or not np.isfinite(bound)):
        return None
    model = problem.model
    layout = Layout.of(model, problem.player)
    par = Parametrisation(model, problem.player, 1, problem.query, problem.target, problem.remain,
                          coalition_of=problem.coalition_of, scalar=problem.scalar, layout=layout)
    Zu, Au = layout.mask.shape
    offered = np.argwhere(layout.mask)
    d_index = np.full((Zu, Au), -1, dtype=np.int64)
    d_index[offered[:, 0], offered[:, 1]] = np.arange(len(offered))
    products = []
    for adversary in adversaries:
        found = _product(problem, adversary, par, d_index)
        if found is None:
            return None
        products.append(found)
    if encoding == Encoding.GREATEST and any(p.end_component_states().any() for p in products):
        return None
    prog = _Program()
    d = prog.variables(len(offered), 0.0, 1.0, binary=True)
    assert np.array_equal(d, np.arange(len(offered)))  # noqa: S101 - d comes first: d_index
    # one label per observation
    prog.constrain(Zu, offered[:, 0], d, np.ones(len(offered)), 1.0, 1.0)
    sign = problem.sign
    if encoding == Encoding.FLOWS:
        assert bound is not None  # noqa: S101 - checked above
        lo, hi = 0.0, float("inf")
    elif encoding == Encoding.GREATEST:
        lo, hi = 0.0, max(_reward_cap(problem, p) for p in products)
        if not np.isfinite(hi):
            return None
    elif problem.rewards is None:
        lo, hi = 0.0, 1.0
    else:
        rmax = float(np.max(np.abs(problem.rewards), initial=0.0))
        lo, hi = -rmax / (1.0 - problem.discount), rmax / (1.0 - problem.discount)
    t = int(prog.variables(1, lo, hi)[0])
    for p in products:
        if encoding == Encoding.FLOWS:
            _flows(prog, p, t, bound)  # type: ignore[arg-type]
            continue
        x = _bellman(prog, p, t, sign, problem.discount, lo, hi)
        if encoding == Encoding.RANKING:
            _ranking(prog, p, x)
    if incumbent is not None and prog.cannot_beat(t, sign, incumbent, deadline):
        return None
    res = prog.solve(t, sign, deadline, nodes)
    if res is None or res.x is None:
        return None
    chosen = np.round(res.x[d]) > 0.5
    gamma = np.zeros((memory, Zu, Au))
    gamma[:, offered[chosen, 0], offered[chosen, 1]] = 1.0
    delta = np.zeros((memory, Zu, Au, memory))
    delta[..., 0] = 1.0  # never leaves node 0
    fss = Parametrisation(model, problem.player, memory, problem.query, problem.target,
                          problem.remain, coalition_of=problem.coalition_of,
                          scalar=problem.scalar, layout=layout).strategy(gamma, delta)
    return MilpComposition(fss, gamma, float(res.x[t]), bool(res.status == 0))


def _bellman(prog: _Program, p: _Product, t: int, sign: float, discount: float, lo: float,
             hi: float) -> np.ndarray:
    """The value columns x(q) of one product, the Bellman inequalities of its open states' rows
    (``sign`` +1: x <= r + g P x, -1: x >= r + g P x; an inactive row relaxed by U) and the
    objective's row sign * t <= sign * x(init). Returns the columns."""
    Q = p.num_states
    fixed_value = p.target.astype(np.float64) if p.probability else np.zeros(Q)
    fixed = p.target | p.zero
    x = prog.variables(Q, np.where(fixed, fixed_value, lo), np.where(fixed, fixed_value, hi))
    rmax = float(np.max(np.abs(p.reward), initial=0.0))
    big = 2.0 * (hi - lo) + rmax + 1.0
    rows = np.flatnonzero(~fixed[p.row_state])
    sub = p.transitions[rows].tocoo()
    n = rows.size
    # sign*x(q) - sign*g*P x + U d <= sign*r + U  (U only on rows a binary controls)
    controlled = p.dcol[rows] >= 0
    r_idx = np.concatenate([np.arange(n), sub.row, np.flatnonzero(controlled)])
    c_idx = np.concatenate([x[p.row_state[rows]], x[sub.col], p.dcol[rows][controlled]])
    vals = np.concatenate([np.full(n, sign), -sign * discount * sub.data,
                           np.full(int(controlled.sum()), big)])
    prog.constrain(n, r_idx, c_idx, vals, -np.inf,
                   sign * p.reward[rows] + np.where(controlled, big, 0.0))
    # the objective: sign*t - sign*x(init) <= 0
    prog.constrain(1, np.zeros(2), np.array([t, x[p.init]]), np.array([sign, -sign]), -np.inf, 0.0)
    return x


def _ranking(prog: _Program, p: _Product, x: np.ndarray) -> None:
    """The ranking constraints of ``Pmax`` (module docstring) for one product with value
    columns ``x``: first the states that cannot reach the target at all are fixed to 0."""
    g = structure_of(p.model)
    reach = positive_reach(g, p.target, ~p.zero, existential=np.ones(p.num_states, dtype=bool))
    never = ~reach & ~p.target
    _set_upper(prog, x[never])
    p = replace(p, zero=p.zero | never)
    in_mec = p.end_component_states()
    M = np.flatnonzero(in_mec)
    if M.size == 0:
        return
    where = np.full(p.num_states, -1, dtype=np.int64)
    where[M] = np.arange(M.size)
    eps = 1.0 / (M.size + 1)
    flag = prog.variables(M.size, 0.0, 1.0, binary=True)  # p(q)
    rank = prog.variables(M.size, 0.0, 1.0)
    # x(q) - p(q) <= 0
    prog.constrain(M.size, np.r_[np.arange(M.size), np.arange(M.size)], np.r_[x[M], flag],
                   np.r_[np.ones(M.size), -np.ones(M.size)], -np.inf, 0.0)
    rows = np.flatnonzero(in_mec[p.row_state])
    sub = p.transitions[rows]
    e_row = rows[row_of_entries(sub)]
    e_dst = sub.indices.astype(np.int64)
    useful = ~p.zero[e_dst] & (sub.data > 0)
    e_row, e_dst = e_row[useful], e_dst[useful]
    E = e_row.size
    w = prog.variables(E, 0.0, 1.0, binary=True)
    e_src = where[p.row_state[e_row]]
    # p(q) - Σ w <= 0
    prog.constrain(M.size, np.r_[np.arange(M.size), e_src], np.r_[flag, w],
                   np.r_[np.ones(M.size), -np.ones(E)], -np.inf, 0.0)
    # w - d <= 0 on rows a binary controls
    ctrl = np.flatnonzero(p.dcol[e_row] >= 0)
    prog.constrain(ctrl.size, np.r_[np.arange(ctrl.size), np.arange(ctrl.size)],
                   np.r_[w[ctrl], p.dcol[e_row[ctrl]]],
                   np.r_[np.ones(ctrl.size), -np.ones(ctrl.size)], -np.inf, 0.0)
    # into M: w - p(q') <= 0 and rho(q) - rho(q') - (1 + eps) w >= -1
    inner = np.flatnonzero(in_mec[e_dst])
    k = inner.size
    dst = where[e_dst[inner]]
    prog.constrain(k, np.r_[np.arange(k), np.arange(k)], np.r_[w[inner], flag[dst]],
                   np.r_[np.ones(k), -np.ones(k)], -np.inf, 0.0)
    prog.constrain(k, np.r_[np.arange(k), np.arange(k), np.arange(k)],
                   np.r_[rank[e_src[inner]], rank[dst], w[inner]],
                   np.r_[np.ones(k), -np.ones(k), np.full(k, -(1.0 + eps))], -1.0, np.inf)


def _set_upper(prog: _Program, cols: np.ndarray) -> None:
    """Fix the columns ``cols`` (already created) to 0 from above."""
    start = 0
    for block in prog.upper:
        local = cols[(cols >= start) & (cols < start + block.size)] - start
        block[local] = 0.0
        start += block.size


def _flows(prog: _Program, p: _Product, t: int, bound: float) -> None:
    """The occupation-measure encoding of ``Rmin [F ψ]`` (module docstring) for one product."""
    inside = p.open
    rows = np.flatnonzero(inside[p.row_state])
    controlled = p.dcol[rows] >= 0
    r_min = float(np.min(p.reward[rows][controlled], initial=np.inf))
    if not r_min > 0:
        raise ValueError("Rmin flows need positive rewards on the decision maker's rows "
                         "(encoding_of checks it)")
    # big-M on visits, with room for the incumbent's rounding
    cap = (bound * (1.0 + 1e-6) + 1e-9) / r_min + 1.0
    # a row with an edge to a state that cannot reach the target is never active under a
    # defence of finite value: its flow is 0
    g = structure_of(p.model)
    reach = positive_reach(g, p.target, np.ones(p.num_states, dtype=bool),
                           existential=np.ones(p.num_states, dtype=bool))
    dead = np.asarray(p.transitions[rows] @ (~reach).astype(np.float64)).ravel() > 0
    lam = prog.variables(rows.size, 0.0, np.where(dead, 0.0, np.where(controlled, cap, np.inf)))
    # λ - cap d <= 0 on controlled rows
    ctl = np.flatnonzero(controlled & ~dead)
    prog.constrain(ctl.size, np.r_[np.arange(ctl.size), np.arange(ctl.size)],
                   np.r_[lam[ctl], p.dcol[rows[ctl]]],
                   np.r_[np.ones(ctl.size), np.full(ctl.size, -cap)], -np.inf, 0.0)
    # conservation at every open state: Σ out - Σ in = [q = init]
    states = np.flatnonzero(inside)
    where = np.full(p.num_states, -1, dtype=np.int64)
    where[states] = np.arange(states.size)
    sub = p.transitions[rows].tocoo()
    into = where[sub.col] >= 0
    rhs = np.zeros(states.size)
    if inside[p.init]:
        rhs[where[p.init]] = 1.0
    prog.constrain(states.size, np.r_[where[p.row_state[rows]], where[sub.col[into]]],
                   np.r_[lam, lam[sub.row[into]]],
                   np.r_[np.ones(rows.size), -sub.data[into]], rhs, rhs)
    # t - Σ r λ >= 0
    prog.constrain(1, np.zeros(rows.size + 1), np.r_[t, lam],
                   np.r_[1.0, -p.reward[rows]], 0.0, np.inf)


def _reward_cap(problem: Problem, p: _Product) -> float:
    """The largest proven upper bound of the decision maker's full-information maximum of the
    expected reward on the product (inf when some state's is infinite)."""
    r = expected_reach_reward(p.model, p.reward, p.target, maximize=p.owned,
                              options=SolverOptions())
    finite = ~p.target
    return float(np.max(r.upper[finite], initial=0.0))
