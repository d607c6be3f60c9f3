"""Properties of partially observable models answered by synthesis: each property's coalition
gets a finite-state strategy (:mod:`posgmc.synthesis.search`) and the result reports what it
provably guarantees, beside the full-observation value that bounds every partially observing
defence."""

from __future__ import annotations

import dataclasses
import time

from posgmc.checking.dispatch import CheckOptions, CoalitionResolver, ScalarEvaluator
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.synthesis.adversaries import enumerate_adversaries, versus_adversaries
from posgmc.synthesis.search import SynthesisOptions, synthesize
from posgmc.syntax.ast import ComparisonOp, Direction, Expr, ProbQuery, RewardQuery

__all__ = ["SynthesisChecker"]


class SynthesisChecker:
    """Checks each property by synthesising the decision maker's strategy (same interface as
    :class:`~posgmc.checking.dispatch.PropertyChecker`)."""

    def __init__(self, model: ExplicitModel, *, coalition_of: CoalitionResolver,
                 scalar: ScalarEvaluator, options: CheckOptions = CheckOptions(),
                 synthesis: SynthesisOptions = SynthesisOptions()) -> None:
        self.model, self.coalition_of, self.scalar = model, coalition_of, scalar
        self.options, self.synthesis = options, synthesis

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

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        """Synthesise and verify. A threshold holds when ``guaranteed`` meets it, fails when the
        full-observation value cannot, and is unknown in between."""
        if not isinstance(expr, (ProbQuery, RewardQuery)):
            raise UnsupportedError(
                "synthesis answers P and R queries of partially observable models",
                expr.span,
                hint="give strategies with --strategy, or use --full-observation",
            )
        player = self._player(expr)
        bare = expr
        if expr.threshold is not None:
            maximize = expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
            bare = dataclasses.replace(expr, threshold=None,
                                       direction=Direction.MAX if maximize else Direction.MIN)
        # the time budget: 4/5 for the search (its verification is quick: candidates are
        # sharpened), the rest for the adversaries; at least a second each
        started = time.perf_counter()
        others = [p for p in range(len(self.model.player_names)) if p != player]
        names = self.model.player_names
        settings = self.synthesis.for_players(
            names[player] if names else "", names[others[0]] if len(others) == 1 else None,
            tuple(names) if names else ("",),
        )
        search = dataclasses.replace(settings, timeout=settings.timeout * 0.8)
        result = synthesize(self.model, bare, player=player, coalition_of=self.coalition_of,
                            scalar=self.scalar, options=search, check_options=self.options)
        g, full = result.guaranteed, result.full_observation
        maximizing = bare.direction is Direction.MAX or (
            bare.direction is None and expr.threshold is not None
            and expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT))
        vs = ub = worst = None
        enumeration = None
        if len(others) == 1 and settings.adversaries > 0:
            # the one-sided view: the adversary's deterministic memoryless strategies, within
            # what is left of the time budget
            t0 = time.perf_counter()
            deadline = max(started + self.synthesis.timeout, t0 + 1.0)
            enumeration = enumerate_adversaries(self.model, others[0], memory=settings.adversary_memory,
                                                limit=settings.adversaries, deadline=deadline)
            vs, ub, evaluated, worst = versus_adversaries(
                self.model, bare, result.strategy, enumeration.strategies, maximize=maximizing,
                coalition_of=self.coalition_of, scalar=self.scalar, deadline=deadline,
            )
            result.phases["adversaries"] = time.perf_counter() - t0
        value: float | bool | None = g.value
        kind = ResultKind.PROBABILITY if isinstance(expr, ProbQuery) else ResultKind.REWARD
        lower: float | None = g.lower
        upper: float | None = g.upper
        if expr.threshold is not None:
            p = float(self.scalar(expr.threshold.value))  # type: ignore[arg-type]
            holds = {ComparisonOp.GE: lambda x: x >= p, ComparisonOp.GT: lambda x: x > p,
                     ComparisonOp.LE: lambda x: x <= p, ComparisonOp.LT: lambda x: x < p}[expr.threshold.op]
            maximize = expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
            proven = holds(g.lower if maximize else g.upper) and g.sound
            # no defence reaches the threshold: not with full observation, nor against the
            # enumerated adversaries
            bound = ub if ub is not None else full
            refuted = not holds(bound.upper if maximize else bound.lower) and bound.sound
            value = True if proven else False if refuted else None
            kind, lower, upper = ResultKind.BOOLEAN, None, None
        player_name = self.model.player_names[player] if self.model.player_names else ""
        direction = "at least" if (bare.direction is Direction.MAX) else "at most"
        note = (f"guaranteed: the synthesised strategy of {player_name or 'the agent'!s} ensures "
                f"{direction} this against every adversary (checked by {result.method}); "
                f"full_observation: the value if it saw everything")
        stats = {
            "partial": result.partial,
            "phases": {k: round(v, 3) for k, v in result.phases.items()},
            "rounds": [
                {"memory": r.memory, "value_policy_iteration": r.guaranteed.value,
                 "deterministic": r.deterministic, "seconds": round(r.seconds, 3)}
                for r in result.rounds
            ],
            "timeout": self.synthesis.timeout,
            "seed": self.synthesis.seed,
        }
        if enumeration is not None:
            exhaustive = enumeration.exhaustive and evaluated == len(enumeration.strategies)
            stats["adversaries_kept"] = evaluated
            stats["exhaustive"] = exhaustive
            stats["adversary_memory"] = settings.adversary_memory
            adversary_kind = ("memoryless" if settings.adversary_memory == 1
                    else f"{settings.adversary_memory}-node finite-state")
            note += ("; vs_fss_adversary: its worst value against the adversary's deterministic "
                     f"{adversary_kind} strategies enumerated" + (" (all of them)" if exhaustive
                     else f" (the first {evaluated})") + "; upper_bound: no "
                     "defence does better against those adversaries")
        return PropertyResult(
            property=text, name=name, kind=kind, value=value, lower=lower, upper=upper,
            seconds=sum(result.phases.values()), method=f"synthesis ({result.method})",
            converged=True, sound=g.sound, note=note, per_initial=(value,),
            guaranteed=g, vs_fss_adversary=vs, upper_bound=ub,
            memory=((player_name, result.strategy.memory_size),),
            full_observation=full, synthesis=stats, strategies=(result.strategy,) + ((worst,) if worst is not None else ()),
        )
