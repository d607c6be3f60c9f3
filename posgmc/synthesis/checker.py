"""Properties of partially observable models answered by synthesis: each property's coalition
gets a finite-state strategy (:mod:`posgmc.synthesis.search`) and the result reports what it
provably guarantees, beside the full-observation value that bounds every partially observing
defence."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from contextlib import closing
from dataclasses import dataclass

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.checking.results import Bound, Optimum, PropertyResult, ResultKind, ordered_numbers
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.observables import with_boolean_observables
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax.ast import ComparisonOp, Direction, Expr, ProbQuery, RewardQuery
from posgmc.synthesis import fixed_memory, lower_side, progress
from posgmc.synthesis.bracket import (
    DEFAULT_VERTICES,
    GAP_SHARE,
    GAP_VERTICES,
    optimum_of,
)
from posgmc.synthesis.budget import Clock
from posgmc.synthesis.double_oracle import (
    RESPONSE_EXHAUSTIVE,
    VersusJob,
    _batched,
    one_sided,
    verified_numbers,
)
from posgmc.synthesis.executors import Executor, executor_for
from posgmc.synthesis.objectives import lift, needs_product
from posgmc.synthesis.options import SynthesisOptions
from posgmc.synthesis.problem import POLICY, Problem
from posgmc.synthesis.result import SynthesisResult
from posgmc.synthesis.search import _better, problem_of, synthesize
from posgmc.synthesis.sharpen import Sharpening, keeps_original, sharpen

__all__ = ["SynthesisChecker"]

_GAIN = 1e-7
"""How much better (relative) the composed defence must be, by policy iteration, before the
sound engines check it: a gain below this is numerical noise, and a randomised strategy's sound
check can be slow."""


_SEARCH_SHARE = 0.7
"""Under a wall-clock cap: the part of it for the search (deterministic and gradient)."""

_ADVERSARY_END = 0.85
"""Under a wall-clock cap: where in it the adversary phases end; the rest is for the sound
checks."""


_POOL_BATCH = 4
"""The defence is evaluated against the adversaries of ``vs_fss_adversary`` this many at a time
until the adversary phases' deadline (the kept ones, strongest first, come first)."""


def _until(options: CheckOptions, deadline: float | None) -> CheckOptions:
    """``options`` whose iterative solves stop at ``deadline`` (the wall-clock cap; their bounds
    stay proven), with at least a little time when it has passed already: a check that cannot
    iterate at all proves only the trivial bounds. None: ``options``."""
    if deadline is None:
        return options
    floor = time.perf_counter() + 0.2
    return dataclasses.replace(options, solver=dataclasses.replace(
        options.solver, deadline=max(deadline, floor)))


class SynthesisChecker:
    """Checks each property by synthesising the decision maker's strategy (same interface as
    :class:`~posgmc.checking.property_checker.PropertyChecker`)."""

    def __init__(self, model: ExplicitModel, *, coalition_of: CoalitionResolver,
                 scalar: ScalarEvaluator, options: CheckOptions = CheckOptions(),
                 synthesis: SynthesisOptions = SynthesisOptions()) -> None:
        self.model, self.coalition_of, self.scalar = model, coalition_of, scalar
        self.options, self.synthesis = options, synthesis
        self._run_started = synthesis.started

    def _budget_start(self) -> float:
        """Where this property's budget starts: the run's start (``SynthesisOptions.started``:
        loading and building the model count) for the first property synthesised, now for the
        others (``--timeout`` is per property)."""
        now = time.perf_counter()
        start, self._run_started = self._run_started, None
        return now if start is None else min(start, now)

    def _player(self, expr: ProbQuery | RewardQuery) -> int:
        if not self.model.player_names:
            return 0
        players = self.coalition_of(expr.coalition)
        if players is None or len(players) != 1:
            raise UnsupportedError(
                "synthesis needs a coalition of one player, the decision maker",
                expr.span,
                hint="write <<player>> Pmax=? [ ... ]",
            )
        return next(iter(players))

    def _adversary_phases(self, problem: Problem, executor: Executor, result: SynthesisResult,
                          settings: SynthesisOptions, deadline: float | None,
                          verify: CheckOptions) -> _AdversaryOutcome:
        """Enumerate, rank and keep the adversary's strategies, compose the defence against them
        and run the double oracle (:mod:`posgmc.synthesis.double_oracle`); then choose the reported
        defence — the search's or the composed one, whichever proves the better ``guaranteed``
        (the headline; so it is never worse than the search's) — and verify the numbers (with
        ``verify``, whose solver deadline ends the budget)."""
        effort = settings.budget
        found = one_sided(problem, executor, defence=result.strategy, keep=settings.adversaries,
                          adversary_memory=settings.adversary_memory,
                          enumeration_limit=effort.units(settings.enumeration_limit),
                          restarts=effort.units(settings.compose_restarts),
                          oracle_rounds=effort.units(settings.oracle_rounds),
                          iterations=effort.units(settings.iterations),
                          learning_rate=settings.learning_rate,
                          seed=settings.seed, deadline=deadline,
                          milp_nodes=effort.default("milp_nodes"))
        t0 = time.perf_counter()
        progress.report("adversaries: verification")
        maximize = problem.maximize
        defence, g = result.strategy, result.guaranteed
        composed = found.composed.strategy if found.composed is not None else None
        if composed is not None and composed is result.strategy:
            composed = None  # composing kept the search's defence
        sign = problem.sign
        g_composed: Bound | None = None

        def guaranteed_of(strategy: FiniteStateStrategy, options: CheckOptions) -> Bound | None:
            """The composed defence's ``guaranteed`` under ``options``."""
            return (
                StrategyChecker(self.model, {strategy.player: strategy},
                                coalition_of=problem.coalition_of, scalar=problem.scalar,
                                options=options)
                .check(problem.query, text="composed")
                .guaranteed
            )

        sharpened: dict[str, object] | None = None
        if composed is not None:
            # policy iteration first (cheap); the sound engines only for a real gain, since a
            # randomised strategy's near-deterministic loops make interval iteration slow
            rough = guaranteed_of(composed, POLICY)
            assert rough is not None  # noqa: S101 - the decision maker's strategy is given
            if sign * rough.value > sign * g.value + _GAIN * max(1.0, abs(g.value)):
                g_composed = guaranteed_of(composed, verify)
                assert g_composed is not None  # noqa: S101 - as above
                composed, g_composed, sharpened = self._sharpened(
                    composed, g_composed, lambda f: guaranteed_of(f, verify), maximize)
                if _better(g_composed, g, maximize):
                    defence, g = composed, g_composed
        enumerated = found.enumeration.strategies
        ranked_all = found.all_ranked
        # against every enumerated adversary when there are few enough, else the kept ones; the
        # kept first, so that when the deadline cuts the evaluation short the prefix evaluated
        # (the pool then reported) still holds them
        small = (
            found.enumeration.exhaustive and ranked_all and len(enumerated) <= RESPONSE_EXHAUSTIVE
        )
        pool = tuple(found.kept) + (
            tuple(a for a in enumerated if not any(a is k for k in found.kept)) if small else ()
        )
        # small batches: past the deadline only the first runs (the strongest kept adversaries)
        mine: list[float] = _batched(executor, [VersusJob(defence, a) for a in pool], deadline,
                                     size=_POOL_BATCH)
        if len(mine) < len(pool):
            pool, small = pool[:len(mine)], False
        vs_from_composed = False
        shown_values = mine
        if composed is not None and composed is not defence and pool:
            # vs_fss_adversary of the composed defence when it is clearly better there
            theirs: list[float] = _batched(executor, [VersusJob(composed, a) for a in pool],
                                           deadline, size=_POOL_BATCH)
            worst_mine = min(mine, key=lambda v: sign * v)
            if len(theirs) == len(pool) and sign * min(theirs, key=lambda v: sign * v) > \
                    sign * worst_mine + _GAIN * max(1.0, abs(worst_mine)):
                if g_composed is None:
                    g_composed = guaranteed_of(composed, verify)
                vs_from_composed = g_composed is not None
                shown_values = theirs
        shown, shown_g = (composed, g_composed) if vs_from_composed else (defence, g)
        assert shown is not None and shown_g is not None  # noqa: S101 - set together
        vs, worst, ub = verified_numbers(problem, executor, shown, shown_g, pool, found.ranked,
                                         check_options=verify, values=shown_values)
        phases = dict(found.phases)
        phases["adversaries: verification"] = time.perf_counter() - t0
        stats: dict[str, object] = {
            "adversaries_enumerated": len(enumerated),
            "adversaries_ranked": len(found.ranked),
            "adversaries_kept": len(found.kept),
            "adversaries_added": found.added,
            "vs_adversaries": len(pool),
            "exhaustive": bool(small),
            "defence": "composed" if composed is not None and defence is composed else "search",
            "vs_fss_defence": "composed"
            if vs_from_composed or (composed is not None and defence is composed)
            else "search",
            "composed_value": None if found.composed is None else found.composed.value,
            "composed_sharpening": sharpened if defence is composed else None,
            "oracle": [{"response_value": v, "exhaustive": e} for v, e in found.responses],
        }
        return _AdversaryOutcome(defence, g, vs, ub, worst,
                                 composed if vs_from_composed else None, vs_from_composed,
                                 found.partial, phases, stats)

    @staticmethod
    def _sharpened(strategy: FiniteStateStrategy, g: Bound,
                   verified: Callable[[FiniteStateStrategy], Bound | None], maximize: bool,
                   ) -> tuple[FiniteStateStrategy, Bound, dict[str, object] | None]:
        """The strategy sharpened (:mod:`posgmc.synthesis.sharpen`) and its proven
        ``guaranteed`` (``verified``, the caller's sound check), unless the original proves
        strictly more; and what was done, for the statistics (None: nothing to sharpen)."""
        t0 = time.perf_counter()
        s: Sharpening = sharpen(strategy)
        if not s.changed:
            return strategy, g, None
        g_sharp = verified(s.strategy)
        assert g_sharp is not None  # noqa: S101 - the decision maker's strategy is given
        kept = keeps_original(g, g_sharp, maximize=maximize)
        record: dict[str, object] = {
            "probabilities": s.probabilities, "nodes_dropped": s.nodes_dropped,
            "reported": "original" if kept else "sharpened",
            "guaranteed_original": g.to_json(), "guaranteed_sharpened": g_sharp.to_json(),
            "seconds": round(time.perf_counter() - t0, 3),
            "text": ("not sharpened: the sharpened strategy proves less" if kept else s.text()),
        }
        return (strategy, g, record) if kept else (s.strategy, g_sharp, record)

    def _on_product(self, expr: ProbQuery | RewardQuery, *, text: str,
                    name: str | None) -> PropertyResult:
        """Co-safe LTL and step bounds: synthesis on the product with the formula's automaton
        (:mod:`posgmc.synthesis.objectives`: the strategies observe the game, not the
        automaton, so they are strategies of the game); the defence's ``guaranteed`` is then
        recomputed on the game itself, as ``--strategy`` would."""
        started = self._budget_start()
        clock = Clock(started, self.synthesis.timeout)
        lifted, query = lift(self.model, expr, PropertyChecker(
            self.model, coalition_of=self.coalition_of, scalar=self.scalar))
        # under a cap: the synthesis on the product, then the last tenth for the recomputation
        budget = self.synthesis.timeout
        inner = SynthesisChecker(lifted, coalition_of=self.coalition_of, scalar=self.scalar,
                                 options=self.options, synthesis=dataclasses.replace(
                                     self.synthesis, timeout=None if budget is None
                                     else 0.9 * budget, started=started))
        result = inner.check(query, text=text, name=name)
        defence = result.strategies[0]
        bare = _without_threshold(expr)
        g = StrategyChecker(self.model, {defence.player: defence}, coalition_of=self.coalition_of,
                            scalar=self.scalar, options=_until(self.options, clock.end)
                            ).check(bare, text=text).guaranteed
        assert g is not None  # noqa: S101 - the decision maker's strategy is given
        note = (result.note or "") + ("; synthesised on the product with the formula's automaton, "
                                      "whose state the strategies do not observe")
        ordered = ordered_numbers(
            {"guaranteed": g, "vs_fss_adversary": result.vs_fss_adversary,
             "upper_bound": result.upper_bound, "full_observation": result.full_observation},
            maximizing=bare.direction is Direction.MAX)
        g = ordered["guaranteed"]
        assert g is not None  # noqa: S101 - given
        vs, ub = ordered["vs_fss_adversary"], ordered["upper_bound"]
        full = ordered["full_observation"]
        sound = all(b.sound for b in (g, vs, ub, full) if b is not None)
        strategies = tuple(with_boolean_observables(f, self.model) for f in result.strategies)
        optimum = result.optimum
        if optimum is not None:
            # the product's bracket bounds the same optimum (the automaton is deterministic);
            # its achieved side is the defence's number recomputed on the game
            maximize = PropertyChecker(self.model, coalition_of=self.coalition_of,
                                       scalar=self.scalar).direction_of(bare) is Direction.MAX
            optimum = dataclasses.replace(
                optimum, lower=g.lower if maximize else optimum.lower,
                upper=optimum.upper if maximize else g.upper, sound=optimum.sound and g.sound)
        if expr.threshold is not None:
            return dataclasses.replace(result, note=note, guaranteed=g, vs_fss_adversary=vs,
                                       upper_bound=ub, full_observation=full, sound=sound,
                                       strategies=strategies, optimum=optimum)
        return dataclasses.replace(
            result,
            optimum=optimum,
            value=g.value,
            lower=g.lower,
            upper=g.upper,
            per_initial=(g.value,),
            converged=g.converged,
            note=note,
            guaranteed=g,
            vs_fss_adversary=vs,
            upper_bound=ub,
            full_observation=full,
            sound=sound,
            strategies=strategies,
        )

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        """Synthesise and verify. A threshold holds when ``guaranteed`` meets it, fails when the
        full-observation value cannot, and is unknown in between.

        The phases, in order: the search and the adversary phases (:meth:`_search_phase`), the
        optimum bracket (:func:`_bracket_phase`), under ``--gap`` its achievable side refined
        (:meth:`_lower_phase`), the reported numbers (:func:`_shown_numbers`),
        the answer (:meth:`_answer`), then the note and the statistics that explain it."""
        if not isinstance(expr, (ProbQuery, RewardQuery)):
            raise UnsupportedError(
                "synthesis answers P and R queries of partially observable models",
                expr.span,
                hint="give strategies with --strategy, or use --full-observation",
            )
        player = self._player(expr)
        if needs_product(expr):
            return self._on_product(expr, text=text, name=name)
        run = self._check_run(expr, player, text)
        searched = self._search_phase(run)
        bracket = _bracket_phase(run, searched)
        searched, bracket = self._lower_phase(run, searched, bracket)
        shown = _shown_numbers(run, searched)
        answer = self._answer(expr, shown, bracket.optimum)
        result, adversaries = searched.result, searched.adversaries
        return PropertyResult(
            property=text, name=name, kind=answer.kind, value=answer.value, lower=answer.lower,
            upper=answer.upper, seconds=sum(result.phases.values()),
            method=f"synthesis ({result.method})",
            # exit 0 only when every printed number is proven: an unproven guaranteed (the budget
            # cut its check short) leaves the answer unconverged unless a threshold is decided
            converged=shown.g.converged or isinstance(answer.value, bool),
            sound=all(b.sound for b in (shown.g, shown.vs, shown.ub, shown.full) if b is not None),
            note=self._note(expr, run, searched, shown, bracket, answer),
            per_initial=(answer.value,),
            guaranteed=shown.g, vs_fss_adversary=shown.vs, upper_bound=shown.ub,
            memory=((run.player_name, shown.defence.memory_size),),
            full_observation=shown.full, optimum=bracket.optimum,
            synthesis=self._statistics(run, searched, bracket),
            maximizing=run.bare.direction is Direction.MAX,
            # Boolean observables written true/false in strategy files, as in the model
            strategies=tuple(
                with_boolean_observables(f, self.model) for f in
                (shown.defence,) + ((shown.worst,) if shown.worst is not None else ())
                + ((adversaries.composed,) if adversaries is not None
                   and adversaries.vs_from_composed and adversaries.composed is not None
                   else ())),
        )

    def _check_run(self, expr: ProbQuery | RewardQuery, player: int, text: str) -> _CheckRun:
        """The check's record: its budget starts (``progress`` too), the players' settings and
        the problem synthesis solves."""
        bare = _without_threshold(expr)
        started = self._budget_start()
        clock = Clock(started, self.synthesis.timeout)
        progress.begin(text)
        others = [p for p in range(len(self.model.player_names)) if p != player]
        names = self.model.player_names
        settings = self.synthesis.for_players(
            names[player] if names else "", names[others[0]] if len(others) == 1 else None,
            tuple(names) if names else ("",),
        )
        adversary = others[0] if len(others) == 1 else None
        problem = problem_of(self.model, bare, player=player, adversary=adversary,
                             coalition_of=self.coalition_of, scalar=self.scalar)
        return _CheckRun(bare, player, names[player] if names else "", adversary, settings,
                         problem, started, clock)

    def _search_phase(self, run: _CheckRun) -> _Searched:
        """The search (:func:`~posgmc.synthesis.search.synthesize`), its defence sharpened, then
        the adversary phases when the game has one adversary and they are asked for.

        The work budget is counted per phase (budget.py); a wall-clock cap T (--timeout) is
        shared: up to 7/10 of it for the search (the deterministic search, then the gradient
        search), up to 17/20 for the adversary phases, the rest for the sound checks of the
        reported numbers, which stop at the end of the cap (interval iteration stopped early:
        bounds still proven, only wider; the result then says partial, cut by the timeout).
        With ``--gap`` these fractions are of the search's part of the cap (all but
        :data:`~posgmc.synthesis.bracket.GAP_SHARE`), so that a sound check that overruns its
        share never eats the bound side's (:func:`search_clock`)."""
        settings, run_clock, problem = run.settings, run.clock, run.problem
        with closing(executor_for(problem, settings.placement)) as executor:
            # with --gap the bound side has its share of the budget; without, a little on top
            clock = search_clock(run_clock, settings)
            budget = clock.timeout
            phases_follow = run.adversary is not None and settings.adversaries > 0
            # without adversary phases the search has their time too
            search = dataclasses.replace(
                settings, timeout=None if budget is None else
                budget * (_SEARCH_SHARE if phases_follow else _ADVERSARY_END),
                started=run.started)
            result = synthesize(
                self.model,
                run.bare,
                player=run.player,
                coalition_of=self.coalition_of,
                scalar=self.scalar,
                options=search,
                check_options=_until(self.options, clock.at(_ADVERSARY_END)),
                executor=executor,
            )
            # the search's defence made readable (near-0/1 probabilities exact, unreachable
            # nodes dropped) before the adversary phases, so that every number is about it
            strategy, g_search, search_sharpening = self._sharpened(
                result.strategy, result.guaranteed,
                lambda f: StrategyChecker(
                    self.model, {f.player: f}, coalition_of=self.coalition_of,
                    scalar=self.scalar,
                    options=_until(self.options, clock.at(_ADVERSARY_END)),
                ).check(run.bare, text="synthesis").guaranteed,
                problem.maximize)
            if strategy is not result.strategy:
                result = dataclasses.replace(result, strategy=strategy, guaranteed=g_search)
            adversaries = None
            if phases_follow:
                adversaries = self._adversary_phases(problem, executor, result, settings,
                                                     clock.at(_ADVERSARY_END),
                                                     _until(self.options, clock.end))
            where = {"executor": executor.kind, "workers": executor.workers,
                     "tasks": executor.ledger.to_json()}
        # what cut the work budget short, if anything: the cap (the sound checks then stopped at
        # its end: wider, still proven bounds) or an interrupt
        cut = result.cut or clock.cut()
        if adversaries is not None:
            result.phases.update(adversaries.phases)
        return _Searched(result, search_sharpening, adversaries, where, cut)

    def _lower_phase(self, run: _CheckRun, searched: _Searched, bracket: _Bracket
                     ) -> tuple[_Searched, _Bracket]:
        """Under ``--gap``, when the bracket is still wider: strategies with more memory over
        the reported defence (:mod:`posgmc.synthesis.lower_side`: policy graphs, on a POMDP
        belief controllers) until the rest of the budget; one
        whose sound check against every adversary proves more becomes the reported defence (the
        numbers about the old one against the enumerated adversaries are dropped, not
        carried over), and the bracket's achievable side moves with it."""
        optimum, gap = bracket.optimum, run.settings.gap
        if gap is None or optimum is None or gap.met(optimum.lower, optimum.upper) \
                or not lower_side.applies(run.problem):
            return searched, bracket
        result, adversaries = searched.result, searched.adversaries
        defence = adversaries.defence if adversaries else result.strategy
        g = adversaries.guaranteed if adversaries else result.guaranteed
        if not g.sound or not optimum.sound:
            return searched, bracket
        maximize = run.problem.maximize
        t0 = time.perf_counter()
        progress.report("lower side")
        clock = run.clock
        found = lower_side.close_from_below(
            run.problem, defence, g, bound=optimum.upper if maximize else optimum.lower,
            gap=gap, nodes=run.settings.budget.default("belief_nodes"), deadline=clock.end,
            steps=run.settings.budget.units(fixed_memory.ITERATIONS),
            verify=lambda f: _proven(StrategyChecker(
                self.model, {f.player: f}, coalition_of=self.coalition_of, scalar=self.scalar,
                options=_until(self.options, clock.end)).check(run.bare, text="synthesis")
                .guaranteed))
        result.phases["lower side"] = time.perf_counter() - t0
        stats = dict(bracket.stats, lower_side=found.to_json())
        if found.strategy is None or found.guaranteed is None:
            return searched, _Bracket(optimum, stats)
        new, g_new = found.strategy, found.guaranteed
        result = dataclasses.replace(result, strategy=new, guaranteed=g_new)
        if adversaries is not None:
            adversaries = dataclasses.replace(
                adversaries, defence=new, guaranteed=g_new, vs=None, worst=None, composed=None,
                vs_from_composed=False,
                stats=dict(adversaries.stats, defence="belief", vs_fss_defence="belief",
                           composed_sharpening=None))
        optimum = dataclasses.replace(
            optimum, lower=g_new.lower if maximize else optimum.lower,
            upper=optimum.upper if maximize else g_new.upper, sound=optimum.sound and g_new.sound)
        searched = dataclasses.replace(searched, result=result, adversaries=adversaries,
                                       search_sharpening=None)
        return searched, _Bracket(optimum, stats)

    def _answer(self, expr: ProbQuery | RewardQuery, shown: _ShownNumbers,
                optimum: Optimum | None) -> _Answer:
        """The property's answer: ``guaranteed`` for a query; for a threshold, true when
        ``guaranteed`` proves it, false when no defence reaches it (not with full observation,
        nor against the enumerated adversaries, nor where the optimum's bound side misses it),
        else unknown."""
        g, kind = shown.g, (ResultKind.PROBABILITY if isinstance(expr, ProbQuery)
                            else ResultKind.REWARD)
        if expr.threshold is None:
            return _Answer(g.value, kind, g.lower, g.upper, by_optimum=False)
        p = float(self.scalar(expr.threshold.value))
        holds: Callable[[float], bool] = {
            ComparisonOp.GE: lambda x: x >= p,
            ComparisonOp.GT: lambda x: x > p,
            ComparisonOp.LE: lambda x: x <= p,
            ComparisonOp.LT: lambda x: x < p,
        }[expr.threshold.op]
        maximize = expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
        proven = holds(g.lower if maximize else g.upper) and g.sound
        bound = shown.ub if shown.ub is not None else shown.full
        refuted = bound is not None and bound.sound and not holds(
            bound.upper if maximize else bound.lower)
        by_optimum = (optimum is not None and optimum.sound and not refuted
                      and not holds(optimum.upper if maximize else optimum.lower))
        refuted = refuted or by_optimum
        value = True if proven else False if refuted else None
        return _Answer(value, ResultKind.BOOLEAN, None, None, by_optimum=by_optimum)

    @staticmethod
    def _note(expr: ProbQuery | RewardQuery, run: _CheckRun, searched: _Searched,
              shown: _ShownNumbers, bracket: _Bracket, answer: _Answer) -> str:
        """What each reported number means, and which were left out and why."""
        result, adversaries, optimum = searched.result, searched.adversaries, bracket.optimum
        agent = run.player_name or "the agent"
        direction = "at least" if (run.bare.direction is Direction.MAX) else "at most"
        note = (f"guaranteed: the synthesised strategy of {agent!s} ensures "
                f"{direction} this against every adversary (checked by {result.method}); "
                f"full_observation: the value if it saw everything")
        if optimum is not None:
            note += ("; optimum: proven bounds on the best value any strategy of "
                     f"{agent} (any memory) achieves against every "
                     f"adversary, the {'upper' if run.problem.maximize else 'lower'}"
                     f" one by {optimum.method}")
            if expr.threshold is not None and answer.value is False and answer.by_optimum:
                note += ("; false: the optimum's bound side misses the threshold, so no defence "
                         "of any memory meets it")
        if adversaries is not None:
            settings = run.settings
            adversary_kind = ("memoryless" if settings.adversary_memory == 1
                              else f"{settings.adversary_memory}-node finite-state")
            counted = adversaries.stats["vs_adversaries"]
            if shown.vs is not None:
                note += ("; vs_fss_adversary: the " + ("composed" if adversaries.vs_from_composed
                         else "synthesised") + " strategy's worst value against the adversary's "
                         f"deterministic {adversary_kind} strategies"
                         + (" (all of them)" if adversaries.stats["exhaustive"] else
                            f" (the {counted} strongest found)"))
            if shown.ub is not None:
                note += "; upper_bound: no defence does better against the strongest of them"
        left_out = [k for k, b in (("full_observation", result.full_observation),
                                   ("vs_fss_adversary", adversaries.vs if adversaries else None),
                                   ("upper_bound", adversaries.ub if adversaries else None))
                    if b is not None and not b.converged]
        if left_out:
            note += (f"; {' and '.join(left_out)} left out: the budget ended "
                     f"{'its check' if len(left_out) == 1 else 'their checks'} before the bounds "
                     "converged")
        return note

    def _statistics(self, run: _CheckRun, searched: _Searched,
                    bracket: _Bracket) -> dict[str, object]:
        """The run's statistics (``synthesis`` in the result): what cut it, where it ran, each
        phase's seconds, the rounds, the deterministic search's, the bracket's, the adversary
        phases' and what was sharpened of the reported defence."""
        result, adversaries = searched.result, searched.adversaries
        stats: dict[str, object] = {
            "partial": result.partial or bool(adversaries and adversaries.partial)
            or searched.cut is not None,
            "cut": searched.cut,
            "synthesis": searched.where,
            "phases": {k: round(v, 3) for k, v in result.phases.items()},
            "rounds": [
                {"memory": r.memory, "value_policy_iteration": r.guaranteed.value,
                 "deterministic": r.deterministic, "seconds": round(r.seconds, 3)}
                for r in result.rounds
            ],
            "timeout": self.synthesis.timeout,
            "effort": self.synthesis.effort,
            "seed": self.synthesis.seed,
            "deterministic": [
                {"memory": d.memory, "value": d.value, "exhaustive": d.exhaustive,
                 "families": d.families, "seconds": round(d.seconds, 3)}
                for d in result.deterministic
            ],
        }
        if bracket.optimum is not None:
            stats["optimum_bound"] = bracket.stats
            if run.settings.gap is not None:
                stats["gap_met"] = run.settings.gap.met(bracket.optimum.lower,
                                                        bracket.optimum.upper)
        if adversaries is not None:
            stats.update(adversaries.stats)
        lower = bracket.stats.get("lower_side")
        if isinstance(lower, dict) and lower.get("improved"):
            stats["defence"] = "belief"  # the lower side's controller replaced the defence
        # what was sharpened of the reported defence (the composed one's, when it is reported)
        composed_sharpening = stats.pop("composed_sharpening", None)
        sharpening = composed_sharpening if stats.get("defence") == "composed" else \
            searched.search_sharpening
        if sharpening is not None:
            stats["sharpening"] = sharpening
            stats["sharpened"] = sharpening["text"]  # type: ignore[index]
        if adversaries is not None:
            stats["adversary_memory"] = run.settings.adversary_memory
        return stats


@dataclass(frozen=True)
class _AdversaryOutcome:
    """The reported defence after the adversary phases, its proven numbers and statistics."""

    defence: FiniteStateStrategy
    guaranteed: Bound
    vs: Bound | None
    ub: Bound | None
    worst: FiniteStateStrategy | None
    composed: FiniteStateStrategy | None
    vs_from_composed: bool
    partial: bool
    phases: dict[str, float]
    stats: dict[str, object]


def _proven(bound: Bound | None) -> Bound:
    """A check's ``guaranteed`` (the decision maker's strategy is given, so it has one)."""
    assert bound is not None  # noqa: S101 - the decision maker's strategy is given
    return bound


def _without_threshold(expr: ProbQuery | RewardQuery) -> ProbQuery | RewardQuery:
    """The query synthesis optimises for ``expr``: a threshold's comparison becomes the
    direction (>= and > maximise, <= and < minimise)."""
    if expr.threshold is None:
        return expr
    maximize = expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
    return dataclasses.replace(expr, threshold=None,
                               direction=Direction.MAX if maximize else Direction.MIN)


@dataclass(frozen=True, eq=False)
class _CheckRun:
    """One property's synthesis: the query optimised (``bare``), the decision maker (index and
    name) and its one adversary (or None), the players' settings, the problem, where the budget
    started and its clock."""

    bare: ProbQuery | RewardQuery
    player: int
    player_name: str
    adversary: int | None
    settings: SynthesisOptions
    problem: Problem
    started: float
    clock: Clock


@dataclass(frozen=True, eq=False)
class _Searched:
    """What the search and the adversary phases found: the search's result (its defence
    sharpened), what sharpening did to it, the adversary phases' outcome (None: none ran), where
    the work ran and what cut the budget short (None: nothing)."""

    result: SynthesisResult
    search_sharpening: dict[str, object] | None
    adversaries: _AdversaryOutcome | None
    where: dict[str, object]
    cut: str | None


@dataclass(frozen=True, eq=False)
class _Bracket:
    """The optimum bracket (None: not asked for) and its statistics."""

    optimum: Optimum | None
    stats: dict[str, object]


def search_clock(clock: Clock, settings: SynthesisOptions) -> Clock:
    """The part of the wall-clock cap that the search, the adversary phases and their sound
    checks share: all of it, except with ``--gap`` (and the bracket asked for), where the bound
    side keeps :data:`~posgmc.synthesis.bracket.GAP_SHARE` of it at the end."""
    if clock.timeout is None or not (settings.bracket and settings.gap is not None):
        return clock
    return Clock(clock.started, clock.timeout * (1.0 - GAP_SHARE))


def _bracket_phase(run: _CheckRun, searched: _Searched) -> _Bracket:
    """Proven bounds on the optimum over every defence (:mod:`posgmc.synthesis.bracket`), when
    asked for. The grid's work budget is counted in vertices (effort scales it), so its bound
    depends only on model, options and seed; a wall-clock cap stops it at its end."""
    if not run.settings.bracket:
        return _Bracket(None, {})
    result, adversaries = searched.result, searched.adversaries
    g = adversaries.guaranteed if adversaries else result.guaranteed
    ub = adversaries.ub if adversaries is not None else None
    now = time.perf_counter()
    progress.report("optimum bound")
    vertices = GAP_VERTICES if run.settings.gap is not None else DEFAULT_VERTICES
    # with --gap the lower side (:meth:`SynthesisChecker._lower_phase`) keeps the end of the cap
    end = run.clock.at(1.0 - lower_side.SHARE) if run.settings.gap is not None \
        and lower_side.applies(run.problem) else run.clock.end
    optimum, stats = optimum_of(run.problem, g, result.full_observation, ub,
                                deadline=end, gap=run.settings.gap,
                                vertices=int(vertices * run.settings.effort))
    result.phases["optimum bound"] = time.perf_counter() - now
    return _Bracket(optimum, stats)


@dataclass(frozen=True, eq=False)
class _ShownNumbers:
    """The numbers reported, each proven and in order (:func:`ordered_numbers`): ``guaranteed``
    and the converged ones of ``vs_fss_adversary``, ``upper_bound`` and ``full_observation``;
    the reported defence and the adversary's worst strategy against it."""

    g: Bound
    vs: Bound | None
    ub: Bound | None
    full: Bound | None
    defence: FiniteStateStrategy
    worst: FiniteStateStrategy | None


def _shown_numbers(run: _CheckRun, searched: _Searched) -> _ShownNumbers:
    """The reported numbers. A number whose check the budget cut short before it converged was
    not computed: its point would be a midpoint of wide bounds (0.5 in [0, 1] when it had no
    time at all), so it is left out; guaranteed, the headline, stays with its proven bounds and
    says so."""
    result, adversaries = searched.result, searched.adversaries
    defence = adversaries.defence if adversaries else result.strategy
    g = adversaries.guaranteed if adversaries else result.guaranteed
    full = result.full_observation
    vs = ub = worst = None
    if adversaries is not None:
        vs, ub, worst = adversaries.vs, adversaries.ub, adversaries.worst
    vs, ub = (b if b is not None and b.converged else None for b in (vs, ub))
    ordered = ordered_numbers(
        {"guaranteed": g, "vs_fss_adversary": vs, "upper_bound": ub,
         "full_observation": full if full.converged else None},
        maximizing=run.bare.direction is Direction.MAX)
    g = ordered["guaranteed"] or g
    maximize = run.bare.direction is Direction.MAX
    progress.report("done", best=g.lower if maximize else g.upper, proven=g.sound, bound=g)
    return _ShownNumbers(g, ordered["vs_fss_adversary"], ordered["upper_bound"],
                         ordered["full_observation"], defence, worst)


@dataclass(frozen=True)
class _Answer:
    """The property's value (a number, or a threshold's true/false/None), its kind and bounds
    (None for a threshold), and whether the optimum's bound side refuted the threshold."""

    value: float | bool | None
    kind: ResultKind
    lower: float | None
    upper: float | None
    by_optimum: bool
