"""Synthesis of the decision maker's finite-state strategy against an omniscient adversary:
gradient ascent of `guaranteed` over randomised k-FSSs, memory escalation, verified results.

For each memory size k in turn (a memoryless warm-up first when k = 1 is not asked for): start
from (i) the best smaller defence embedded into k nodes (and perturbed copies), (ii) the
full-observation optimum projected onto the decision maker's observations (pessimistic QMDP,
then majority vote), (iii) seeded random logits; follow the exact (sub)gradient of the value against
the adversary's best response (:mod:`posgmc.synthesis.parametric`) with Adam; keep the best iterate
and its hardened (deterministic) version. Every candidate is then verified by the sound product
check (:class:`~posgmc.strategies.verify.StrategyChecker`), and the reported number is that check's
proven bound. A larger memory never reports a worse `guaranteed`: the best smaller defence,
embedded exactly (the extra nodes unreachable), is always among the candidates. Every phase's
extent is a count of its own units (:mod:`posgmc.synthesis.budget`), so a run is determined by
the model, the property, the options and the seed; a wall-clock cap (``timeout``) or an interrupt
may cut it short, and the result then says so (``cut``).
"""

from __future__ import annotations

import time
from contextlib import closing
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.checking.results import Bound
from posgmc.engines.graph import concat_ranges
from posgmc.engines.options import Method, SolverOptions
from posgmc.errors import InputError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax.ast import (
    Direction,
    Expr,
    ProbQuery,
    RewardKind,
    RewardQuery,
    Temporal,
    TemporalOp,
)
from posgmc.synthesis import belief, progress
from posgmc.synthesis.ascent import LOGIT, ascend
from posgmc.synthesis.budget import DEFAULT_UNITS, Clock
from posgmc.synthesis.deterministic import DeterministicResult, deterministic_phase
from posgmc.synthesis.executors import Executor, executor_for
from posgmc.synthesis.improvement import improvement_phase
from posgmc.synthesis.options import AUTO_MEMORY, SynthesisOptions
from posgmc.synthesis.parametric import ITERATIVE_STATES, Layout, Parametrisation
from posgmc.synthesis.problem import Problem, expired
from posgmc.synthesis.result import MemoryRound, SynthesisResult

__all__ = ["synthesize", "problem_of", "parametrisation"]

_POLICY = CheckOptions(solver=SolverOptions(method=Method.POLICY, prove=False))  # ranking only
_LOGIT = LOGIT


def _objective(model: ExplicitModel, expr: ProbQuery | RewardQuery, checker: PropertyChecker):  # type: ignore[no-untyped-def]
    """(target, remain, choice rewards or None, discount) of a supported objective."""
    if isinstance(expr, ProbQuery):
        path = expr.path
        if (
            isinstance(path, Temporal)
            and path.bound is None
            and path.op in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL)
        ):
            if path.op is TemporalOp.UNTIL:
                return (
                    checker._states(path.operands[1]),
                    checker._states(path.operands[0]),
                    None,
                    1.0,
                )
            return (
                checker._states(path.operands[0]),
                np.ones(model.num_states, dtype=bool),
                None,
                1.0,
            )
    if isinstance(expr, RewardQuery) and expr.objective.kind is RewardKind.DISCOUNTED_TOTAL:
        # R[Cdiscount=g]: x = r + g P x everywhere (a target that is never reached)
        rewards = model.reward_model(expr.reward).choice_rewards(model.row_groups)
        never = np.zeros(model.num_states, dtype=bool)
        return never, ~never, rewards, checker._discount(expr.objective.discount)
    if isinstance(expr, RewardQuery) and expr.objective.kind in (RewardKind.DISCOUNTED_REACH,
                                                                  RewardKind.REACH):
        assert expr.objective.target is not None  # noqa: S101 - F and Fdiscount have a target
        rewards = model.reward_model(expr.reward).choice_rewards(model.row_groups)
        discount = (1.0 if expr.objective.kind is RewardKind.REACH
                    else checker._discount(expr.objective.discount))
        return (checker._states(expr.objective.target), np.ones(model.num_states, dtype=bool),
                rewards, discount)
    raise UnsupportedError(
        "synthesis supports <<d>> Pmax/Pmin=? of F b, a U b and co-safe LTL (step bounds "
        "included), the expected reward <<d>> R{\"c\"}min/max=? [ F b ] or until a co-safe "
        "formula, and the discounted costs R[ Fdiscount=g b ] and R[ Cdiscount=g ]",
        expr.span,
        hint="check other objectives under a given strategy (--strategy PLAYER=FILE)",
    )


def synthesize(
    model: ExplicitModel,
    expr: Expr,
    *,
    player: int,
    coalition_of: CoalitionResolver,
    scalar: ScalarEvaluator,
    options: SynthesisOptions = SynthesisOptions(),
    check_options: CheckOptions = CheckOptions(),
    executor: Executor | None = None,
) -> SynthesisResult:
    """A finite-state strategy for ``player`` (the property's coalition) and what it guarantees.

    Candidates are compared by policy iteration on their products (exact linear solves); the
    chosen one is checked again with ``check_options`` (by default sound interval iteration),
    and that check's bounds are the reported ``guaranteed``.

    Raises:
        UnsupportedError: an objective other than unbounded reachability, or a coalition of
            several players.
    """
    now = time.perf_counter()
    started = now if options.started is None else min(options.started, now)
    clock = Clock(started, options.timeout)
    effort = options.budget
    end = clock.end
    deadline = end  # the search's; a pomdp keeps a share of the cap for the belief phase
    if executor is None:
        others = [p for p in range(len(model.player_names)) if p != player]
        problem = problem_of(
            model,
            expr,
            player=player,
            adversary=others[0] if len(others) == 1 else None,
            coalition_of=coalition_of,
            scalar=scalar,
        )
        with closing(executor_for(problem, options.placement)) as own:
            return synthesize(model, expr, player=player, coalition_of=coalition_of,
                              scalar=scalar, options=options, check_options=check_options,
                              executor=own)
    problem = executor.problem
    with_belief = bool(options.belief if options.belief is not None
                       else options.memory == AUTO_MEMORY) and belief.applies(problem)
    if with_belief:
        deadline = clock.at(1.0 - belief.SHARE)
    # the full-observation solve stops at the search's deadline too (its bounds stay proven)
    base = PropertyChecker(model, coalition_of=coalition_of, scalar=scalar,
                           options=CheckOptions(keep_strategy=True,
                                                solver=SolverOptions(deadline=deadline)))
    query = problem.query
    direction = query.direction
    target, remain, rewards, discount = (
        problem.target,
        problem.remain,
        problem.rewards,
        problem.discount,
    )
    maximize = direction is Direction.MAX
    sign = 1.0 if maximize else -1.0
    phases: dict[str, float] = {}

    t0 = time.perf_counter()
    progress.report("full observation")
    full = base.query(query, everywhere=False)
    init = model.initial_states[0]
    full_bound = Bound(
        float(full.values[init]), float(full.lower[init]), float(full.upper[init]),
        full.sound and full.converged, full.converged,
    )
    phases["full observation"] = time.perf_counter() - t0
    # observation-level policy iteration over deterministic FSSs first (cheap: a few value
    # iterations per size; it carries directed moves and the value of gathering information into
    # the start, where the projections below leave them tied), then the direct search over
    # deterministic FSSs (abstraction refinement, its share of the budget): their best defences
    # per memory size join that size's candidates and starts
    t0 = time.perf_counter()
    progress.report("policy iteration (observations)")
    improved_det = improvement_phase(
        executor, _with_warm_up(options.memory), deadline,
        rounds=effort.default("improvement_rounds"),
    )
    phases["policy iteration (observations)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    share = (
        DEFAULT_UNITS["families"] if executor.problem.adversary is not None
        else DETERMINISTIC_FAMILIES_POMDP
    )
    if share > 0:
        progress.report("deterministic search", done=0, total=effort.units(share),
                        unit="families")
    deterministic = deterministic_phase(
        executor, options.memory, deadline, families=effort.units(share),
        seeds=tuple(improved_det.values()),
    ) if share > 0 else {}
    phases["deterministic search"] = time.perf_counter() - t0

    verifier = StrategyChecker  # built per candidate (its products are cached per checker)
    rng = np.random.default_rng(options.seed)
    best: tuple[FiniteStateStrategy, Bound] | None = None
    best_logits: tuple[np.ndarray, np.ndarray] | None = None
    evaluations = 0
    t_search = t_verify = 0.0
    # pass 0 tries every memory size from the projected full-observation strategy (and the best
    # smaller one, embedded); later passes restart each size from new random points (and the best
    # so far) for as long as a pass improves the best, at most ``passes`` (the work budget)
    params: dict[int, Parametrisation] = {}
    best_of: dict[int, tuple[FiniteStateStrategy, Bound]] = {}
    seconds_of: dict[int, float] = {}
    evaluations_of: dict[int, int] = {}
    # a memory range that does not start at 1 is warm-started from a memoryless defence (a k-FSS
    # embeds into k+1 nodes): --memory 2 searches k = 1 first and never reports less than it
    sizes = _with_warm_up(options.memory)
    passes = effort.default("passes")
    for pass_no in range(passes):
        improved = False
        for i, k in enumerate(sizes):
            if expired(deadline) and best is not None:
                break
            progress.report("gradient search", memory=k, done=pass_no * len(sizes) + i,
                            total=passes * len(sizes), unit="round")
            round_start = time.perf_counter()
            if k not in params:
                params[k] = Parametrisation(model, player, k, query, target, remain,
                                            coalition_of=coalition_of, scalar=scalar,
                                            rewards=rewards, discount=discount)
            par = params[k]
            # the best smaller defence first (when the round's time runs out, the starts that
            # build on what is known have run), then the full-observation optimum projected
            # two ways (pessimistic QMDP, majority vote), then random logits
            starts = []
            # the deterministic defences (policy iteration's, the deterministic search's), the
            # better first, first of all
            seeded = [] if pass_no else _distinct(sorted(
                (r for r in (improved_det.get(k), deterministic.get(k)) if r is not None),
                key=lambda r: -sign * r.value))
            for found_det in seeded:
                starts.append(_hard_logits(found_det.gamma, found_det.delta))
            if best_logits is not None and best is not None and best[0].memory_size <= k:
                la0, ld0 = _embedded(par, *best_logits)
                starts.append((la0, ld0))
                if best[0].memory_size < k:
                    # the embedding is a stationary point of the larger space (the new nodes
                    # copy node 0): perturbed copies let the nodes specialise
                    for _ in range(2):
                        starts.append((la0 + rng.normal(size=la0.shape),
                                       ld0 + 2.0 * rng.normal(size=ld0.shape)))
            if pass_no == 0:
                starts.append(_qmdp(par, full, model, rewards, discount, sign))
                starts.append(_projected(par, full, model))
            for _ in range(effort.units(options.restarts)):
                starts.append((rng.normal(size=par.shapes[0]), rng.normal(size=par.shapes[1])))
            found, n_eval, seconds = _round(
                par,
                starts,
                sign,
                options,
                deadline,
                executor,
                model,
                query,
                coalition_of,
                scalar,
                maximize,
                extra=tuple((r.gamma, r.delta) for r in seeded),
            )
            evaluations += n_eval
            t_search += seconds[0]
            t_verify += seconds[1]
            if found is not None and (best is None or _better(found[1], best[1], maximize)):
                best = (found[0], found[1])
                best_logits = found[2]
                improved = True
                progress.report("gradient search", memory=k, best=found[1].value)
            # else the smaller defence stays: embedded into k nodes (_embed_strategy) it
            # guarantees exactly as much, so k never does worse; the smaller one is reported
            if found is not None and (
                k not in best_of or _better(found[1], best_of[k][1], maximize)
            ):
                best_of[k] = (found[0], found[1])
            seconds_of[k] = seconds_of.get(k, 0.0) + time.perf_counter() - round_start
            evaluations_of[k] = evaluations
        if expired(deadline) or not improved:
            break
    # the deterministic defences of the memory sizes the gradient rounds never reached
    for k, found_det in sorted([*improved_det.items(), *deterministic.items()],
                               key=lambda kr: (kr[0], -sign * kr[1].value)):
        if k in best_of:
            continue
        fss = params[k].strategy(found_det.gamma, found_det.delta) if k in params else \
            Parametrisation(model, player, k, query, target, remain, coalition_of=coalition_of,
                            scalar=scalar, rewards=rewards, discount=discount
                            ).strategy(found_det.gamma, found_det.delta)
        bound = StrategyChecker(model, {fss.player: fss}, coalition_of=coalition_of, scalar=scalar,
                                options=_POLICY).check(query, text="synthesis").guaranteed
        assert bound is not None  # noqa: S101 - the decision maker's strategy is given
        best_of[k] = (fss, bound)
        seconds_of[k], evaluations_of[k] = 0.0, evaluations
        if best is None or _better(bound, best[1], maximize):
            best = (fss, bound)
    # a pomdp: the belief-based controller handing over to the best defence at its frontier
    # (:mod:`posgmc.synthesis.belief`), kept when its product check beats the best
    belief_result = None
    if with_belief and best is not None:
        t0 = time.perf_counter()
        progress.report("belief exploration")
        belief_result = _belief_candidate(problem, best[0], end, model, query, coalition_of,
                                          scalar, maximize, effort.default("belief_nodes"))
        if belief_result is not None and _better(belief_result[1], best[1], maximize):
            best = belief_result
        phases["belief exploration"] = time.perf_counter() - t0
    # per memory size: the best defence with at most that many nodes (a smaller one embeds)
    rounds = []
    upto: tuple[FiniteStateStrategy, Bound] | None = None
    for k in sizes:
        if k not in best_of:
            continue
        if upto is None or _better(best_of[k][1], upto[1], maximize):
            upto = best_of[k]
        rounds.append(MemoryRound(k, upto[1], upto[0].is_deterministic, evaluations_of[k],
                                  seconds_of[k]))
    phases["gradient search"] = t_search
    phases["candidates (policy iteration)"] = t_verify
    assert best is not None  # noqa: S101 - the first memory size always runs
    if best[0].memory_size < min(options.memory):
        # the warm-up's defence won: report it with the memory asked for (the new nodes are
        # never entered, so it guarantees exactly as much)
        best = (_embed_strategy(best[0], min(options.memory)), best[1])
    # the reported number: the chosen defence checked by the caller's method (sound interval
    # iteration by default). Policy iteration ranked the candidates, but its floating-point
    # solves of nearly singular systems are no proof (it can exceed the full-observation value
    # by ~1e-9), so it is never what is reported
    t0 = time.perf_counter()
    progress.report("verification")
    final = verifier(model, {best[0].player: best[0]}, coalition_of=coalition_of, scalar=scalar,
                     options=check_options).check(query, text="synthesis")
    phases["verification"] = time.perf_counter() - t0
    assert final.guaranteed is not None  # noqa: S101 - the decision maker's strategy is given
    guaranteed, method = final.guaranteed, final.method
    # what cut the budget short, if anything: the cap or an interrupt (seen by every phase as an
    # expired deadline); a check stopped by the caller's deadline (check_options) proves wider
    # bounds
    cut = clock.cut()
    partial = cut is not None or not final.converged
    return SynthesisResult(best[0], guaranteed, full_bound, tuple(rounds), partial, phases, method,
                           tuple(deterministic[k] for k in sorted(deterministic)), cut)


def _belief_candidate(problem: Problem, cutoff: FiniteStateStrategy, end: float | None,
                      model: ExplicitModel, query: Expr, coalition_of: CoalitionResolver,
                      scalar: ScalarEvaluator, maximize: bool, nodes: int,
                      ) -> tuple[FiniteStateStrategy, Bound] | None:
    """The belief-based controller over ``cutoff`` (at most ``nodes`` belief nodes explored) and
    its bound by policy iteration on its product (a ranking, like every candidate's), or None."""
    # under a cap the controller is built with a fifth of what is left to spare: its product is
    # checked after
    now = time.perf_counter()
    found = belief.belief_phase(problem, cutoff,
                                None if end is None else now + 0.8 * max(0.0, end - now),
                                explore=nodes)
    if found is None:
        return None
    r = StrategyChecker(model, {found.strategy.player: found.strategy}, coalition_of=coalition_of,
                        scalar=scalar, options=_POLICY).check(query, text="synthesis")
    assert r.guaranteed is not None  # noqa: S101 - the decision maker's strategy is given
    return found.strategy, r.guaranteed


DETERMINISTIC_FAMILIES_POMDP = 0
"""The deterministic search's families on a pomdp: none (in a game, PAYNT's POSMG setting where
deterministic FSSs did best, ``DEFAULT_UNITS["families"]``). On a pomdp the gradient search
alone reached at least PAYNT's value on every shared POMDP (docs/performance.md), and the
deterministic search's best on refuel-06, 0.3500 (PAYNT's), is below the gradient search's."""


def _distinct(found: list[DeterministicResult]) -> list[DeterministicResult]:
    """``found`` without repeats of a strategy (the deterministic search returns its incumbent,
    policy iteration's defence, when it finds nothing better)."""
    kept: list[DeterministicResult] = []
    for r in found:
        if not any(np.array_equal(r.gamma, o.gamma) and np.array_equal(r.delta, o.delta)
                   for o in kept):
            kept.append(r)
    return kept


def _with_warm_up(memory: tuple[int, ...]) -> tuple[int, ...]:
    """The memory sizes searched for ``memory``: a memoryless warm-up first when the smallest
    size asked for is larger (its defence embeds into every larger size)."""
    return memory if min(memory) <= 1 else (1,) + tuple(memory)




def _round(
    par: Parametrisation,
    starts: list[tuple[np.ndarray, np.ndarray]],
    sign: float,
    options: SynthesisOptions,
    deadline: float | None,
    executor: Executor,
    model: ExplicitModel,
    query: Expr,
    coalition_of: CoalitionResolver,
    scalar: ScalarEvaluator,
    maximize: bool,
    extra: tuple[tuple[np.ndarray, np.ndarray], ...] = (),
) -> tuple[
    tuple[FiniteStateStrategy, Bound, tuple[np.ndarray, np.ndarray]] | None,
    int,
    tuple[float, float],
]:
    """Gradient ascent from each start, a local search around the best deterministic candidate,
    the ``extra`` candidates (the deterministic search's, as γ and δ), and the most promising
    candidates checked by policy iteration on their products. Returns the
    best (strategy, its bound, its logits), the number of evaluations and (search, check)
    seconds."""
    evaluations = 0
    t0 = time.perf_counter()
    candidates: list[tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]] = []
    # the starts are independent jobs (run in parallel with --jobs); each begins without a warm
    # start, so the results do not depend on where or in which order they run
    budget = options.budget
    jobs = [AscendJob(par.k, la, ld, budget.units(options.iterations), options.learning_rate,
                      deadline) for la, ld in starts]
    for i, ((la, ld), n_eval) in enumerate(executor.map(jobs)):
        if i and not n_eval:
            continue  # the budget ran out before this start moved
        evaluations += n_eval
        g, d = par.probabilities(la, ld)
        candidates.append((*par.sharpened(g, d), (la, ld)))
        candidates.append((*par.hardened(g, d), (la, ld)))
        candidates.append((g, d, (la, ld)))
    # each candidate's float value, computed once (on a large model each is a cold iterative
    # solve: a hardened or sharpened candidate's product has its own structure)
    floats: dict[int, float] = {}

    def value_of(c: tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]) -> float:
        if id(c) not in floats:
            floats[id(c)] = sign * par.evaluate(c[0], c[1], gradient=False).value
        return floats[id(c)]

    large = model.num_states * par.k >= ITERATIVE_STATES
    # deterministic neighbours of the best hardened candidate: one rule changed at a time (not on
    # a large model, where each neighbour costs a full evaluation and thousands of rules exist)
    hard = candidates[1::3]
    if hard and not large and not expired(deadline):
        g, d, logits = max(hard, key=value_of)
        (g, d), n_eval = _local_search(par, g, d, sign, deadline,
                                       budget.default("local_steps"))
        evaluations += n_eval
        candidates.append((g, d, logits))
    for g, d in extra:
        candidates.append((g, d, _hard_logits(g, d)))
    t_search = time.perf_counter() - t0
    # verify the most promising candidates (by their float value) with policy iteration; rounded
    # to 1e-7, so that on a near-tie the stable sort keeps the sharpened (or deterministic)
    # version, which is simpler and verified far faster than the softmax's near-deterministic one
    t0 = time.perf_counter()
    scored = sorted(candidates, key=lambda c: round(-value_of(c), 7))
    best: tuple[FiniteStateStrategy, Bound, tuple[np.ndarray, np.ndarray]] | None = None
    # on a large model one candidate only: a policy-iteration check of its product costs LU
    # factorisations of 10^5 unknowns (seconds each), and the float ranking rarely errs
    for g, d, logits in scored[: 1 if large else options.verify]:
        if best is not None and expired(deadline):
            break  # the most promising candidate is checked; the rest only within the cap
        fss = par.strategy(g, d)
        r = StrategyChecker(model, {fss.player: fss}, coalition_of=coalition_of, scalar=scalar,
                            options=_POLICY).check(query, text="synthesis")
        bound = r.guaranteed
        assert bound is not None  # noqa: S101 - the decision maker's strategy is given
        if best is None or _better(bound, best[1], maximize):
            best = (fss, bound, logits)
    return best, evaluations, (t_search, time.perf_counter() - t0)


def _better(a: Bound, b: Bound, maximize: bool) -> bool:
    """Whether ``a`` proves more than ``b`` (a higher lower bound for max, a lower upper bound for
    min) by more than the numerical noise of the candidates' checks (1e-9 relative): a larger
    memory that only gains noise does not replace a smaller strategy."""
    margin = 1e-9 * max(1.0, abs(b.value)) if np.isfinite(b.value) else 0.0
    return a.lower > b.lower + margin if maximize else a.upper < b.upper - margin


@dataclass(frozen=True, eq=False)
class AscendJob:
    """One start of the gradient search against the omniscient adversary: the defence's memory
    size, the start logits, Adam's settings and the deadline. ``run`` returns the best iterate's
    logits and the number of evaluations."""

    PHASE: ClassVar[str] = "gradient search"

    memory: int
    logits_action: np.ndarray
    logits_update: np.ndarray
    iterations: int
    learning_rate: float
    deadline: float | None

    def run(self, problem: Problem) -> tuple[tuple[np.ndarray, np.ndarray], int]:
        par = parametrisation(problem, self.memory)
        sign = problem.sign

        def step(a: np.ndarray, d: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
            g, dd = par.probabilities(a, d)
            ev = par.evaluate(g, dd)
            ga, gd = par.logit_gradient(ev, g, dd)
            return sign * ev.value, sign * ga, sign * gd

        best, _, n = ascend(step, self.logits_action, self.logits_update,
                            iterations=self.iterations, learning_rate=self.learning_rate,
                            deadline=self.deadline)
        return best, n


def parametrisation(problem: Problem, memory: int) -> Parametrisation:
    """The decision maker's k-node FSSs against the omniscient adversary of ``problem``."""
    return Parametrisation(problem.model, problem.player, memory, problem.query, problem.target,
                           problem.remain, coalition_of=problem.coalition_of,
                           scalar=problem.scalar, rewards=problem.rewards,
                           discount=problem.discount)


def problem_of(model: ExplicitModel, expr: Expr, *, player: int, adversary: int | None,
               coalition_of: CoalitionResolver, scalar: ScalarEvaluator) -> Problem:
    """The picklable description of synthesising ``player``'s strategy for ``expr`` (a P or R
    query with min or max).

    Raises:
        UnsupportedError: a threshold, or an objective synthesis does not cover.
    """
    if not isinstance(expr, (ProbQuery, RewardQuery)) or expr.threshold is not None:
        raise UnsupportedError("synthesis takes one P or R query with min or max (=?)", expr.span,
                               hint="write <<player>> Pmax=? [ F \"goal\" ]")
    if not Layout.of(model, player).used_obs.size:
        name = model.player_names[player] if model.player_names else "the agent"
        raise InputError(
            f"player {name!r} never has a move: none of its actions is enabled in any state, so "
            "there is no strategy to synthesise",
            expr.span,
            hint="its value is that of the other players' choices alone: check the property with "
            "--full-observation, or give the coalition to a player that moves",
        )
    base = PropertyChecker(model, coalition_of=coalition_of, scalar=scalar)
    query = replace(expr, direction=base.direction_of(expr))
    target, remain, rewards, discount = _objective(model, query, base)
    coalition = coalition_of(query.coalition)
    return Problem(model, query, player, adversary,
                   frozenset() if coalition is None else frozenset(coalition),
                   target, remain, rewards, float(discount), scalar)


def _local_search(par: Parametrisation, gamma: np.ndarray, delta: np.ndarray, sign: float,
                  deadline: float | None, steps: int,
                  ) -> tuple[tuple[np.ndarray, np.ndarray], int]:
    """First-improvement search over deterministic FSSs: change one rule's action (or next node)
    at a time, keep a change that improves the value, until no change improves, ``steps``
    evaluations were made or the deadline passes."""
    value = sign * par.evaluate(gamma, delta, gradient=False).value
    n, improved = 1, True
    k, Zu, Au = gamma.shape
    while improved and n < steps and not expired(deadline):
        improved = False
        for node in range(k):
            for z in range(Zu):
                a_now = int(gamma[node, z].argmax())
                m_now = int(delta[node, z, a_now].argmax())
                for a in np.flatnonzero(par.mask[z]).tolist():
                    for m in range(k):
                        if (a, m) == (a_now, m_now) or n >= steps or expired(deadline):
                            continue
                        g2, d2 = gamma.copy(), delta.copy()
                        g2[node, z] = 0.0
                        g2[node, z, a] = 1.0
                        d2[node, z, a] = 0.0
                        d2[node, z, a, m] = 1.0
                        v = sign * par.evaluate(g2, d2, gradient=False).value
                        n += 1
                        if v > value + 1e-12:
                            gamma, delta, value, improved = g2, d2, v, True
                            a_now, m_now = a, m
    return (gamma, delta), n


def _projected(par: Parametrisation, full, model: ExplicitModel) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """Logits favouring, in each observation, the action the full-observation optimum plays most
    often in the decision maker's states with that observation; memory stays put."""
    la = np.zeros(par.shapes[0])
    strategy = full.engine.strategy if full.engine is not None else None
    if strategy is not None:
        states = np.flatnonzero(par.owned & (strategy >= 0))
        z = par.obs_index[par.view.state_obs[states]]
        a = par.act_index[model.choice_actions[strategy[states]]]
        votes = np.zeros(par.shapes[0][1:])
        np.add.at(votes, (z, a), 1.0)
        best = votes.argmax(axis=1)
        has = votes.max(axis=1) > 0
        la[:, np.flatnonzero(has), best[has]] = _LOGIT
    ld = np.zeros(par.shapes[1])
    k = par.k
    ld[np.arange(k), :, :, np.arange(k)] = _LOGIT
    return la, ld


def _qmdp(par: Parametrisation, full, model: ExplicitModel, rewards: np.ndarray | None,  # type: ignore[no-untyped-def]
          discount: float, sign: float) -> tuple[np.ndarray, np.ndarray]:
    """Logits favouring, in each observation, the actions whose full-observation Q-value is best
    in the worst of the decision maker's states with that observation (a pessimistic QMDP: as if
    the state were revealed after this step, and the state the observation hides were the least
    favourable one); every action within 1e-9 of the best is favoured alike; memory stays put.

    Where :func:`_projected` lets each state vote for its own optimal action (with full
    observation the planner never gathers information, so that vote says "act now" everywhere),
    the worst case over an observation's states refuses an action that is fatal in one of them:
    information-gathering moves win until the observation pins the state down."""
    la = np.zeros(par.shapes[0])
    values = np.asarray(full.values, dtype=np.float64)
    finite = np.isfinite(values)
    big = 10.0 * (float(np.abs(values[finite]).max(initial=0.0)) + 1.0)
    values = np.where(finite, values, np.copysign(big, values))
    states = np.flatnonzero(par.owned)
    c = concat_ranges(model.row_groups[states], model.row_groups[states + 1])
    q = discount * np.asarray(model.transitions[c] @ values).ravel()
    if rewards is not None:
        q = q + rewards[c]
    z = par.obs_index[par.view.state_obs[model.choice_states[c]]]
    a = par.act_index[model.choice_actions[c]]
    worst = np.full(par.shapes[0][1:], np.inf)
    np.minimum.at(worst, (z, a), sign * q)
    score = np.where(par.mask & np.isfinite(worst), worst, -np.inf)
    top = score.max(axis=1, keepdims=True)
    has = np.isfinite(top[:, 0])
    favoured = (
        has[:, None] & np.isfinite(score) & (score >= top - 1e-9 * np.maximum(1.0, np.abs(top)))
    )
    la[:, favoured] = _LOGIT
    ld = np.zeros(par.shapes[1])
    k = par.k
    ld[np.arange(k), :, :, np.arange(k)] = _LOGIT
    return la, ld


def _hard_logits(gamma: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Logits of a deterministic FSS: +LOGIT on its choices, -LOGIT elsewhere."""
    return np.where(gamma > 0, _LOGIT, -_LOGIT), np.where(delta > 0, _LOGIT, -_LOGIT)


def _embedded(
    par: Parametrisation, la: np.ndarray, ld: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Smaller logits extended by nodes copying node 0 and rarely entered."""
    k0, k = la.shape[0], par.k
    new_a = np.concatenate([la, np.repeat(la[:1], k - k0, axis=0)], axis=0)
    new_d = np.full(par.shapes[1], -_LOGIT)
    new_d[:k0, :, :, :k0] = ld
    new_d[k0:, :, :, :k0] = ld[:1]
    return new_a, new_d


def _embed_strategy(fss: FiniteStateStrategy, k: int) -> FiniteStateStrategy:
    """The same strategy with k >= its memory nodes; the new nodes are never entered (their rules
    copy node 0), so every number about it is unchanged."""
    k0 = fss.memory_size
    if k == k0:
        return fss
    action = np.concatenate([fss.action, np.repeat(fss.action[:1], k - k0, axis=0)], axis=0)
    update = np.zeros(action.shape + (k,))
    update[:k0, :, :, :k0] = fss.update
    update[k0:, :, :, :k0] = fss.update[:1]
    return FiniteStateStrategy.from_arrays(
        player=fss.player, observables=fss.observables, observation_values=fss.observation_values,
        actions=fss.actions, action=action, update=update * (action[..., None] > 0),
        initial_memory=fss.initial_memory,
    )
