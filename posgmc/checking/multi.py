"""PRISM's multi-objective queries ``multi(...)`` on mdps: what each form asks, as one LP.

Semantics (PRISM manual, "Multi-objective properties"; Forejt et al., TACAS 2011): a strategy is
sought for the single initial state that meets every objective **at once**:

* achievability ``multi(P>=0.9 [F "goal"], R{"cost"}<=20 [C])``: does one exist? (Boolean);
* numerical ``multi(Pmax=? [F "goal"], R{"cost"}<=20 [C])``: the optimum of the ``=?`` objective
  over the strategies meeting the constraints (NaN when none does, as PRISM);
* Pareto ``multi(Pmax=? [...], R{"cost"}min=? [...])``: the front of the two ``=?`` objectives
  over those strategies, as an under- and an over-approximation
  (:mod:`posgmc.engines.multi.pareto`).

A threshold ``P>=p`` here means "some strategy achieves it" (not "every scheduler", as alone).
Strict and non-strict thresholds are read alike (the LP's closure; PRISM does the same).

Translation (each step a module of its own): every probability objective becomes a condition on
the end component a path settles in (:mod:`posgmc.engines.multi.settle`): a co-safe LTL formula
(reachability, until, bounded ``F``, ...) through its DFA product, whose accepting set is closed
under successors; a formula whose negation is co-safe (``G a``) through the complement; ``G F a``
and ``F G a`` directly; a minimised probability or an upper bound ``P<=p`` through the
complement of the formula. Cumulative rewards ``[C<=k]`` unfold the MDP by steps
(:mod:`posgmc.engines.multi.unfold`). Total rewards must be non-negative; a path may settle only
where no total-reward objective collects reward. Then one occupation LP
(:mod:`posgmc.engines.multi.lp`) over the product answers the query.

Precision: an LP optimum is a floating-point number (HiGHS, feasibility tolerances
:data:`~posgmc.engines.multi.lp.LP_TOLERANCE`), not a proven bound: results say so
(``sound: false``, ``method: "lp"``). An achievability verdict is **decided** when the
constraints hold (or fail) with a margin of at least :data:`MARGIN`; at the boundary the
nominal LP answer is reported with a note that it is within the LP's tolerance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np
import scipy.sparse as sp

from posgmc.checking.multi_objectives import (
    Front,
    MultiAnswer,
    MultiKind,
    Objective,
    ProductBuilder,
    objectives_of,
)
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.engines.multi.lp import LP_TOLERANCE, LPStatus, OccupationLP
from posgmc.engines.multi.pareto import ParetoFront, pareto_front
from posgmc.engines.multi.pareto_nd import pareto_front_nd
from posgmc.engines.multi.settle import Condition, Settling, settling
from posgmc.engines.multi.unfold import layer_rewards, unfold_steps
from posgmc.errors import UnsupportedError
from posgmc.semantics.queries import reward_structure
from posgmc.syntax.ast import (
    ComparisonOp,
    Direction,
    MultiQuery,
    RewardKind,
    RewardQuery,
)
from posgmc.syntax.printer import format_expr

if TYPE_CHECKING:
    from posgmc.checking.protocols import StateFormulaChecker

__all__ = ["answer_multi", "check_multi", "MARGIN"]

MARGIN = 1e-6
"""An achievability verdict is decided when the constraints hold, or fail, by at least this
much (relative to ``max(1, |bound|)`` for rewards)."""


# -- translation to the LP ---------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Parts:
    """The LP's MDP, kept to re-check an LP solution's strategy (:func:`_certify`)."""

    transitions: sp.csr_matrix
    groups: np.ndarray
    initial: int
    settling: Settling
    rewards: dict[int, np.ndarray]  # objective -> its non-negative choice rewards (own sense)
    condition_of: dict[int, int]  # probability objective -> its condition


def _lp(
    expr: MultiQuery, objectives: list[Objective], checker: StateFormulaChecker
) -> tuple[OccupationLP, int, _Parts]:
    """The occupation LP of the query (objective ``i`` is row ``i``), its number of states and
    the parts its strategy is re-checked on."""
    model = checker.model
    if model.initial_states.size != 1:
        raise UnsupportedError(
            f"multi(...) needs a single initial state; the model has {model.initial_states.size}",
            expr.span,
            hint="add an init ... endinit block, or initial values, that pick one state",
        )
    builder = ProductBuilder(checker)
    condition_of = {
        i: builder.add_probability(o) for i, o in enumerate(objectives) if o.is_probability
    }
    m = builder.model
    last = 0
    bounds: dict[int, int | None] = {}
    for i, o in enumerate(objectives):
        if isinstance(o.query, RewardQuery):
            if o.query.objective.kind is RewardKind.CUMULATIVE:
                bounds[i] = checker.step_bound(o.query.objective.bound)
                last = max(last, bounds[i] or 0)
            else:
                bounds[i] = None
    transitions, groups = m.transitions, m.row_groups
    if last > 0:
        transitions, groups = unfold_steps(transitions, groups, last)
    num_states = int(groups.size - 1)
    num_choices = int(groups[-1])
    layer_start = last * m.num_states
    settle = np.zeros(num_states, dtype=bool)
    settle[layer_start:] = True
    allowed = np.ones(num_choices, dtype=bool)
    rewards: dict[int, np.ndarray] = {}
    plain: dict[int, np.ndarray] = {}
    for i, bound in bounds.items():
        q = objectives[i].query
        assert isinstance(q, RewardQuery)  # noqa: S101
        base = reward_structure(m, q).choice_rewards(m.row_groups)
        if (base < 0).any():
            raise UnsupportedError(
                "multi(...) needs non-negative rewards; this reward structure has negative ones",
                q.span,
            )
        r = layer_rewards(base, last, bound)
        plain[i] = r
        rewards[i] = -r if objectives[i].minimise else r
        allowed &= r == 0
    conditions = tuple(
        Condition(kind, np.tile(mask, last + 1)) for kind, mask in builder.masks
    )
    found = settling(transitions, groups, conditions, allowed=allowed, settle=settle)
    stop_state, stop_sat = found.stop_state, found.stop_sat
    if stop_state.size == 0 or not _settles_almost_surely(
        transitions, groups, builder.initial, stop_state
    ):
        # Under every strategy a path that never settles takes, infinitely often, a choice with
        # a positive reward of some total-reward objective (the choices that may repeat forever
        # are those without any): when no strategy settles with probability 1, one of the
        # objectives' expected totals is infinite whatever the strategy (the LP, which asks for
        # settling with probability 1, would be infeasible and say NaN).
        raise UnsupportedError(
            "every strategy collects reward forever with positive probability in a total-reward "
            "objective of multi(...): the expected total rewards are infinite",
            expr.span,
        )
    coefficients = np.zeros((len(objectives), num_choices + stop_state.size))
    for i in range(len(objectives)):
        if i in condition_of:
            coefficients[i, num_choices:] = stop_sat[:, condition_of[i]]
        else:
            coefficients[i, :num_choices] = rewards[i]
    lp = OccupationLP.build(transitions, groups, builder.initial, stop_state, coefficients)
    return lp, num_states, _Parts(transitions, groups, builder.initial, found, plain, condition_of)


def _settles_almost_surely(
    transitions: sp.csr_matrix, groups: np.ndarray, initial: int, stop_state: np.ndarray
) -> bool:
    """Some strategy reaches a state where a path may settle with probability 1 from
    ``initial`` (graph analysis: the almost-sure region of reaching ``stop_state``)."""
    from posgmc.engines.graph import Structure, almost_sure_reach

    num_states = int(groups.size - 1)
    target = np.zeros(num_states, dtype=bool)
    target[stop_state] = True
    everywhere = np.ones(num_states, dtype=bool)
    region, _ = almost_sure_reach(
        Structure.build(transitions, groups), target, everywhere, existential=everywhere
    )
    return bool(region[initial])


def _certify(parts: _Parts, objectives: list[Objective], x: np.ndarray) -> np.ndarray:
    """Proven lower bounds, in the LP's maximising sense, on every objective's value under the
    strategy of the LP solution ``x`` (:mod:`posgmc.engines.multi.scheduler`): sound interval
    iteration on the chain it induces. A bound is ``-inf`` where nothing is proven."""
    from posgmc.engines.multi.scheduler import occupation_chain
    from posgmc.engines.reach import reach_probability
    from posgmc.engines.total import total_reward

    chain = occupation_chain(parts.transitions, parts.groups, parts.initial, parts.settling, x,
                          parts.rewards)
    m = chain.model
    s0 = int(m.initial_states[0])
    yes = np.ones(m.num_states, dtype=bool)
    out = np.full(len(objectives), -np.inf)
    for i, o in enumerate(objectives):
        if i in parts.condition_of:
            r = reach_probability(m, m.label(f"sat{parts.condition_of[i]}"), maximize=yes)
            if r.sound:
                out[i] = float(r.lower[s0])
        else:
            r = total_reward(m, chain.rewards[i], maximize=yes)
            if r.sound:
                out[i] = -float(r.upper[s0]) if o.minimise else float(r.lower[s0])
    return out


# -- the three forms ---------------------------------------------------------------------------


def answer_multi(
    checker: StateFormulaChecker,
    expr: MultiQuery,
    *,
    tolerance: float = 1e-6,
    max_solves: int = 200,
) -> MultiAnswer:
    """Answer a ``multi(...)`` query on the checker's model (see the module docstring).

    Args:
        checker: the property checker of an mdp (or dtmc).
        expr: the query, resolved (constants substituted).
        tolerance: Pareto queries: a segment of the front is final when no point lies further
            beyond it than this.
        max_solves: Pareto queries: at most this many LPs.

    Raises:
        UnsupportedError: a form outside the fragment (see :mod:`posgmc.semantics.multi`).
    """
    if expr.coalition is not None:
        from posgmc.checking.multi_games import answer_game

        return answer_game(checker, expr)
    start = time.perf_counter()
    objectives = objectives_of(expr, checker)
    texts = tuple(format_expr(o.query) for o in objectives)
    lp, num_states, parts = _lp(expr, objectives, checker)
    at_least = {i: o.lp_bound() for i, o in enumerate(objectives) if o.bound is not None}
    queries = [i for i, o in enumerate(objectives) if o.bound is None]
    if not queries:
        scale = {i: objectives[i].scale_of_bound for i in at_least}
        point = lp.slack(at_least, scale)
        if point.status is not LPStatus.OPTIMAL:
            raise UnsupportedError(f"the LP solver failed: {point.message}", expr.span)
        t = point.extra
        proven = False
        if t >= -10 * LP_TOLERANCE and point.x is not None:
            # the slack LP's solution keeps the largest room: re-check its strategy
            lower = _certify(parts, objectives, point.x)
            proven = _meets(objectives, lower, at_least)
        return MultiAnswer(
            MultiKind.ACHIEVABILITY, texts, achievable=t >= -10 * LP_TOLERANCE,
            decided=abs(t) >= MARGIN or proven, margin=t, residual=point.residual,
            states=num_states, seconds=time.perf_counter() - start, proven=proven,
        )
    if len(queries) == 1:
        (i,) = queries
        weights = np.zeros(len(objectives))
        weights[i] = 1.0
        point = lp.maximise(weights, at_least=at_least)
        if point.status is LPStatus.FAILED:
            raise UnsupportedError(f"the LP solver failed: {point.message}", expr.span)
        certified = math.nan
        if point.status is LPStatus.UNBOUNDED:
            value = objectives[i].reported(np.inf)
        else:
            value = objectives[i].reported(float(point.values[i]))
            if point.status is LPStatus.OPTIMAL:
                certified = _certified_optimum(lp, parts, objectives, i, weights, at_least, point.x)
        return MultiAnswer(
            MultiKind.NUMERICAL, texts, value=value, residual=point.residual, states=num_states,
            seconds=time.perf_counter() - start, certified=certified,
            minimised=objectives[i].minimise,
        )
    if len(queries) == 2:
        raw: ParetoFront = pareto_front(
            lp, queries[0], queries[1], at_least=at_least, tolerance=tolerance,
            max_solves=max_solves,
        )
    else:
        raw = pareto_front_nd(lp, tuple(queries), at_least=at_least, tolerance=tolerance,
                              max_solves=max_solves)

    def units(pts: np.ndarray) -> np.ndarray:
        out = pts.copy()
        for axis, i in enumerate(queries):
            out[:, axis] = [objectives[i].reported(v) for v in pts[:, axis]]
        return out

    directions = tuple(Direction.MIN if objectives[i].minimise else Direction.MAX for i in queries)
    front = Front(
        tuple(texts[i] for i in queries), directions, units(raw.points), units(raw.corners),
        raw.precision, raw.solves, raw.converged,
    )
    return MultiAnswer(MultiKind.PARETO, texts, front=front, states=num_states,
                       seconds=time.perf_counter() - start)


def _meets(objectives: list[Objective], lower: np.ndarray, at_least: dict[int, float]) -> bool:
    """Every threshold holds for the proven lower bounds (strictly for ``>``/``<``)."""
    for k, v in at_least.items():
        t = objectives[k].query.threshold
        strict = t is not None and t.op in (ComparisonOp.GT, ComparisonOp.LT)
        if not (lower[k] > v if strict else lower[k] >= v):
            return False
    return True


def _certified_optimum(
    lp: OccupationLP,
    parts: _Parts,
    objectives: list[Objective],
    i: int,
    weights: np.ndarray,
    at_least: dict[int, float],
    x: np.ndarray | None,
) -> float:
    """A proven bound on the optimum of objective ``i`` (a lower bound when it is maximised, an
    upper bound when minimised), in its own units, from a strategy whose values the sound
    engines re-check; NaN when the check proves nothing. The LP's own solution is tried first;
    when its re-checked values miss a constraint (a binding one, by rounding), the constraints
    are tightened by 1e-6 (relative to ``max(1, |bound|)`` for rewards) and the LP solved again,
    so that the strategy meets them with room beyond the engines' precision."""
    def proven(candidate: np.ndarray) -> float:
        lower = _certify(parts, objectives, candidate)
        if _meets(objectives, lower, at_least) and np.isfinite(lower[i]):
            return objectives[i].reported(float(lower[i]))
        return math.nan

    if x is not None and not math.isnan(found := proven(x)):
        return found
    if at_least:
        room = {k: v + MARGIN * objectives[k].scale_of_bound for k, v in at_least.items()}
        tight = lp.maximise(weights, at_least=room)
        if tight.status is LPStatus.OPTIMAL and tight.x is not None:
            return proven(tight.x)
    return math.nan


def check_multi(
    checker: StateFormulaChecker, expr: MultiQuery, *, text: str, name: str | None
) -> PropertyResult:
    """A ``multi(...)`` property as a :class:`PropertyResult` (``multi`` holds the typed answer)."""
    a = answer_multi(checker, expr)
    if expr.coalition is not None:
        return _game_result(a, text=text, name=name)
    method = "lp (HiGHS)"
    common = _Common(property=text, name=name, seconds=a.seconds, method=method, sound=False,
                     multi=a)
    if a.kind is MultiKind.ACHIEVABILITY:
        if a.proven:
            note = ("proven: the LP's strategy, re-checked by interval iteration on the chain it "
                    f"induces, meets every threshold (LP margin {a.margin:.3g})")
            common["sound"] = True
        elif a.decided:
            note = (f"LP: the constraints hold with margin {a.margin:.3g} (not re-proven)"
                    if a.achievable else f"LP: a constraint fails by at least {-a.margin:.3g} "
                    "(the LP's estimate; infeasibility is not certified)")
        else:
            note = (f"at the boundary: the LP's answer is within its tolerance of the thresholds "
                    f"(margin {a.margin:.2g}); not decided with margin {MARGIN:g}")
        return PropertyResult(kind=ResultKind.BOOLEAN, value=bool(a.achievable), lower=None,
                              upper=None, note=note, **common)
    if a.kind is MultiKind.NUMERICAL:
        v = a.value
        if np.isnan(v):
            note = "the constraints cannot be met together (PRISM: NaN)"
            lower = upper = v
        else:
            eps = max(LP_TOLERANCE * (1.0 + abs(v)), a.residual) if np.isfinite(v) else 0.0
            lower, upper = v - eps, v + eps
            note = "LP optimum (floating point, within the LP's tolerance; not a proven bound)"
            if not np.isnan(a.certified):
                side = "at most" if a.minimised else "at least"
                note = (f"LP optimum (floating point); proven: the optimum is {side} "
                        f"{a.certified:.10g} (the LP's strategy, re-checked by interval iteration "
                        "on the chain it induces); the other side is the LP's estimate")
                if side == "at least":
                    lower = min(lower, a.certified)
                else:
                    upper = max(upper, a.certified)
        return PropertyResult(kind=ResultKind.NUMBER, value=v, lower=lower, upper=upper,
                              note=note, **common)
    assert a.front is not None  # noqa: S101
    f = a.front
    note = (f"Pareto front: {len(f.points)} vertices; over-approximation within {f.precision:.2g} "
            f"({f.solves} LPs" + ("" if f.converged else ", STOPPED at the LP budget") + ")")
    if len(f.points) == 0:
        note = "the constraints cannot be met together: the front is empty"
    return PropertyResult(kind=ResultKind.PARETO, value=float("nan"), lower=None, upper=None,
                          note=note, **common)


class _Common(TypedDict):
    """The fields every result of a ``multi(...)`` query shares."""

    property: str
    name: str | None
    seconds: float
    method: str
    sound: bool
    multi: MultiAnswer


def _game_result(a: MultiAnswer, *, text: str, name: str | None) -> PropertyResult:
    """A coalition query on an smg: answers from an under-approximation (multi_games.py)."""
    common = _Common(property=text, name=name, seconds=a.seconds,
                     method="value iteration (sets)", sound=False, multi=a)
    if a.kind is MultiKind.ACHIEVABILITY:
        note = ("the coalition achieves the thresholds (they lie in the under-approximation of "
                "the achievable set)" if a.achievable else
                f"not proven: the thresholds lie {-a.margin:.3g} outside the under-approximation "
                "of the achievable set; its limit might still reach them")
        return PropertyResult(kind=ResultKind.BOOLEAN, value=bool(a.achievable), lower=None,
                              upper=None, note=note, **common)
    if a.kind is MultiKind.NUMERICAL:
        note = ("a lower bound: achievable by the coalition (from the under-approximation of the "
                "achievable set); the optimum may be higher")
        if np.isnan(a.value):
            note = "no point of the under-approximation meets the constraint"
        return PropertyResult(kind=ResultKind.NUMBER, value=a.value, lower=a.value,
                              upper=math.inf if not np.isnan(a.value) else a.value, note=note,
                              **common)
    assert a.front is not None  # noqa: S101
    note = (
        f"Pareto front of the coalition: {len(a.front.points)} vertices of an "
        "under-approximation (value iteration"
        + (", converged" if a.front.converged else ", NOT converged")
        + "); no over-approximation"
    )
    return PropertyResult(kind=ResultKind.PARETO, value=float("nan"), lower=None, upper=None,
                          note=note, **common)
