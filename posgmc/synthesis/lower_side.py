"""Closing the optimum bracket from the achievable side: under ``--gap``, when the search's
defence and the bound side leave more than the gap, strategies with more memory over the defence,
from beliefs explored with growing budgets: the policy graph backed up at them
(:mod:`posgmc.synthesis.policy_graph`) and, on a POMDP, the belief controller
(:mod:`posgmc.synthesis.belief`), each ranked like every other candidate; then, while the gap is
still open, a randomised controller whose memory is the belief support
(:mod:`posgmc.synthesis.belief_support`), its action map climbed by gradient ascent against the
adversary's best response (:mod:`posgmc.synthesis.fixed_memory`). The policy graphs and belief
controllers are deterministic, and an omniscient adversary knows a deterministic defender's next
move; the randomised controller keeps it guessing (probability objectives only).

On a POMDP the beliefs are exact. On a one-sided game (a partially observing decision maker
against an omniscient adversary) the decision maker's belief depends on the adversary's unseen
moves: each exploration assumes one stage rule for them (:mod:`posgmc.synthesis.belief_stage`):
the adversary's best response to the current defence (its choices in the defence's product,
mixed over the defence's memory nodes), the full-observation optimum's choice in each state, the
uniform mixture. The assumption only places the backups: a policy graph's values are the
product's own, and the best candidate replaces the defence only when the sound product check of
its FSS against *every* adversary (``verify``) proves more.

The work is counted in explored belief nodes (``--effort`` scales it), so the controllers, and
so the numbers, depend only on the model, the options and the seed; a wall-clock cap stops it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from posgmc.checking.property_checker import CheckOptions, PropertyChecker
from posgmc.checking.results import Bound
from posgmc.engines.options import SolverOptions
from posgmc.strategies.binding import bind
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.strategies.verify import StrategyChecker
from posgmc.synthesis import belief, belief_grid, belief_support, fixed_memory, policy_graph
from posgmc.synthesis.belief_stage import deterministic_rule, uniform_rule
from posgmc.synthesis.options import Gap
from posgmc.synthesis.problem import POLICY, Problem, expired

__all__ = ["LowerSide", "applies", "close_from_below", "GROWTH", "FIRST_BUDGET", "SHARE",
           "GRAPH_NODES", "GRAPH_MAX", "SUPPORT_SHARE", "STALE"]

GRAPH_NODES = 256
"""The first policy graph (:mod:`posgmc.synthesis.policy_graph`) adds this many memory nodes at
most; each next one twice as many, up to :data:`GRAPH_MAX`."""

GRAPH_MAX = 1024
"""The most memory nodes a policy graph adds (its product lays the model out once per node)."""

BUILD_SHARE = 0.6
"""Under a cap: the part of the lower side's time for building candidates (the sound check of
the best one has the rest)."""

SUPPORT_SHARE = 0.5
"""Under a cap, when the model has a belief-support frame: the part of the building time kept
at its end for the randomised support controller, unless the policy graphs and belief controllers
built before it already improve on the defence (by more than :data:`STALE` of the gap: then they
keep going, and it has what they leave)."""

STALE = 0.01
"""Policy graphs and belief controllers that close less of the gap between the defence and the
bound side than this part of it are not improving on it (:data:`SUPPORT_SHARE`)."""

SHARE = 0.15
"""Under a wall-clock cap with ``--gap``: the part of it at its end kept for the lower side (the
bound side stops before it)."""

FIRST_BUDGET = 4
"""The first controller explores this many times the belief phase's node budget
(``budget.DEFAULT_UNITS["belief_nodes"]`` times ``--effort``)."""

GROWTH = 4
"""Each further controller explores this many times as many belief nodes as the one before (up to
:data:`posgmc.synthesis.belief.MAX_EXPLORED`)."""


@dataclass(frozen=True, eq=False)
class LowerSide:
    """What the lower side found: ``strategy`` and its proven ``guaranteed`` (None: nothing
    better than the defence it started from); ``tried``: per controller built, its assumed
    adversary rule, belief nodes explored, memory nodes and its ranking value (policy iteration
    on its product, a float)."""

    strategy: FiniteStateStrategy | None
    guaranteed: Bound | None
    tried: tuple[dict[str, object], ...]

    def to_json(self) -> dict[str, object]:
        return {"improved": self.strategy is not None, "tried": list(self.tried)}


def applies(problem: Problem) -> bool:
    """A POMDP, or a turn-based game of the decision maker against one omniscient adversary."""
    model = problem.model
    if model.initial_states.size != 1:
        return False
    return belief.applies(problem) or (problem.adversary is not None
                                       and len(model.player_names) == 2)


def close_from_below(problem: Problem, defence: FiniteStateStrategy, guaranteed: Bound, *,
                     bound: float, gap: Gap, nodes: int, deadline: float | None,
                     verify: Callable[[FiniteStateStrategy], Bound],
                     steps: int = fixed_memory.ITERATIONS) -> LowerSide:
    """Belief-based controllers over ``defence`` (which proves ``guaranteed``) until one is
    ranked within ``gap`` of ``bound`` (the bracket's bound side), the budgets are spent or
    ``deadline`` passes; then, while none is within the gap, the randomised support controller;
    the best-ranked one is checked by ``verify`` (the sound product check against every
    adversary) and returned when that proves more than ``guaranteed``.

    ``nodes``: the belief phase's node budget (the first controller explores
    :data:`FIRST_BUDGET` times it, each next one :data:`GROWTH` times more); ``steps``: the
    support controller's gradient steps."""
    maximize = problem.maximize
    sign = problem.sign
    achieved = guaranteed.lower if maximize else guaranteed.upper
    tried: list[dict[str, object]] = []
    if not applies(problem):
        return LowerSide(None, None, ())
    # under a cap the candidates are built in the first part of the time left, so that the
    # best one's product check has the rest
    now = time.perf_counter()
    build_until = None if deadline is None else now + BUILD_SHARE * max(0.0, deadline - now)
    frame = None
    if problem.rewards is None:
        frame = belief_support.support_frame(problem.model, problem.player,
                                             deadline=build_until)
    graphs_until = build_until
    if frame is not None and build_until is not None:
        now = time.perf_counter()
        graphs_until = now + (1.0 - SUPPORT_SHARE) * max(0.0, build_until - now)
    upper, choice = belief_grid.full_observation_bounds(problem, build_until)
    best = _belief_candidates(problem, defence, bound, gap, nodes, upper, choice,
                              (graphs_until, achieved), build_until, tried)
    if frame is not None and not expired(build_until) and not (
            best is not None and gap.met(*sorted((best[0], bound)))):
        # from the full-observation optimum's cautious reading over each support
        found = fixed_memory.ascend_frame(problem, frame, iterations=steps, start=upper,
                                          deadline=build_until)
        tried.append({"kind": "randomised support controller",
                      "adversary_rule": "best response to each step",
                      "steps": found.evaluations, "memory": frame.memory_size,
                      "ranked": found.value if math.isfinite(found.value) else None})
        if math.isfinite(found.value) and (best is None
                                           or sign * found.value > sign * best[0]):
            best = (found.value, found.strategy)
    if best is None or sign * best[0] <= sign * achieved or expired(deadline):
        return LowerSide(None, None, tuple(tried))
    proven = verify(best[1])
    value = proven.lower if maximize else proven.upper
    if not proven.sound or sign * value <= sign * achieved:
        return LowerSide(None, None, tuple(tried))
    return LowerSide(best[1], proven, tuple(tried))


def _belief_candidates(problem: Problem, defence: FiniteStateStrategy, bound: float, gap: Gap,
                       nodes: int, upper: np.ndarray, choice: np.ndarray | None,
                       stale: tuple[float | None, float], build_until: float | None,
                       tried: list[dict[str, object]]
                       ) -> tuple[float, FiniteStateStrategy] | None:
    """The best-ranked policy graph or belief controller over ``defence`` (each one built is
    appended to ``tried``), from explorations under each assumed adversary rule with growing
    budgets until one is within ``gap`` of ``bound`` or ``build_until`` passes; or, once the
    time ``stale[0]`` has passed, as soon as none closes more than :data:`STALE` of the gap
    between ``stale[1]`` (what the defence achieves) and ``bound`` (the time then goes to the
    randomised support controller). ``upper``,
    ``choice``: the full-observation optimum's bound and choice per state."""
    sign = problem.sign
    soft, achieved = stale

    def improving() -> bool:
        return best is not None and sign * (best[0] - achieved) > STALE * abs(bound - achieved)
    cut = belief.cutoff_values(problem.model, defence, problem.query,
                               coalition_of=problem.coalition_of, scalar=problem.scalar)
    best: tuple[float, FiniteStateStrategy] | None = None
    for name, rule in _rules(problem, defence, choice):
        explore, graph = FIRST_BUDGET * nodes, GRAPH_NODES
        while not expired(build_until) and (improving() or not expired(soft)):
            # an exploration that has not improved on the defence yet stops at the soft limit
            made, explored = _candidates(problem, defence, cut, upper, rule, explore, graph,
                                         build_until if improving() or soft is None
                                         else min(soft, build_until or soft))
            for kind, fss in made:
                ranked = _rank(problem, fss)
                tried.append({"kind": kind, "adversary_rule": name, "explore": explore,
                              "explored": explored, "memory": fss.memory_size,
                              "ranked": ranked if math.isfinite(ranked) else None})
                if best is None or sign * ranked > sign * best[0]:
                    best = (ranked, fss)
            # more beliefs while the exploration used its whole budget, more nodes up to the cap
            grown = (explore if explored < explore else
                     min(belief.MAX_EXPLORED, GROWTH * explore), min(GRAPH_MAX, 2 * graph))
            if not made or (best is not None and gap.met(*sorted((best[0], bound)))) \
                    or grown == (explore, graph):
                break  # within the gap, or nothing left to grow
            explore, graph = grown
        if best is not None and gap.met(*sorted((best[0], bound))) \
                or (expired(soft) and not improving()):
            break
    return best


def _candidates(problem: Problem, defence: FiniteStateStrategy, cut: np.ndarray,
                upper: np.ndarray, rule: np.ndarray | None, explore: int, graph: int,
                deadline: float | None) -> tuple[list[tuple[str, FiniteStateStrategy]], int]:
    """The strategies built from the beliefs explored with ``explore`` nodes under ``rule``:
    the policy graph backed up at them (at most ``graph`` new nodes) and, on a POMDP, the
    belief controller; and how many belief nodes were explored."""
    args = dict(player=problem.player, cutoff=defence, cut_values=cut, upper=upper,
                target=problem.target, remain=problem.remain, rewards=problem.rewards,
                discount=problem.discount, maximize=problem.maximize, deadline=deadline,
                explore=explore, adversary_rule=rule)
    made: list[tuple[str, FiniteStateStrategy]] = []
    points = belief.belief_points(problem.model, **args)  # type: ignore[arg-type]
    if points is None:
        return made, 0
    pg = policy_graph.backed_up(
        problem.model, player=problem.player, cutoff=defence, cut_values=cut, beliefs=points,
        target=problem.target, remain=problem.remain, rewards=problem.rewards,
        discount=problem.discount, maximize=problem.maximize, max_nodes=graph,
        deadline=deadline)
    if pg is not None:
        made.append(("policy graph", pg.strategy))
    if problem.adversary is None and not expired(deadline):
        # on a POMDP the belief is exact: the belief MDP's controller too (in a game it would
        # trust the assumed rule, which the omniscient adversary need not follow)
        found = belief.belief_controller(problem.model, **args)  # type: ignore[arg-type]
        if found is not None:
            made.append(("belief controller", found.strategy))
    return made, points.shape[0]


def _rank(problem: Problem, fss: FiniteStateStrategy) -> float:
    """``fss``'s value against the omniscient adversary by policy iteration on its product (a
    ranking, not a proof; the worst value when it has none)."""
    bound = StrategyChecker(problem.model, {fss.player: fss}, coalition_of=problem.coalition_of,
                            scalar=problem.scalar, options=POLICY
                            ).check(problem.query, text="synthesis").guaranteed
    if bound is None:
        return -problem.sign * math.inf
    value = bound.lower if problem.maximize else bound.upper
    return value if math.isfinite(value) else -problem.sign * math.inf


def _rules(problem: Problem, defence: FiniteStateStrategy, choice: np.ndarray | None
           ) -> list[tuple[str, np.ndarray | None]]:
    """The adversary stage rules the controllers assume (a POMDP: none)."""
    if problem.adversary is None:
        return [("none", None)]
    model, adversary = problem.model, problem.adversary
    rules: list[tuple[str, np.ndarray | None]] = []
    response = _best_response(problem, defence)
    if response is not None:
        rules.append(("best response to the defence", response))
    if choice is not None:
        rules.append(("full-observation optimum", deterministic_rule(model, adversary, choice)))
    rules.append(("uniform", uniform_rule(model, adversary)))
    return rules


def _best_response(problem: Problem, defence: FiniteStateStrategy) -> np.ndarray | None:
    """float64[C]: the adversary's optimal choices in the product with ``defence``, each state's
    mixed over the defence's memory nodes the product reaches it with (None: the solve gives no
    strategy)."""
    model = problem.model
    prod = strategy_product(model, [bind(model, defence)])
    checker = PropertyChecker(prod.model, coalition_of=problem.coalition_of,
                              scalar=problem.scalar,
                              options=CheckOptions(keep_strategy=True, solver=SolverOptions(
                                  method=POLICY.solver.method, prove=False)))
    r = checker.query(problem.query, everywhere=True)
    if r.engine is None or r.engine.strategy is None:
        return None
    picked = np.asarray(r.engine.strategy, dtype=np.int64)  # a product choice per product state
    pm = prod.model
    owned = model.state_players[prod.state_of] == problem.adversary
    rg = pm.row_groups
    states = np.flatnonzero(owned & (picked >= rg[:-1]) & (picked < rg[1:]))
    if not states.size:
        return None
    # the product keeps the model's choice order within each state: offset = the model choice
    local = picked[states] - rg[states]
    s = prod.state_of[states]
    global_choice = model.row_groups[s] + local
    rule = np.bincount(global_choice, minlength=model.num_choices).astype(np.float64)
    per_state = np.bincount(s, minlength=model.num_states).astype(np.float64)
    rule /= np.maximum(per_state[model.choice_states], 1.0)
    # adversary states the product never reaches: the full mixture
    seen = per_state > 0
    adv = model.state_players == problem.adversary
    fill = adv & ~seen
    if fill.any():
        counts = np.diff(model.row_groups)
        cs = model.choice_states
        rule = np.where(fill[cs], 1.0 / counts[cs], rule)
    return rule
