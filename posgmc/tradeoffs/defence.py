"""A defender's trade-off front on a partially observable game: mission success against cost.

The question: "maximise the `guaranteed` P(mission) subject to the worst-case expected cost
<= c", for a sweep of c. Synthesis (:mod:`posgmc.synthesis`) optimises one objective, so the front
is found by **scalarisation** and kept honest by **verification**:

1. for every weight ``w >= 0`` a defence is synthesised (through :func:`posgmc.api.synthesize`)
   for one scalar objective: the cost query with its reward replaced by
   ``cost(c) - w * P(c enters G)`` (``G`` the mission's target; the entering step only, from
   outside ``G``), i.e. cost minus ``w`` per unit of (discounted, for a discounted cost)
   probability of completing the mission. ``w = 0`` is the cheapest defence, ``w = inf`` (the
   mission query itself) the most successful one;
2. every defence is written as a ``posgmc-fss/1`` file (when a directory is given), read back,
   and both objectives are checked under it on the original model with the sound engines
   (:func:`posgmc.api.check` with ``strategies=``): its ``guaranteed`` P(mission) against the
   omniscient adversary, and its ``guaranteed`` expected cost (the cost the worst adversary
   inflicts on it), each with proven bounds. The scalarised value itself is never reported: it is
   only a way to produce candidates;
3. the **front** is the set of verified points no other point beats on both proven bounds (mission
   lower bound, cost upper bound); a **constraint** ``cost <= c`` is answered by the verified point
   of largest proven mission among those whose proven cost is at most ``c``.

Each point is a strategy that provably achieves its point (both numbers against every adversary,
each objective's worst adversary separately: the cost bound holds whatever the adversary does,
and so does the mission bound). What is *not* proven: that no defence of that memory does better
(synthesis is a local search; the scalarisation only finds points on the convex hull of what it
finds). ``full_observation`` bounds are reported beside (no partially observing defence beats them).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from posgmc.checking.results import Bound
from posgmc.errors import InputError, PosgmcError, UnsupportedError
from posgmc.synthesis import progress

__all__ = ["DefencePoint", "DefenceFront", "BudgetAnswer", "defence_front",
           "defence_front_to_csv", "SCALARISED_REWARD"]

SCALARISED_REWARD = "__posgmc_scalarised"
"""The name of the reward structure the scalarised objective is written over (on a copy of the
compiled model; never visible in the user's model)."""


@dataclass(frozen=True, eq=False)
class DefencePoint:
    """One synthesised defence: the scalarisation ``weight`` it was synthesised for
    (``math.inf``: the mission query itself), its verified ``mission`` and ``cost`` numbers
    (``guaranteed``, proven bounds, against every adversary), the strategy and where it was
    written; ``error`` when synthesis or verification failed (the other points go on)."""

    weight: float
    mission: Bound | None
    cost: Bound | None
    strategy: Any = None  # FiniteStateStrategy
    strategy_file: str | None = None
    memory: int = 0
    seconds: float = 0.0
    partial: bool = False
    error: PosgmcError | None = None

    @property
    def verified(self) -> bool:
        return (self.error is None and self.mission is not None and self.cost is not None
                and self.mission.sound and self.cost.sound)


@dataclass(frozen=True, eq=False)
class BudgetAnswer:
    """The answer to "max guaranteed mission s.t. guaranteed cost <= ``budget``": ``point`` the
    defence (None: no verified defence meets it), ``pure`` the index of the best single verified
    point that meets it, ``mixed`` ``(i, j, alpha)`` when ``point`` is the mixture playing point
    ``j`` with probability ``alpha`` and point ``i`` otherwise (:mod:`posgmc.strategies.mixture`),
    verified itself and better than ``pure``."""

    budget: float
    point: DefencePoint | None
    pure: int | None
    mixed: tuple[int, int, float] | None = None


@dataclass(frozen=True, eq=False)
class DefenceFront:
    """The points of a scalarisation sweep; ``front`` indexes the non-dominated verified ones
    (sorted by cost), ``budgets`` answers each cost constraint. ``full_observation`` is the
    mission's and the cost's full-observation bound (proven; no partially observing defence beats
    them)."""

    mission: str
    cost: str
    points: tuple[DefencePoint, ...]
    front: tuple[int, ...]
    budgets: tuple[BudgetAnswer, ...] = ()
    full_observation: tuple[Bound | None, Bound | None] = (None, None)
    seconds: float = 0.0


def _dominates(a: DefencePoint, b: DefencePoint) -> bool:
    assert a.mission and a.cost and b.mission and b.cost  # noqa: S101 - verified points only
    return (a.mission.lower >= b.mission.lower and a.cost.upper <= b.cost.upper
            and (a.mission.lower > b.mission.lower or a.cost.upper < b.cost.upper))


def pareto_indices(points: Sequence[DefencePoint]) -> tuple[int, ...]:
    """The verified points no other verified point dominates (proven mission lower bound at least
    as high and proven cost upper bound at most as high, one strictly), sorted by cost; of equal
    points the first is kept."""
    ok = [i for i, p in enumerate(points) if p.verified]
    keep: list[int] = []
    for i in ok:
        if any(_dominates(points[j], points[i]) for j in ok if j != i):
            continue
        if any(j < i and points[j].mission.lower == points[i].mission.lower  # type: ignore[union-attr]
               and points[j].cost.upper == points[i].cost.upper for j in keep):  # type: ignore[union-attr]
            continue
        keep.append(i)
    return tuple(sorted(keep, key=lambda i: (points[i].cost.upper, -points[i].mission.lower)))  # type: ignore[union-attr]


def best_under(points: Sequence[DefencePoint], budget: float) -> int | None:
    """The constrained answer: the verified point of largest proven mission lower bound whose
    proven cost upper bound is at most ``budget`` (ties: the cheaper)."""
    ok = [i for i, p in enumerate(points) if p.verified and p.cost.upper <= budget]  # type: ignore[union-attr]
    if not ok:
        return None
    return max(ok, key=lambda i: (points[i].mission.lower, -points[i].cost.upper))  # type: ignore[union-attr]


def _queries(session: Any, mission: str, cost: str) -> tuple[Any, Any]:
    """Parse and check the two queries' shapes: ``<<C>> Pmax=? [ F G ]`` and
    ``<<C>> R{"c"}min=? [ ... ]`` for the same coalition."""
    from posgmc import api
    from posgmc.syntax.ast import Direction, ProbQuery, RewardQuery, Temporal, TemporalOp

    _, (m, c) = api.parse_properties(session, texts=[mission, cost])
    e = m.expr
    if not (isinstance(e, ProbQuery) and e.direction is Direction.MAX and e.threshold is None
            and isinstance(e.path, Temporal) and e.path.op is TemporalOp.EVENTUALLY
            and e.path.bound is None):
        raise UnsupportedError(
            f"the mission of a defence front is a coalition's unbounded reachability, got: "
            f"{mission}",
            hint="e.g. --prop '<<planner>> Pmax=? [ F \"retrieved\" ]'",
        )
    r = c.expr
    if not (isinstance(r, RewardQuery) and r.direction is Direction.MIN and r.threshold is None):
        raise UnsupportedError(
            f"the cost of a defence front is a coalition's minimised reward query, got: {cost}",
            hint='e.g. --cost \'<<planner>> R{"time"}min=? [ Fdiscount=0.95 "retrieved" ]\'')
    def players(q: Any) -> Any:
        return (
            None
            if q.coalition is None
            else (
                q.coalition.kind,
                q.coalition.all_players,
                tuple((p.name, p.number) for p in q.coalition.players),
            )
        )

    if players(r) != players(e):
        raise InputError("the mission and the cost must be about the same coalition",
                         hint="write the same <<player>> in both")
    return m, c


def _scalarised(model: Any, mission: Any, cost: Any, weight: float) -> tuple[Any, str]:
    """A copy of ``model`` with the reward ``cost - weight * P(enter G)`` and the cost query over
    it (as text)."""
    from posgmc.checking.states import evaluate_states
    from posgmc.model.explicit import RewardModel
    from posgmc.syntax.printer import format_expr

    target = np.asarray(evaluate_states(model, mission.expr.path.operands[0]), dtype=bool)
    base = model.reward_model(cost.expr.reward).choice_rewards(model.row_groups)
    entering = (model.transitions @ target.astype(np.float64)) * ~target[model.choice_states]
    reward = base - weight * entering
    scalar = dataclasses.replace(model, reward_models=model.reward_models
                                 + (RewardModel(SCALARISED_REWARD, choice=reward),))
    return scalar, format_expr(dataclasses.replace(cost.expr, reward=SCALARISED_REWARD))


def defence_front(
    path: str | Path,
    mission: str,
    cost: str,
    *,
    weights: Sequence[float],
    constants: Mapping[str, Any] | None = None,
    memory: int | Sequence[int] = 1,
    timeout: float | None = None,
    effort: float = 1.0,
    seed: int = 0,
    budgets: Sequence[float] = (),
    strategy_dir: str | Path | None = None,
    include_mission: bool = True,
    placement: Any = None,
) -> DefenceFront:
    """Synthesise one defence per weight and verify both objectives under each.

    Args:
        path: a posg or pomdp model.
        mission: ``<<C>> Pmax=? [ F G ]`` (G a state formula).
        cost: ``<<C>> R{"c"}min=? [ objective ]`` for the same coalition, an objective synthesis
            covers (``Fdiscount=γ t``, ``Cdiscount=γ``, ``F t``).
        weights: the scalarisation weights ``w >= 0`` (per unit of mission probability, in the
            cost's units).
        constants: the model's undefined constants.
        memory: the defence's memory size(s), as for :func:`posgmc.api.synthesize`.
        timeout: a wall-clock cap in seconds on each point's synthesis (None: none).
        effort: the multiplier of each synthesis's work budget (docs/synthesis.md).
        budgets: cost constraints ``c`` to answer from the verified points.
        strategy_dir: write each defence to ``<dir>/w=<w>/<player>.json`` and verify the file.
        include_mission: also synthesise for the mission query itself (``w = inf``).
        placement: where the weights' defences are synthesised and verified, each a task
            (:class:`~posgmc.synthesis.tasks.Placement`; default: one after the other here);
            the front does not depend on it.

    Returns:
        The :class:`DefenceFront`.

    Raises:
        PosgmcError: the model or a query is invalid, or outside what this covers.
    """
    from posgmc import api
    from posgmc.strategies.files import write_strategy
    from posgmc.synthesis.fanout import each_result
    from posgmc.synthesis.tasks import Placement

    start = time.perf_counter()
    ws = [float(w) for w in weights]
    if any(not (w >= 0) for w in ws):
        raise InputError(f"scalarisation weights are >= 0, got {list(weights)}")
    session = api.load(path, constants=dict(constants or {}))
    built = api.build(session)
    if not built.model.observations:
        raise UnsupportedError(f"{path}: not partially observable: a defence front synthesises "
                               "defences for a pomdp or posg",
                               hint="on an mdp use pareto --prop 'multi(...)'")
    m, c = _queries(session, mission, cost)
    full = _full_observation(session, built, m.text, c.text)
    points: list[DefencePoint] = []
    every = ws + ([math.inf] if include_mission else [])
    # each weight a task; the model's text travels (a cluster's nodes need not see the file)
    calls = [(str(path), session.source.text, dict(constants or {}), m.text, c.text, w, memory,
              timeout, effort, seed, strategy_dir is not None) for w in every]
    # this process's model serves the weights run here (and, forked, those of a local pool)
    _BUILT.clear()
    _BUILT[_model_key(str(path), session.source.text, dict(constants or {}))] = (session, built)
    results = each_result(front_point, calls, placement or Placement(),
                          labels=[f"w={_fmt_weight(w)}" for w in every])
    try:
        for done in results:
            if strategy_dir is not None and done.strategy is not None:
                done = _written(done, strategy_dir, write_strategy)
            points.append(done)
            progress.point_done(f"w={_fmt_weight(done.weight)}", done.mission, len(points),
                                len(every))
    finally:
        results.close()
        _BUILT.clear()
    front = pareto_indices(points)
    answers = tuple(_answer(session, built, m, c, points, float(b), strategy_dir, write_strategy)
                    for b in budgets)
    return DefenceFront(m.text, c.text, tuple(points), front, answers, full,
                        time.perf_counter() - start)


def _answer(session: Any, built: Any, mission: Any, cost: Any, points: Sequence[DefencePoint],
            budget: float, strategy_dir: str | Path | None, write: Any) -> BudgetAnswer:
    """The best single point under the budget and, when a mixture of a cheaper and a dearer
    verified point promises more mission within the budget, that mixture, verified."""
    from posgmc.strategies.mixture import mix

    pure = best_under(points, budget)
    ok = [i for i, p in enumerate(points) if p.verified]
    best: tuple[float, int, int, float] | None = None
    floor = -math.inf if pure is None else points[pure].mission.lower  # type: ignore[union-attr]
    for i in ok:
        for j in ok:
            pi, pj = points[i], points[j]
            assert pi.mission and pi.cost and pj.mission and pj.cost  # noqa: S101 - verified
            if not (
                pi.cost.upper <= budget < pj.cost.upper and pj.mission.lower > pi.mission.lower
            ):
                continue
            # leave room for the bounds' width: the mixture's own check has its own intervals
            margin = 1e-9 + (pi.cost.upper - pi.cost.lower) + (pj.cost.upper - pj.cost.lower)
            alpha = (budget - margin - pi.cost.upper) / (pj.cost.upper - pi.cost.upper)
            if alpha <= 0:
                continue
            promise = (1 - alpha) * pi.mission.lower + alpha * pj.mission.lower
            if promise > floor + 1e-9 and (best is None or promise > best[0]):
                best = (promise, i, j, alpha)
    pure_point = None if pure is None else points[pure]
    if best is None:
        return BudgetAnswer(budget, pure_point, pure)
    _, i, j, alpha = best
    mixed = mix(points[j].strategy, points[i].strategy, alpha)
    point = _verify(session, built, mission, cost, mixed, math.nan, strategy_dir,
                    f"budget={budget:g}", write, time.perf_counter(), partial=False)
    if point.verified and point.cost.upper <= budget and (  # type: ignore[union-attr]
            pure_point is None or point.mission.lower > pure_point.mission.lower):  # type: ignore[union-attr]
        return BudgetAnswer(budget, point, pure, (i, j, alpha))
    return BudgetAnswer(budget, pure_point, pure)


def _full_observation(
    session: Any, built: Any, mission: str, cost: str
) -> tuple[Bound | None, Bound | None]:
    from posgmc import api

    out: list[Bound | None] = []
    report = api.check(session, properties=[mission, cost], built=built, full_observation=True)
    for o in report.outcomes:
        if (
            isinstance(o, api.PropertyError)
            or o.value is None
            or o.lower is None
            or o.upper is None
        ):
            out.append(None)
        else:
            out.append(Bound(float(o.value), float(o.lower), float(o.upper), o.sound))
    return out[0], out[1]


_BUILT: dict[tuple[str, str, str], tuple[Any, Any]] = {}
"""This process's model of a front (session, built) by (path, text, constants): built once per
worker, whatever the number of weights it runs."""


def _model_key(path: str, text: str, constants: Mapping[str, Any]) -> tuple[str, str, str]:
    return path, text, repr(sorted(constants.items()))


def front_point(path: str, text: str, constants: dict[str, Any], mission: str, cost: str,
                weight: float, memory: Any, timeout: float | None, effort: float, seed: int,
                from_file: bool) -> DefencePoint:
    """One weight of :func:`defence_front`: its defence synthesised and both objectives verified
    under it (``from_file``: read back from a ``posgmc-fss/1`` file written to a temporary
    folder, as :func:`_written` then writes it where asked). Plain data in and out: a task on any
    executor."""
    import tempfile
    from contextlib import nullcontext

    from posgmc import api
    from posgmc.strategies.files import write_strategy

    key = _model_key(path, text, constants)
    if key not in _BUILT:
        session = api.load(path, text=text, constants=constants)
        _BUILT.clear()
        _BUILT[key] = (session, api.build(session))
    session, built = _BUILT[key]
    m, c = _queries(session, mission, cost)
    folder = tempfile.TemporaryDirectory(prefix="posgmc-front-") if from_file else nullcontext()
    with folder as where:
        point = _point(session, built, m, c, weight, memory=memory, timeout=timeout,
                       effort=effort, seed=seed, strategy_dir=where, write=write_strategy)
    return dataclasses.replace(point, strategy_file=None)


def _written(point: DefencePoint, strategy_dir: str | Path, write: Any) -> DefencePoint:
    """``point`` with its defence written to ``<strategy_dir>/w=<w>/<player>.json`` (the file
    its numbers were verified from, written again where asked)."""
    folder = os.path.join(str(strategy_dir), f"w={_fmt_weight(point.weight)}")
    os.makedirs(folder, exist_ok=True)
    where = os.path.join(folder, f"{point.strategy.player or 'agent'}.json")
    write(point.strategy, where)
    return dataclasses.replace(point, strategy_file=where)


def _point(session: Any, built: Any, mission: Any, cost: Any, weight: float, *, memory: Any,
           timeout: float | None, effort: float, seed: int, strategy_dir: str | Path | None,
           write: Any) -> DefencePoint:
    from posgmc import api

    t0 = time.perf_counter()
    try:
        if math.isinf(weight):
            result = api.synthesize(session, mission.text, memory=memory, timeout=timeout,
                                    effort=effort, seed=seed, built=built)
        else:
            model, text = _scalarised(built.model, mission, cost, weight)
            result = api.synthesize(api.Session.of_model(model, name=session.path), text,
                                    memory=memory, timeout=timeout, effort=effort, seed=seed)
    except PosgmcError as e:
        return DefencePoint(weight, None, None, seconds=time.perf_counter() - t0, error=e)
    return _verify(session, built, mission, cost, result.strategies[0], weight, strategy_dir,
                   f"w={_fmt_weight(weight)}", write, t0,
                   partial=bool(result.synthesis and result.synthesis.get("partial")))


def _verify(session: Any, built: Any, mission: Any, cost: Any, defence: Any, weight: float,
            strategy_dir: str | Path | None, folder_name: str, write: Any, t0: float, *,
            partial: bool) -> DefencePoint:
    """Both objectives under ``defence`` (from its file when ``strategy_dir`` is given), by the
    sound engines on the original model."""
    from posgmc import api

    try:
        given: Any = defence
        where = None
        if strategy_dir is not None:
            folder = os.path.join(str(strategy_dir), folder_name)
            os.makedirs(folder, exist_ok=True)
            where = os.path.join(folder, f"{defence.player or 'agent'}.json")
            write(defence, where)
            given = where  # verified from the file, as a user deploying it would
        report = api.check(session, properties=[mission.text, cost.text], built=built,
                           strategies={defence.player: given})
        numbers = []
        for o in report.outcomes:
            if isinstance(o, api.PropertyError):
                raise o.error
            numbers.append(o.guaranteed)
        return DefencePoint(weight, numbers[0], numbers[1], defence, where, defence.memory_size,
                            time.perf_counter() - t0, partial)
    except PosgmcError as e:
        return DefencePoint(weight, None, None, seconds=time.perf_counter() - t0, error=e)


def _fmt_weight(w: float) -> str:
    if math.isnan(w):
        return "mix"
    return "inf" if math.isinf(w) else repr(w).removesuffix(".0") if w == int(w) else repr(w)


def defence_front_to_csv(front: DefenceFront) -> str:
    """One row per point: ``weight, mission, mission_lower, mission_upper, cost, cost_lower,
    cost_upper, on_front, memory, partial, strategy, error`` (mission/cost: ``guaranteed``), then
    one ``budget`` row per constraint: its ``cost`` is the constraint ``c``, the other cells those
    of the defence that answers it (``cost_lower``/``cost_upper``: its proven cost; ``weight`` the
    point's weight, or ``mix(wj:alpha, wi)`` for the mixture playing the point of weight ``wj``
    with probability ``alpha``), or an error "no verified point meets it"."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["kind", "weight", "mission", "mission_lower", "mission_upper", "cost",
                "cost_lower", "cost_upper", "on_front", "memory", "partial", "strategy", "error"])
    for i, p in enumerate(front.points):
        cells = [""] * 6
        if p.mission is not None and p.cost is not None:
            cells = [repr(p.mission.value), repr(p.mission.lower), repr(p.mission.upper),
                     repr(p.cost.value), repr(p.cost.lower), repr(p.cost.upper)]
        w.writerow(["point", _fmt_weight(p.weight), *cells, i in front.front, p.memory,
                    p.partial, p.strategy_file or "", "" if p.error is None else p.error.message])
    for answer in front.budgets:
        q = answer.point
        if q is None or q.mission is None or q.cost is None:
            w.writerow(["budget", "", "", "", "", repr(answer.budget), "", "", "", "", "", "",
                        "no verified point meets it"])
            continue
        how = _fmt_weight(q.weight)
        if answer.mixed is not None:
            i, j, alpha = answer.mixed
            how = (f"mix({_fmt_weight(front.points[j].weight)}:{alpha!r}, "
                   f"{_fmt_weight(front.points[i].weight)})")
        w.writerow(["budget", how, repr(q.mission.value),
                    repr(q.mission.lower), repr(q.mission.upper), repr(answer.budget),
                    repr(q.cost.lower), repr(q.cost.upper), True, q.memory, q.partial,
                    q.strategy_file or "", ""])
    return out.getvalue()
