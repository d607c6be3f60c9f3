"""The adversary's deterministic memoryless strategies, enumerated with a SAT solver, and what
they say about a defence (the one-sided approach of ACJJKT19, "The partially observable games we
play for cyber deception").

Encoding: one Boolean variable per (observation, offered label) for the observations of the
adversary's states reachable in the model, exactly one label per observation. After each solution
the strategy is applied (:mod:`posgmc.strategies.product`, the decision maker left free) and only
the observations the adversary actually meets under it are blocked, so strategies that agree
wherever they matter come once. The enumeration is *exhaustive* when the solver runs out of
models. With memory (k□ > 1) the update δ(n, z) is enumerated too (see
:func:`enumerate_adversaries`).

With the enumerated adversaries A and a defence σ:

* ``vs_fss_adversary`` = min over A of the value of (σ, a) — exact over all deterministic
  memoryless adversaries when the enumeration was exhaustive;
* ``upper_bound`` = min over A of the decision maker's full-information optimum against a (an
  MDP solve on the product): no defence whatsoever does better against the adversaries of A, so
  guaranteed <= the max-min over memoryless adversaries <= upper_bound (for Pmax; reversed for
  Pmin and Rmin).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pysat.card import CardEnc, EncType
from pysat.solvers import Solver

from posgmc.checking.property_checker import CoalitionResolver, ScalarEvaluator
from posgmc.checking.results import Bound
from posgmc.errors import LimitError
from posgmc.model.explicit import ExplicitModel
from posgmc.resources import check_allocation
from posgmc.strategies.binding import bind, player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.strategies.verify import StrategyChecker, bound_of
from posgmc.syntax.ast import Expr
from posgmc.synthesis.budget import expired

__all__ = ["Enumeration", "enumerate_adversaries", "versus_adversaries"]


_DIRECT_SYMMETRY = 8
"""Up to this many memory nodes the symmetry breaking is written as direct clauses (their size
grows with k³·Z²); beyond, through one auxiliary variable per node (linear)."""


@dataclass(frozen=True)
class Enumeration:
    """The adversary strategies found; ``exhaustive``: every class was enumerated."""

    strategies: tuple[FiniteStateStrategy, ...]
    exhaustive: bool
    seconds: float


def enumerate_adversaries(model: ExplicitModel, player: int, *, memory: int = 1, limit: int = 50,
                          deadline: float | None = None) -> Enumeration:
    """Deterministic finite-state strategies of ``player`` with ``memory`` nodes, one per class on
    the reachable part.

    Encoding (python-sat): for every memory node n and observation z of the adversary's states
    reachable at all, one-hot variables for the action γ(n, z) among the labels offered there and,
    with memory, for the next node δ(n, z) (the update of the chosen action). Symmetry breaking on
    node names: node m > 1 is a successor only if node m - 1 is one too, so renamings of the nodes
    come once as far as this ordering reaches. After each solution the strategy is applied
    (:mod:`posgmc.strategies.product`, the decision maker left free) and the choices at the
    (node, observation) pairs it actually meets are blocked together, so strategies that agree
    wherever they matter come once.

    Args:
        model: the game.
        player: the adversary's index.
        memory: its memory nodes (1: memoryless).
        limit: stop after this many strategies.
        deadline: ``time.perf_counter()`` value after which to stop.
    """
    started = time.perf_counter()
    k = memory
    view = player_view(model, player)
    owned = model.state_players == player
    # observations of the adversary's states reachable at all (everyone free)
    reach = _forward(model)
    rows = np.flatnonzero((owned & reach)[model.choice_states])
    A = len(model.action_names)
    offered = np.zeros((view.num_observations, A), dtype=bool)
    offered[view.state_obs[model.choice_states[rows]], model.choice_actions[rows]] = True
    obs = np.flatnonzero(offered.any(axis=1))
    if obs.size == 0:
        # no state of the adversary is reachable: it never decides, so there is no strategy to
        # enumerate (the phases after it have no adversary to compose against; the omniscient
        # check of the defence is unaffected)
        return Enumeration((), False, time.perf_counter() - started)
    # the encoding has k·Z·(A + k) variables, and each solution dense k x Z x A x k arrays: a
    # memory the machine cannot hold, or a deadline passed while encoding, enumerates nothing
    num_vars = k * (int(offered[obs].sum()) + (k * obs.size if k > 1 else 0))
    try:
        check_allocation(300.0 * num_vars + 8.0 * k * k * obs.size * A,
                         f"enumerating the adversary's {k}-node strategies")
    except LimitError:
        return Enumeration((), False, time.perf_counter() - started)

    def late() -> bool:
        return deadline is not None and time.perf_counter() >= deadline

    act: dict[tuple[int, int, int], int] = {}  # (n, z, a) -> variable
    upd: dict[tuple[int, int, int], int] = {}  # (n, z, m) -> variable
    for n in range(k):
        if late():
            return Enumeration((), False, time.perf_counter() - started)
        for z in obs.tolist():
            for a in np.flatnonzero(offered[z]).tolist():
                act[(n, z, a)] = len(act) + len(upd) + 1
            if k > 1:
                for m in range(k):
                    upd[(n, z, m)] = len(act) + len(upd) + 1
    solver = Solver(name="g3")
    top = len(act) + len(upd)

    def exactly_one(lits: list[int]) -> None:
        nonlocal top
        enc = CardEnc.equals(lits=lits, bound=1, top_id=top, encoding=EncType.seqcounter)
        top = max(top, enc.nv)
        for clause in enc.clauses:
            solver.add_clause(clause)

    for n in range(k):
        if late():
            return Enumeration((), False, time.perf_counter() - started)
        for z in obs.tolist():
            exactly_one([act[(n, z, a)] for a in np.flatnonzero(offered[z]).tolist()])
            if k > 1:
                exactly_one([upd[(n, z, m)] for m in range(k)])
    into: dict[int, list[int]] = {}  # m -> the variables "some rule moves to node m"
    for (_, _, mm), v in upd.items():
        into.setdefault(mm, []).append(v)
    direct = k <= _DIRECT_SYMMETRY
    for m in range(2, k):  # node m is a successor only if node m-1 is one
        if late():
            return Enumeration((), False, time.perf_counter() - started)
        if direct:
            for v in into[m]:
                solver.add_clause([-v, *into[m - 1]])
        else:  # the same through one variable "node m-1 is a successor": linear in size
            top += 1
            solver.add_clause([-top, *into[m - 1]])
            for v in into[m]:
                solver.add_clause([-v, top])
    found: list[FiniteStateStrategy] = []
    exhaustive = False
    used_actions = np.flatnonzero(offered.any(axis=0))
    act_index = {a: i for i, a in enumerate(used_actions.tolist())}
    zi = {z: i for i, z in enumerate(obs.tolist())}
    while len(found) < limit and not expired(deadline):
        if not solver.solve():
            exhaustive = True
            break
        sol = solver.get_model()
        chosen = {(n, z): a for (n, z, a), v in act.items() if sol[v - 1] > 0}
        nxt = {(n, z): m for (n, z, m), v in upd.items() if sol[v - 1] > 0}
        # one rule per (n, z), playing its action, moving to its next node (its rules as
        # written: no dense k x Z x A x k arrays)
        pairs = list(chosen.items())
        ones = np.ones(len(pairs))
        fss = FiniteStateStrategy.from_entries(
            player=view.name, memory_size=k, initial_memory=0, observables=view.observables,
            observation_values=view.obs_values[obs],
            actions=tuple(model.action_names[a] for a in used_actions.tolist()),
            rule_memory=np.array([n for (n, _), _ in pairs], dtype=np.int64),
            rule_observation=np.array([zi[z] for (_, z), _ in pairs], dtype=np.int64),
            entry_rule=np.arange(len(pairs)), entry_action=np.array(
                [act_index[a] for _, a in pairs], dtype=np.int64),
            entry_probability=ones, update_entry=np.arange(len(pairs)),
            update_node=np.array([nxt.get(nz, nz[0]) for nz, _ in pairs], dtype=np.int64),
            update_probability=ones,
        )
        found.append(fss)
        # block the choices only where they matter: the (node, observation) pairs met under them
        prod = strategy_product(model, [bind(model, fss)])
        mine = owned[prod.state_of]
        met = {(int(n), int(z)) for n, z in zip(prod.memory_of[mine, 0].tolist(),
                                                  view.state_obs[prod.state_of[mine]].tolist())}
        clause = []
        for n, z in sorted(met):
            if (n, z) in chosen:
                clause.append(-act[(n, z, chosen[(n, z)])])
                if k > 1:
                    clause.append(-upd[(n, z, nxt[(n, z)])])
        if not clause:
            exhaustive = True  # the adversary never moves: one class only
            break
        solver.add_clause(clause)
    solver.delete()
    return Enumeration(tuple(found), exhaustive, time.perf_counter() - started)


def _forward(model: ExplicitModel) -> np.ndarray:
    """bool[S]: states reachable from the initial states (any choices)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import breadth_first_order

    S = model.num_states
    T = model.transitions.tocoo()
    src = model.choice_states[T.row]
    graph = sp.csr_matrix((np.ones(src.size, dtype=np.int8), (src, T.col)), shape=(S, S))
    out = np.zeros(S, dtype=bool)
    for s in model.initial_states.tolist():
        out[breadth_first_order(graph, s, return_predecessors=False)] = True
    return out


def versus_adversaries(model: ExplicitModel, expr: Expr, defence: FiniteStateStrategy,
                       adversaries: tuple[FiniteStateStrategy, ...], *, maximize: bool,
                       coalition_of: CoalitionResolver, scalar: ScalarEvaluator,
                       deadline: float | None = None,
                       ) -> tuple[Bound | None, Bound | None, int, FiniteStateStrategy | None]:
    """(vs_fss_adversary, upper_bound, how many adversaries were evaluated, the adversary that
    achieves vs_fss_adversary) over ``adversaries`` (see the module docstring), stopping at
    ``deadline``: the worst for the decision maker of each number, with its proven bounds."""
    worst_vs: Bound | None = None
    worst_adversary: FiniteStateStrategy | None = None
    worst_ub: Bound | None = None

    def worse(a: Bound, b: Bound | None) -> bool:
        return b is None or (a.value < b.value if maximize else a.value > b.value)

    done = 0
    for adv in adversaries:
        if done and expired(deadline):
            break
        checker = StrategyChecker(model, {defence.player: defence, adv.player: adv},
                                  coalition_of=coalition_of, scalar=scalar)
        p_def, p_adv = (checker.bound_player(f) for f in (defence, adv))
        both = checker.product_checker(frozenset({p_def, p_adv}))
        alone = checker.product_checker(frozenset({p_adv}))
        vs = both.check(expr, text="vs")
        ub = alone.check(expr, text="ub")
        vs_b, ub_b = bound_of(vs), bound_of(ub)
        if worse(vs_b, worst_vs):
            worst_vs, worst_adversary = vs_b, adv
        if worse(ub_b, worst_ub):
            worst_ub = ub_b
        done += 1
    return worst_vs, worst_ub, done, worst_adversary
