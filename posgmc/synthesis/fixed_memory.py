"""Randomised action maps over a fixed deterministic memory: the decision maker's FSS whose memory
update δ is given (one next node per rule and action) and whose action map γ is searched by
gradient ascent on what it guarantees against the omniscient adversary.

A :class:`MemoryFrame` lists the rules (n, z) the memory can reach and, for each, the actions z
offers and the node each one moves to. Its FSSs are the distributions γ(n, z) over those actions,
parametrised by logits θ (a softmax per rule); every γ with full support has the same product
(:func:`~posgmc.strategies.product.strategy_product`), so the product is built once, and its
transition data is linear in γ:

    P((s, n), (s', n')) = Σ_a γ(n, z(s), a) T(c_a(s), s') [n' = δ(n, z(s), a)]

(``fixed + A @ γ``, A sparse). Evaluation at γ is Danskin's, as in
:mod:`posgmc.synthesis.parametric`: the adversary's best response on the product by policy
iteration, the induced chain's values x by one sparse LU and its adjoint y for the initial
state, and ``∂ value / ∂ γ_e = Σ_entries A[entry, e] · y(row) · x(column)``; the softmax's chain
rule gives the logits' gradient, and Adam (:func:`posgmc.synthesis.ascent.ascend`) climbs it.

Why randomise over a fixed memory: against an omniscient adversary a deterministic defence is
predictable — the adversary knows the next move and covers it — and a small memory cannot keep
track of what the defender has seen. A memory that tracks enough (the belief support,
:mod:`posgmc.synthesis.belief_support`) with a randomised γ can keep the adversary guessing,
which no deterministic FSS of any memory can. The values here are floats that only rank; the
FSS is reported only after the sound product check against every adversary.

Probability objectives only (``P[a U b]``, ``F b``): the product's action rewards are mixtures
by γ, which the refilled product does not carry.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from posgmc.checking.property_checker import CheckOptions, PropertyChecker
from posgmc.engines.graph import concat_ranges, row_of_entries
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import bind, player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import StrategyProduct, strategy_product
from posgmc.synthesis.ascent import LOGIT, ascend
from posgmc.synthesis.parametric import chain_reach
from posgmc.synthesis.problem import Problem

__all__ = ["MemoryFrame", "FrameParametrisation", "FrameAscent", "ascend_frame",
           "ITERATIONS", "LEARNING_RATE"]

ITERATIONS = 300
"""Adam steps of one ascent (fewer when the deadline passes)."""

LEARNING_RATE = 0.3
"""Adam's step size on the logits (which stay in [-LOGIT, LOGIT])."""


@dataclass(frozen=True, eq=False)
class MemoryFrame:
    """A deterministic memory for the decision maker: ``memory_size`` nodes, ``initial`` node;
    rules R (``rule_node``, ``rule_obs``: int64[R], the node and the model observation id of the
    player's view, sorted by (node, observation), no pair twice); entries E (``entry_rule``:
    int64[E] nondecreasing, ``entry_action``: int64[E] the model action id, increasing within a
    rule, ``entry_next``: int64[E] the node the action moves to)."""

    memory_size: int
    initial: int
    rule_node: np.ndarray
    rule_obs: np.ndarray
    entry_rule: np.ndarray
    entry_action: np.ndarray
    entry_next: np.ndarray

    @property
    def num_entries(self) -> int:
        return int(self.entry_rule.size)

    def strategy(self, model: ExplicitModel, player: int,
                 probability: np.ndarray) -> FiniteStateStrategy:
        """The FSS playing entry e with ``probability[e]`` (float64[E], a distribution per rule;
        entries of probability 0 are dropped)."""
        view = player_view(model, player)
        E = self.num_entries
        return FiniteStateStrategy.from_entries(
            player=view.name, memory_size=self.memory_size, initial_memory=self.initial,
            observables=view.observables, observation_values=view.obs_values,
            actions=tuple(model.action_names),
            rule_memory=self.rule_node, rule_observation=self.rule_obs,
            entry_rule=self.entry_rule, entry_action=self.entry_action,
            entry_probability=probability,
            update_entry=np.arange(E), update_node=self.entry_next,
            update_probability=np.ones(E))


def _softmax(theta: np.ndarray, starts: np.ndarray, of_entry: np.ndarray) -> np.ndarray:
    """The softmax of ``theta`` within each rule (entries ``starts[r]:starts[r + 1]``)."""
    top = np.maximum.reduceat(theta, starts[:-1])[of_entry]
    w = np.exp(theta - top)
    out: np.ndarray = w / np.add.reduceat(w, starts[:-1])[of_entry]
    return out


class FrameParametrisation:
    """The FSSs of one frame as logits θ[E], their value against the omniscient adversary's best
    response and its gradient (see the module docstring).

    Raises:
        ValueError: ``problem`` has an action reward objective (probabilities only).
    """

    def __init__(self, problem: Problem, frame: MemoryFrame) -> None:
        if problem.rewards is not None:
            raise ValueError("a memory frame is searched for probability objectives only")
        self.problem, self.frame = problem, frame
        rule_starts = np.searchsorted(frame.entry_rule, np.arange(frame.rule_node.size + 1))
        self.starts = rule_starts.astype(np.int64)
        self.of_entry = frame.entry_rule
        uniform = 1.0 / np.diff(self.starts)[frame.entry_rule]
        prod = strategy_product(problem.model,
                                [bind(problem.model, frame.strategy(problem.model,
                                                                    problem.player, uniform))])
        self.product = prod
        self.coefficients, self.fixed, self.entry_choices = _coefficients(problem, frame, prod)
        # the product state of each stored entry's row (the decision maker's states have one
        # row each; the adversary's entries carry no coefficient)
        pm = prod.model
        state_of_row = np.repeat(np.arange(pm.num_states), np.diff(pm.row_groups))
        self.entry_rows = state_of_row[row_of_entries(pm.transitions)]
        self._response: np.ndarray | None = None

    def cautious_start(self, values: np.ndarray) -> np.ndarray:
        """Logits from per-state values (float64[S], e.g. the full-observation optimum): each
        entry scored by its choice's worst one-step backup over the states its rule is played
        in, the best entry of each rule at 0 and the others lower in proportion, down to
        -LOGIT for a loss of half the values' range."""
        model, sign = self.problem.model, self.problem.sign
        finite = np.where(np.isfinite(values), values, 0.0)
        span = float(finite.max(initial=0.0) - finite.min(initial=0.0))
        q = sign * np.asarray(model.transitions @ finite).ravel()  # per model choice
        e, c = self.entry_choices
        worst = np.full(self.frame.num_entries, np.inf)
        np.minimum.at(worst, e, q[c])
        worst = np.where(np.isfinite(worst), worst, 0.0)
        best = np.maximum.reduceat(worst, self.starts[:-1])[self.of_entry]
        if span <= 0:
            return np.zeros(self.frame.num_entries)
        out: np.ndarray = np.clip(2.0 * LOGIT * (worst - best) / span, -LOGIT, 0.0)
        return out

    def probabilities(self, theta: np.ndarray) -> np.ndarray:
        return _softmax(theta, self.starts, self.of_entry)

    def refill(self, gamma: np.ndarray) -> StrategyProduct:
        """The product with the FSS ``gamma`` (full support: the template's structure)."""
        pm = self.product.model
        T = pm.transitions
        data = self.fixed + self.coefficients @ gamma
        transitions = sp.csr_matrix((data, T.indices, T.indptr), shape=T.shape)
        transitions.has_sorted_indices = True
        return dataclasses.replace(self.product, model=dataclasses.replace(
            pm, transitions=transitions, reward_models=()))

    def evaluate(self, gamma: np.ndarray) -> tuple[float, np.ndarray]:
        """The initial value of the FSS ``gamma`` against the adversary's best response, and its
        gradient in γ (float64[E])."""
        problem = self.problem
        prod = self.refill(gamma)
        pm = prod.model
        strategy = None
        if pm.transitions.shape[0] > pm.num_states:  # the adversary still chooses
            solver = SolverOptions(method=Method.POLICY, initial_strategy=self._response,
                                   prove=False)
            checker = PropertyChecker(pm, coalition_of=problem.coalition_of,
                                      scalar=problem.scalar,
                                      options=CheckOptions(solver=solver, keep_strategy=True))
            q = checker.query(problem.query)
            strategy = q.engine.strategy if q.engine is not None else None
            self._response = strategy
        rows = pm.row_groups[:-1].copy()
        if strategy is not None:
            rows = np.where(strategy >= 0, strategy, rows)
        chain = pm.transitions[rows].tocsr()
        tgt = problem.target[prod.state_of]
        rem = problem.remain[prod.state_of]
        unknown = chain_reach(chain, tgt, rem) & ~tgt
        x = tgt.astype(np.float64)
        init = int(prod.initial_map[0])
        grad = np.zeros(self.frame.num_entries)
        U = np.flatnonzero(unknown)
        if not unknown[init]:
            return float(x[init]), grad
        rows_u = chain[U]
        PUU = rows_u[:, U].tocsc()
        b = np.asarray(rows_u[:, np.flatnonzero(tgt)].sum(axis=1)).ravel()
        lu = splu((sp.identity(U.size, format="csc") - PUU).tocsc())
        x[U] = lu.solve(b)
        e = np.zeros(U.size)
        e[np.searchsorted(U, init)] = 1.0
        y = np.zeros(pm.num_states)
        y[U] = lu.solve(e, trans="T")
        T = pm.transitions
        w = y[self.entry_rows] * x[T.indices]
        grad = np.asarray(self.coefficients.T @ w).ravel()
        return float(x[init]), grad


def _coefficients(problem: Problem, frame: MemoryFrame, prod: StrategyProduct
                  ) -> tuple[sp.csr_matrix, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """A csr float64[nnz, E] and fixed float64[nnz]: the product's transition data of the FSS
    γ is ``fixed + A @ γ`` (the decision maker's entries are 0 in ``fixed``); and the pairs
    (entry e, model choice c) of the decision maker's product states: e is played in a product
    state (s, n) by choosing c in s (int64[M] each)."""
    model, player = problem.model, problem.player
    view = player_view(model, player)
    owned = (model.state_players == player) if model.player_names \
        else np.ones(model.num_states, dtype=bool)
    pm = prod.model
    P = pm.num_states
    k = frame.memory_size
    T = model.transitions
    nodes = prod.memory_of[:, 0]
    keys = prod.state_of * k + nodes
    key_order = np.argsort(keys)
    sorted_keys = keys[key_order]
    # the entries e of each decision-maker product state's rule
    mine = np.flatnonzero(owned[prod.state_of])
    s, n = prod.state_of[mine], nodes[mine]
    rule_keys = frame.rule_node * (int(view.obs_values.shape[0]) + 1) + frame.rule_obs
    asked = n * (int(view.obs_values.shape[0]) + 1) + view.state_obs[s]
    r = np.searchsorted(rule_keys, asked)
    starts = np.searchsorted(frame.entry_rule, np.arange(frame.rule_node.size + 1))
    counts = starts[r + 1] - starts[r]
    e = concat_ranges(starts[r], starts[r + 1])
    p_of_e = np.repeat(mine, counts)
    # the choice of each state with each action label
    A = len(model.action_names)
    choice_keys = model.choice_states * A + model.choice_actions
    c_order = np.argsort(choice_keys, kind="stable")
    c_at = np.searchsorted(choice_keys[c_order], prod.state_of[p_of_e] * A
                           + frame.entry_action[e])
    c = c_order[c_at]
    # every transition of those choices
    t_counts = np.diff(T.indptr)[c]
    t = concat_ranges(T.indptr[c], T.indptr[c + 1])
    of_t = np.repeat(np.arange(c.size), t_counts)
    e_t, p_t = e[of_t], p_of_e[of_t]
    dest = key_order[np.searchsorted(sorted_keys, T.indices[t] * k + frame.entry_next[e_t])]
    row = pm.row_groups[p_t]
    Tp = pm.transitions
    stored = row_of_entries(Tp).astype(np.int64) * P + Tp.indices
    pos = np.searchsorted(stored, row * P + dest)
    coefficients = sp.csr_matrix((T.data[t], (pos, e_t)), shape=(Tp.nnz, frame.num_entries))
    ours = np.repeat(owned[prod.state_of], np.diff(pm.row_groups))[row_of_entries(Tp)]
    fixed = np.where(ours, 0.0, Tp.data)
    return coefficients, fixed, (e, c)


@dataclass(frozen=True, eq=False)
class FrameAscent:
    """What an ascent over a frame found: ``strategy`` (the best iterate's FSS), ``value`` (its
    float value by the evaluation, a ranking), ``evaluations``."""

    strategy: FiniteStateStrategy
    value: float
    evaluations: int


def ascend_frame(problem: Problem, frame: MemoryFrame, *, start: np.ndarray | None = None,
                 iterations: int = ITERATIONS, deadline: float | None = None) -> FrameAscent:
    """Adam over the logits of ``frame``'s action maps for ``iterations`` steps or until
    ``deadline``; the best iterate. ``start``: per-state values (float64[S], e.g. the
    full-observation optimum) for :meth:`FrameParametrisation.cautious_start`; None: the
    uniform γ."""
    par = FrameParametrisation(problem, frame)
    sign = problem.sign

    def step(theta: np.ndarray, _unused: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        gamma = par.probabilities(theta)
        value, grad = par.evaluate(gamma)
        g = sign * grad
        logits = gamma * (g - np.add.reduceat(gamma * g, par.starts[:-1])[par.of_entry])
        return sign * value, logits, _unused

    theta0 = np.zeros(frame.num_entries) if start is None else par.cautious_start(start)
    (theta, _), best, n = ascend(step, theta0, np.zeros(0), iterations=iterations,
                                 learning_rate=LEARNING_RATE, deadline=deadline)
    gamma = par.probabilities(theta)
    return FrameAscent(frame.strategy(problem.model, problem.player, gamma), sign * best, n)
