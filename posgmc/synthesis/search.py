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
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from posgmc.checking.intervals import QueryValue
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
    and that check's bounds are the reported ``guaranteed``. The phases, in order: the
    full-observation solve, the deterministic phases (policy iteration over observations, the
    deterministic search), the gradient rounds per memory size, the deterministic defences of the
    sizes those rounds never reached, the belief controller (a pomdp), the verification.

    Raises:
        UnsupportedError: an objective other than unbounded reachability, or a coalition of
            several players.
    """
    now = time.perf_counter()
    started = now if options.started is None else min(options.started, now)
    clock = Clock(started, options.timeout)
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
    run = _search_run(model, player=player, coalition_of=coalition_of, scalar=scalar,
                      options=options, check_options=check_options, executor=executor,
                      clock=clock)
    phases: dict[str, float] = {}
    full, full_bound = _full_observation_phase(run, phases)
    seeds = _deterministic_phases(run, phases)
    search = _gradient_phase(run, full, seeds)
    best = _unreached_sizes(run, seeds, search)
    best = _belief_phase(run, best, phases)
    rounds = _memory_rounds(run, search)
    phases["gradient search"] = search.t_search
    phases["candidates (policy iteration)"] = search.t_verify
    final = _verification_phase(run, best, phases)
    # what cut the budget short, if anything: the cap or an interrupt (seen by every phase as an
    # expired deadline); a check stopped by the caller's deadline (check_options) proves wider
    # bounds
    cut = clock.cut()
    partial = cut is not None or not final.converged
    return SynthesisResult(
        final.strategy, final.guaranteed, full_bound, rounds, partial, phases, final.method,
        tuple(seeds.deterministic[k] for k in sorted(seeds.deterministic)), cut)


# --- the phases of :func:`synthesize` ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _SearchRun:
    """What every phase of one synthesis reads: the model, the problem (from the executor), the
    caller's resolvers and options, the work budget's clock and the search's deadline (a pomdp
    keeps a share of a wall-clock cap for the belief phase)."""

    model: ExplicitModel
    problem: Problem
    player: int
    coalition_of: CoalitionResolver
    scalar: ScalarEvaluator
    options: SynthesisOptions
    check_options: CheckOptions
    executor: Executor
    clock: Clock
    deadline: float | None
    with_belief: bool

    @property
    def query(self) -> ProbQuery | RewardQuery:
        return self.problem.query

    @property
    def maximize(self) -> bool:
        return self.problem.query.direction is Direction.MAX

    @property
    def sign(self) -> float:
        return 1.0 if self.maximize else -1.0

    def parametrisation(self, k: int) -> Parametrisation:
        """The decision maker's k-node FSSs (with the caller's resolvers)."""
        p = self.problem
        return Parametrisation(self.model, self.player, k, p.query, p.target, p.remain,
                               coalition_of=self.coalition_of, scalar=self.scalar,
                               rewards=p.rewards, discount=p.discount)

    def ranked(self, fss: FiniteStateStrategy) -> Bound:
        """``fss``'s bound by policy iteration on its product (a ranking, not a proof)."""
        bound = StrategyChecker(self.model, {fss.player: fss}, coalition_of=self.coalition_of,
                                scalar=self.scalar, options=_POLICY
                                ).check(self.query, text="synthesis").guaranteed
        assert bound is not None  # noqa: S101 - the decision maker's strategy is given
        return bound


def _search_run(model: ExplicitModel, *, player: int, coalition_of: CoalitionResolver,
                scalar: ScalarEvaluator, options: SynthesisOptions, check_options: CheckOptions,
                executor: Executor, clock: Clock) -> _SearchRun:
    """The run's record; with the belief phase to come, the search ends at its share of the
    cap."""
    problem = executor.problem
    with_belief = bool(options.belief if options.belief is not None
                       else options.memory == AUTO_MEMORY) and belief.applies(problem)
    deadline = clock.at(1.0 - belief.SHARE) if with_belief else clock.end
    return _SearchRun(model, problem, player, coalition_of, scalar, options, check_options,
                      executor, clock, deadline, with_belief)


def _full_observation_phase(run: _SearchRun, phases: dict[str, float],
                            ) -> tuple[QueryValue, Bound]:
    """The full-observation optimum (its strategy kept for the projected starts) and its bound
    at the initial state; it stops at the search's deadline too (its bounds stay proven)."""
    base = PropertyChecker(run.model, coalition_of=run.coalition_of, scalar=run.scalar,
                           options=CheckOptions(keep_strategy=True,
                                                solver=SolverOptions(deadline=run.deadline)))
    t0 = time.perf_counter()
    progress.report("full observation")
    full = base.query(run.query, everywhere=False)
    init = run.model.initial_states[0]
    full_bound = Bound(
        float(full.values[init]), float(full.lower[init]), float(full.upper[init]),
        full.sound and full.converged, full.converged,
    )
    phases["full observation"] = time.perf_counter() - t0
    return full, full_bound


@dataclass(frozen=True)
class _DeterministicSeeds:
    """The deterministic phases' best defences per memory size: policy iteration over
    observations' (``improved``) and the deterministic search's (``deterministic``)."""

    improved: dict[int, DeterministicResult]
    deterministic: dict[int, DeterministicResult]


def _deterministic_phases(run: _SearchRun, phases: dict[str, float]) -> _DeterministicSeeds:
    """Observation-level policy iteration over deterministic FSSs first (cheap: a few value
    iterations per size; it carries directed moves and the value of gathering information into
    the start, where the projections leave them tied), then the direct search over deterministic
    FSSs (abstraction refinement, its share of the budget): their best defences per memory size
    join that size's candidates and starts."""
    options, effort, executor = run.options, run.options.budget, run.executor
    t0 = time.perf_counter()
    progress.report("policy iteration (observations)")
    improved = improvement_phase(
        executor, _with_warm_up(options.memory), run.deadline,
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
        executor, options.memory, run.deadline, families=effort.units(share),
        seeds=tuple(improved.values()),
    ) if share > 0 else {}
    phases["deterministic search"] = time.perf_counter() - t0
    return _DeterministicSeeds(improved, deterministic)


@dataclass(eq=False)
class _GradientSearch:
    """The gradient rounds' state as they go: the best defence overall (with its logits), the
    best per memory size, the parametrisations built, and per size the seconds spent and the
    evaluations made so far; the search and candidate-check seconds."""

    best: tuple[FiniteStateStrategy, Bound] | None = None
    best_logits: tuple[np.ndarray, np.ndarray] | None = None
    params: dict[int, Parametrisation] = field(default_factory=dict)
    best_of: dict[int, tuple[FiniteStateStrategy, Bound]] = field(default_factory=dict)
    seconds_of: dict[int, float] = field(default_factory=dict)
    evaluations_of: dict[int, int] = field(default_factory=dict)
    evaluations: int = 0
    t_search: float = 0.0
    t_verify: float = 0.0


def _gradient_phase(run: _SearchRun, full: QueryValue, seeds: _DeterministicSeeds,
                    ) -> _GradientSearch:
    """The gradient rounds. Pass 0 tries every memory size from the projected full-observation
    strategy (and the best smaller one, embedded); later passes restart each size from new random
    points (and the best so far) for as long as a pass improves the best, at most ``passes`` (the
    work budget). A memory range that does not start at 1 is warm-started from a memoryless
    defence (a k-FSS embeds into k+1 nodes): --memory 2 searches k = 1 first and never reports
    less than it."""
    rng = np.random.default_rng(run.options.seed)
    search = _GradientSearch()
    sizes = _with_warm_up(run.options.memory)
    passes = run.options.budget.default("passes")
    for pass_no in range(passes):
        improved = False
        for i, k in enumerate(sizes):
            if expired(run.deadline) and search.best is not None:
                break
            progress.report("gradient search", memory=k, done=pass_no * len(sizes) + i,
                            total=passes * len(sizes), unit="round")
            improved = _gradient_round(run, search, k, pass_no, full, seeds, rng) or improved
        if expired(run.deadline) or not improved:
            break
    return search


def _gradient_round(run: _SearchRun, search: _GradientSearch, k: int, pass_no: int,
                    full: QueryValue,
                    seeds: _DeterministicSeeds, rng: np.random.Generator) -> bool:
    """One round of memory size ``k``: its starts, the ascent from each and the checked
    candidates; ``search`` records what it found. Returns whether it improved the best."""
    round_start = time.perf_counter()
    if k not in search.params:
        search.params[k] = run.parametrisation(k)
    par = search.params[k]
    # the deterministic defences (policy iteration's, the deterministic search's), the better
    # first, on the first pass
    seeded = [] if pass_no else _distinct(sorted(
        (r for r in (seeds.improved.get(k), seeds.deterministic.get(k)) if r is not None),
        key=lambda r: -run.sign * r.value))
    starts = _round_starts(run, search, par, pass_no, full, seeded, rng)
    found, n_eval, seconds = _round(par, starts, run,
                                    extra=tuple((r.gamma, r.delta) for r in seeded))
    search.evaluations += n_eval
    search.t_search += seconds[0]
    search.t_verify += seconds[1]
    improved = False
    if found is not None and (search.best is None
                              or _better(found[1], search.best[1], run.maximize)):
        search.best = (found[0], found[1])
        search.best_logits = found[2]
        improved = True
        progress.report("gradient search", memory=k, best=found[1].value)
    # else the smaller defence stays: embedded into k nodes (_embed_strategy) it guarantees
    # exactly as much, so k never does worse; the smaller one is reported
    if found is not None and (
        k not in search.best_of or _better(found[1], search.best_of[k][1], run.maximize)
    ):
        search.best_of[k] = (found[0], found[1])
    search.seconds_of[k] = search.seconds_of.get(k, 0.0) + time.perf_counter() - round_start
    search.evaluations_of[k] = search.evaluations
    return improved


def _round_starts(run: _SearchRun, search: _GradientSearch, par: Parametrisation, pass_no: int,
                  full: QueryValue, seeded: list[DeterministicResult], rng: np.random.Generator,
                  ) -> list[tuple[np.ndarray, np.ndarray]]:
    """A round's starts, in the order they run: the deterministic defences ``seeded``, the best
    smaller defence (when the round's time runs out, the starts that build on what is known have
    run), then on the first pass the full-observation optimum projected two ways (pessimistic
    QMDP, majority vote), then random logits."""
    k = par.k
    starts = [_hard_logits(found_det.gamma, found_det.delta) for found_det in seeded]
    best, best_logits = search.best, search.best_logits
    if best_logits is not None and best is not None and best[0].memory_size <= k:
        la0, ld0 = _embedded(par, *best_logits)
        starts.append((la0, ld0))
        if best[0].memory_size < k:
            # the embedding is a stationary point of the larger space (the new nodes copy node
            # 0): perturbed copies let the nodes specialise
            for _ in range(2):
                starts.append((la0 + rng.normal(size=la0.shape),
                               ld0 + 2.0 * rng.normal(size=ld0.shape)))
    if pass_no == 0:
        p = run.problem
        starts.append(_qmdp(par, full, run.model, p.rewards, p.discount, run.sign))
        starts.append(_projected(par, full, run.model))
    for _ in range(run.options.budget.units(run.options.restarts)):
        starts.append((rng.normal(size=par.shapes[0]), rng.normal(size=par.shapes[1])))
    return starts


def _unreached_sizes(run: _SearchRun, seeds: _DeterministicSeeds, search: _GradientSearch,
                     ) -> tuple[FiniteStateStrategy, Bound] | None:
    """The deterministic defences of the memory sizes the gradient rounds never reached, ranked
    and recorded in ``search``; returns the best defence overall."""
    best = search.best
    for k, found_det in sorted([*seeds.improved.items(), *seeds.deterministic.items()],
                               key=lambda kr: (kr[0], -run.sign * kr[1].value)):
        if k in search.best_of:
            continue
        par = search.params[k] if k in search.params else run.parametrisation(k)
        fss = par.strategy(found_det.gamma, found_det.delta)
        bound = run.ranked(fss)
        search.best_of[k] = (fss, bound)
        search.seconds_of[k], search.evaluations_of[k] = 0.0, search.evaluations
        if best is None or _better(bound, best[1], run.maximize):
            best = (fss, bound)
    return best


def _belief_phase(run: _SearchRun, best: tuple[FiniteStateStrategy, Bound] | None,
                  phases: dict[str, float]) -> tuple[FiniteStateStrategy, Bound] | None:
    """A pomdp: the belief-based controller handing over to the best defence at its frontier
    (:mod:`posgmc.synthesis.belief`), kept when its product check beats the best."""
    if not run.with_belief or best is None:
        return best
    t0 = time.perf_counter()
    progress.report("belief exploration")
    found = _belief_candidate(run, best[0], run.options.budget.default("belief_nodes"))
    if found is not None and _better(found[1], best[1], run.maximize):
        best = found
    phases["belief exploration"] = time.perf_counter() - t0
    return best


def _memory_rounds(run: _SearchRun, search: _GradientSearch) -> tuple[MemoryRound, ...]:
    """Per memory size: the best defence with at most that many nodes (a smaller one embeds)."""
    rounds = []
    upto: tuple[FiniteStateStrategy, Bound] | None = None
    for k in _with_warm_up(run.options.memory):
        if k not in search.best_of:
            continue
        if upto is None or _better(search.best_of[k][1], upto[1], run.maximize):
            upto = search.best_of[k]
        rounds.append(MemoryRound(k, upto[1], upto[0].is_deterministic,
                                  search.evaluations_of[k], search.seconds_of[k]))
    return tuple(rounds)


@dataclass(frozen=True)
class _Verified:
    """The reported defence, its proven bound (``guaranteed``), the method that proved it and
    whether that check converged."""

    strategy: FiniteStateStrategy
    guaranteed: Bound
    method: str
    converged: bool


def _verification_phase(run: _SearchRun, best: tuple[FiniteStateStrategy, Bound] | None,
                        phases: dict[str, float]) -> _Verified:
    """The chosen defence (with the memory asked for) checked by the caller's method (sound
    interval iteration by default). Policy iteration ranked the candidates, but its
    floating-point solves of nearly singular systems are no proof (it can exceed the
    full-observation value by ~1e-9), so it is never what is reported."""
    assert best is not None  # noqa: S101 - the first memory size always runs
    strategy = best[0]
    if strategy.memory_size < min(run.options.memory):
        # the warm-up's defence won: report it with the memory asked for (the new nodes are
        # never entered, so it guarantees exactly as much)
        strategy = _embed_strategy(strategy, min(run.options.memory))
    t0 = time.perf_counter()
    progress.report("verification")
    final = StrategyChecker(run.model, {strategy.player: strategy},
                            coalition_of=run.coalition_of, scalar=run.scalar,
                            options=run.check_options).check(run.query, text="synthesis")
    phases["verification"] = time.perf_counter() - t0
    assert final.guaranteed is not None  # noqa: S101 - the decision maker's strategy is given
    return _Verified(strategy, final.guaranteed, final.method, final.converged)


def _belief_candidate(run: _SearchRun, cutoff: FiniteStateStrategy, nodes: int,
                      ) -> tuple[FiniteStateStrategy, Bound] | None:
    """The belief-based controller over ``cutoff`` (at most ``nodes`` belief nodes explored) and
    its bound by policy iteration on its product (a ranking, like every candidate's), or None."""
    # under a cap the controller is built with a fifth of what is left to spare: its product is
    # checked after
    now = time.perf_counter()
    end = run.clock.end
    found = belief.belief_phase(run.problem, cutoff,
                                None if end is None else now + 0.8 * max(0.0, end - now),
                                explore=nodes)
    if found is None:
        return None
    return found.strategy, run.ranked(found.strategy)


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
    run: _SearchRun,
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
    sign, options, deadline, model = run.sign, run.options, run.deadline, run.model
    evaluations = 0
    t0 = time.perf_counter()
    candidates: list[tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]] = []
    # the starts are independent jobs (run in parallel with --jobs); each begins without a warm
    # start, so the results do not depend on where or in which order they run
    budget = options.budget
    jobs = [AscendJob(par.k, la, ld, budget.units(options.iterations), options.learning_rate,
                      deadline) for la, ld in starts]
    for i, ((la, ld), n_eval) in enumerate(run.executor.map(jobs)):
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
        bound = run.ranked(fss)
        if best is None or _better(bound, best[1], run.maximize):
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
