"""Verified numbers about given finite-state strategies: guaranteed, vs_fss_adversary, upper_bound.

For a query ``<<D>> Pmax=? [...]`` (or Pmin, R...min/max, thresholds, co-safe LTL, step bounds,
discounted rewards) the coalition D is the decision maker and every other player the adversary.
Each number is the existing sound engines' answer on a product of the model with the given
strategies (:mod:`posgmc.strategies.product`), so each keeps their proven bounds:

* ``guaranteed`` — the decision maker's strategies fixed, the adversary omniscient (it sees the
  state and the decision maker's memory, with unbounded memory of its own): what the decision
  maker's strategy ensures against every adversary whatsoever (PAYNT's POSMG value). For a pomdp
  (no adversary) it is the exact value of the agent's strategy.
* ``vs_fss_adversary`` — every player's strategy fixed: the value of that strategy profile.
* ``upper_bound`` — the adversary's strategies fixed, the decision maker omniscient: no decision
  maker strategy does better against that adversary.

For a maximising decision maker guaranteed <= vs_fss_adversary <= upper_bound (reversed when it
minimises). Co-safe LTL objectives are solved on the product of the strategy product with the
formula's DFA, so the strategies observe model states only, never the automaton's state.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.checking.results import Bound, PropertyResult, ordered_numbers, strategy_meaning
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import BoundStrategy, bind
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError
from posgmc.strategies.product import strategy_product
from posgmc.syntax.ast import Direction, Expr, ProbQuery, RewardQuery

__all__ = ["StrategyChecker"]


class StrategyChecker:
    """Checks properties of one model under given finite-state strategies.

    Args:
        model: the compiled model (any type).
        strategies: one strategy per player that has one (by the strategy's player name).
        coalition_of: resolves a query's coalition to player indices.
        scalar: evaluates constant expressions.
        options: solver configuration for the products.

    Raises:
        StrategyError: a strategy does not fit the model (wrong player, observables or labels).
    """

    def __init__(
        self,
        model: ExplicitModel,
        strategies: Mapping[str, FiniteStateStrategy],
        *,
        coalition_of: CoalitionResolver,
        scalar: ScalarEvaluator,
        options: CheckOptions = CheckOptions(),
    ) -> None:
        self.model = model
        self.coalition_of = coalition_of
        self.scalar = scalar
        self.options = dataclasses.replace(options, keep_strategy=False, keep_values=False)
        bound = [bind(model, fss) for fss in strategies.values()]
        self.bound: dict[int, BoundStrategy] = {}
        for b in bound:
            if b.player in self.bound:
                raise StrategyError(f"two strategies for player {b.view.name!r}", file=b.fss.source)
            self.bound[b.player] = b
        self.warnings: tuple[str, ...] = tuple(w for b in bound for w in b.warnings)
        self._products: dict[frozenset[int], PropertyChecker] = {}

    @property
    def num_players(self) -> int:
        return max(len(self.model.player_names), 1)

    def bound_player(self, fss: FiniteStateStrategy) -> int:
        """The player index of a strategy given to this checker."""
        return next(p for p, b in self.bound.items() if b.fss is fss)

    def product_checker(self, fixed: frozenset[int]) -> PropertyChecker:
        """The checker of the product with the given players' strategies fixed (cached)."""
        return self._checker(fixed)

    def _checker(self, fixed: frozenset[int]) -> PropertyChecker:
        """The checker of the product with the strategies of the players in ``fixed`` (cached)."""
        if fixed not in self._products:
            product = strategy_product(self.model, [self.bound[p] for p in sorted(fixed)])
            self._products[fixed] = PropertyChecker(
                product.model, coalition_of=self.coalition_of, scalar=self.scalar,
                options=self.options,
            )
        return self._products[fixed]

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        """The numbers that the given strategies determine for one P or R query.

        Raises:
            UnsupportedError: the property is not a single P or R query.
            StrategyError: the strategies leave the question open (no strategy for the decision
                maker nor for the adversary), or a reached (memory, observation) has no rule.
        """
        if not isinstance(expr, (ProbQuery, RewardQuery)):
            raise UnsupportedError(
                "with given strategies a property must be one P or R query",
                expr.span,
                hint="arithmetic over queries and state formulas are checked without --strategy",
            )
        players = frozenset(range(self.num_players))
        deciders = self.coalition_of(expr.coalition)
        deciders = players if deciders is None else frozenset(deciders)
        adversaries = players - deciders
        given = frozenset(self.bound)
        # a threshold's direction is read off the threshold; the numbers come from the bare query
        numeric = dataclasses.replace(
            expr, threshold=None, direction=self._checker(given).direction_of(expr)
        )
        numbers: dict[str, Bound] = {}
        headline: PropertyResult | None = None
        if deciders <= given:
            fixed = frozenset(deciders)
            r = self._checker(fixed).check(numeric, text=text, name=name)
            numbers["guaranteed"] = bound_of(r)
            headline = self._checker(fixed).check(expr, text=text, name=name) \
                if expr.threshold is not None else r
        if adversaries and players <= given:
            numbers["vs_fss_adversary"] = bound_of(self._checker(players).check(numeric, text=text))
        if adversaries and adversaries <= given:
            r = self._checker(frozenset(adversaries)).check(numeric, text=text, name=name)
            numbers["upper_bound"] = bound_of(r)
            if headline is None and expr.threshold is None:
                headline = r
            if headline is None and "vs_fss_adversary" in numbers:
                headline = r
        if headline is None and "vs_fss_adversary" in numbers:
            headline = self._checker(players).check(numeric, text=text, name=name)
        if headline is None:
            names = self.model.player_names or ("",)
            missing = sorted(names[p] for p in deciders - given)
            raise StrategyError(
                f"a threshold is judged on what the decision maker's strategy guarantees: give a "
                f"strategy for {', '.join(map(repr, missing))}"
                if expr.threshold is not None
                else "the given strategies determine no number for this property: give the "
                "decision maker's strategy "
                f"({', '.join(repr(names[p]) for p in sorted(deciders))}) "
                "or the adversary's",
                hint="--strategy PLAYER=FILE, once per player",
            )
        maximizing = numeric.direction is Direction.MAX
        note = "; ".join(f"{k}: {strategy_meaning(k, maximizing=maximizing)}" for k in numbers)
        ordered = ordered_numbers(numbers, maximizing=maximizing)
        memory = tuple(
            (b.view.name, b.memory_size) for _, b in sorted(self.bound.items())
        )
        sound = headline.sound and all(b.sound for b in numbers.values())
        out = dataclasses.replace(
            headline,
            note=note,
            memory=memory,
            sound=sound,
            converged=headline.converged and all(b.converged for b in numbers.values()),
            values=None,
            strategy=None,
            guaranteed=ordered.get("guaranteed", headline.guaranteed),
            vs_fss_adversary=ordered.get("vs_fss_adversary", headline.vs_fss_adversary),
            upper_bound=ordered.get("upper_bound", headline.upper_bound),
            maximizing=maximizing,
        )
        if not isinstance(out.value, bool) and out.value is not None:
            # the headline repeats the first number present: its point as ordered
            first = next(b for b in (out.guaranteed, out.vs_fss_adversary, out.upper_bound)
                         if b is not None)
            out = dataclasses.replace(out, value=first.value, per_initial=(first.value,)
                                      if len(out.per_initial) <= 1 else out.per_initial)
        return out


def bound_of(r: PropertyResult) -> Bound:
    """A numeric result as a :class:`Bound`: its value, proven bounds, and whether they are proven
    and converged."""
    # a numeric query's result
    assert r.value is not None and r.lower is not None and r.upper is not None  # noqa: S101
    return Bound(float(r.value), r.lower, r.upper, r.sound and r.converged, r.converged)
