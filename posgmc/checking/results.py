"""What checking a property answers: a value with the bounds that hold, and where it came from."""

from __future__ import annotations

import builtins
import dataclasses
import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np


def _num(x: float | bool | None) -> Any:
    """A number as JSON has it: infinities as strings, NaN as null."""
    if x is None or isinstance(x, bool):
        return x
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if math.isnan(x):
        return None
    return float(x)


@dataclass(frozen=True)
class Bound:
    """One named number about finite-state strategies, with bounds that hold when ``sound``:
    ``lower <= exact <= upper``; ``value`` is the reported point (the bounds' midpoint for interval
    methods). ``sound`` means proven: the bounds hold and are as close as asked. ``converged`` is
    False when the check stopped before that (out of time or iterations): the interval engines'
    bounds then still hold, but ``value`` is only a point between them."""

    value: float
    lower: float
    upper: float
    sound: bool = True
    converged: bool = True

    def to_json(self) -> dict[str, Any]:
        return {"value": _num(self.value), "lower": _num(self.lower), "upper": _num(self.upper)}


@dataclass(frozen=True)
class Optimum:
    """A proven bracket on the optimum: the best value *any* strategy of the decision maker (any
    memory, randomised) achieves against every adversary (an omniscient one), with
    ``lower <= optimum <= upper`` when ``sound``. One side is what the synthesised strategy
    guarantees; the other (the bound side: ``upper`` for a maximising decision maker, ``lower``
    for a minimising one) comes from ``method`` (docs/synthesis.md)."""

    lower: float
    upper: float
    method: str
    sound: bool = True

    @property
    def gap(self) -> float:
        """``upper - lower`` (0 when both are the same infinity)."""
        if self.lower == self.upper:
            return 0.0
        return self.upper - self.lower

    def to_json(self) -> dict[str, Any]:
        return {"lower": _num(self.lower), "upper": _num(self.upper), "gap": _num(self.gap),
                "method": self.method}


STRATEGY_NUMBERS = ("guaranteed", "vs_fss_adversary", "upper_bound")
"""The numbers about given or synthesised finite-state strategies, in the order they are reported;
the JSON keys and :class:`PropertyResult`'s field names."""


def ordered_numbers(
    numbers: Mapping[str, Bound | None], *, maximizing: bool
) -> dict[str, Bound | None]:
    """``numbers`` (by the keys of :data:`STRATEGY_NUMBERS`, and ``full_observation``) with their
    points in the order that their exact values are in: guaranteed <= vs_fss_adversary <=
    upper_bound for a maximising decision maker (what a strategy ensures against every adversary
    is at most its value against one adversary, which no decision maker exceeds against that
    adversary) and guaranteed <= full_observation (no partially observing defence does better
    than one that sees everything); reversed when it minimises.

    Separate checks round separately, so two points a few ulps apart can come out the wrong way
    round; each point is moved, within its own proven bounds, to the nearest value that respects
    the order. Where the bounds themselves contradict the order (an unproven number) the point
    stays in its own bounds. The bounds are never changed."""
    out = dict(numbers)
    _order_chain(out, STRATEGY_NUMBERS, 1.0 if maximizing else -1.0)
    # then full_observation against guaranteed: this only lowers guaranteed's point (which
    # keeps the first chain in order) or raises full_observation's
    _order_chain(out, ("guaranteed", "full_observation"), 1.0 if maximizing else -1.0)
    return out


def _order_chain(numbers: dict[str, Bound | None], chain: tuple[str, ...], sign: float) -> None:
    """Move the points of the present numbers of ``chain`` (in place), within their bounds, so
    that ``sign * point`` ascends along it."""
    present = [k for k in chain if numbers.get(k) is not None]
    lo: list[float] = []
    hi: list[float] = []
    points: list[float] = []
    for k in present:
        b = numbers[k]
        assert b is not None  # noqa: S101 - present
        a, z = sorted((sign * b.lower, sign * b.upper))
        lo.append(a)
        hi.append(z)
        points.append(min(max(sign * b.value, a), z))
    # upwards: each point at least its predecessor (as far as its upper bound allows); then
    # downwards: each point at most its successor (as far as its lower bound allows)
    for i in range(1, len(points)):
        points[i] = min(max(points[i], points[i - 1]), hi[i])
    for i in range(len(points) - 2, -1, -1):
        points[i] = max(min(points[i], points[i + 1]), lo[i])
    for k, v in zip(present, points):
        b = numbers[k]
        assert b is not None  # noqa: S101 - present
        value = sign * v
        if value != b.value and not (math.isnan(b.value) and math.isnan(value)):
            numbers[k] = dataclasses.replace(b, value=value)


def strategy_meaning(key: str, *, maximizing: bool) -> str:
    """What one of :data:`STRATEGY_NUMBERS` means, in words, for a maximising (Pmax, Rmax) or a
    minimising (Pmin, Rmin) decision maker."""
    best, worse = ("at least", "more") if maximizing else ("at most", "less")
    return {
        "guaranteed": f"the decision maker's strategy ensures {best} this against every adversary "
        "(an omniscient one)",
        "vs_fss_adversary": "the exact value of the decision maker's strategy against this "
                            "adversary "
        "strategy",
        "upper_bound": f"no decision-maker strategy gets {worse} than this against this adversary "
        "strategy (not even one that sees everything)",
    }[key]


class ResultKind(enum.Enum):
    PROBABILITY = "probability"
    REWARD = "reward"
    BOOLEAN = "boolean"
    NUMBER = "number"  # arithmetic over queries
    PARETO = "pareto"  # a multi(...) Pareto query: the front is in ``multi.front``


@dataclass(frozen=True, eq=False)
class PropertyResult:
    """The answer to one property at the model's initial state(s).

    ``value`` is the reported number (or bool for threshold properties); ``lower``/``upper`` are
    proven bounds on the exact value (equal to ``value`` for exact methods, None for booleans).
    With several initial states, a numeric value is the one of the first initial state and
    ``per_initial`` lists them all; a boolean holds when it holds in every initial state (PRISM).
    ``note`` says what the number means when it is not the plain answer (e.g. a full-observation
    bound on a partially observable model). With given finite-state strategies, ``guaranteed``,
    ``vs_fss_adversary`` and ``upper_bound`` hold the numbers that apply (see
    :data:`STRATEGY_NUMBERS`), ``memory`` each strategy's memory size, and ``value``/``lower``/
    ``upper`` repeat the first of them that is present (a threshold is judged on ``guaranteed``).
    In exact mode (PRISM's ``-exact``) ``exact`` is the value as a fraction, and ``lower``/
    ``upper`` are the doubles just around it.
    A synthesised result also has ``full_observation`` (the value when the decision maker sees
    everything: no partially observing defence does better), ``optimum`` (a proven bracket on
    the best value any defence achieves, :class:`Optimum`), ``synthesis`` (JSON-ready statistics:
    ``partial``, ``phases``, ``rounds``) and ``strategies`` (the synthesised
    :class:`~posgmc.strategies.fss.FiniteStateStrategy` objects).
    """

    property: str
    name: str | None
    kind: ResultKind
    value: float | bool | None  # None: a Boolean left undecided by the proven bounds
    lower: float | None
    upper: float | None
    seconds: float
    method: str
    iterations: int = 0
    converged: bool = True
    sound: bool = True
    note: str | None = None
    per_initial: tuple[float | bool | None, ...] = ()
    values: np.ndarray | None = field(default=None, repr=False)
    strategy: np.ndarray | None = field(default=None, repr=False)
    guaranteed: Bound | None = None
    vs_fss_adversary: Bound | None = None
    upper_bound: Bound | None = None
    memory: tuple[tuple[str, int], ...] = ()
    full_observation: Bound | None = None
    optimum: Optimum | None = None
    synthesis: Mapping[str, Any] | None = None
    strategies: tuple[Any, ...] = field(default=(), repr=False)
    exact: Fraction | None = None
    multi: Any = field(default=None, repr=False)
    maximizing: bool | None = None
    """For a result about a decision maker's strategies: whether it maximises (Pmax, Rmax, a
    ``>=`` threshold), which says which side each bound is on; None otherwise."""

    @builtins.property  # the field ``property`` shadows the builtin in the class body
    def front(self) -> Any:
        """The Pareto front of a ``multi(...)`` Pareto query
        (:class:`~posgmc.checking.multi.Front`), else None."""
        return getattr(self.multi, "front", None)

    @builtins.property
    def headline(self) -> Bound | None:
        """The one number a progress report shows for this result, with its proven bounds (so it
        prints as the result does): the ``guaranteed`` of a synthesis or of given strategies, else
        the numeric value (its bounds those of the value, or the value itself where it has none;
        None for a Boolean)."""
        if self.guaranteed is not None:
            return self.guaranteed
        value = self.value
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            return None
        v = float(value)
        return Bound(v, v if self.lower is None else float(self.lower),
                     v if self.upper is None else float(self.upper), self.sound, self.converged)

    def to_json(self) -> dict[str, Any]:
        """The documented machine-readable form (see docs/cli.md)."""

        num = _num
        out: dict[str, Any] = {
            "property": self.property,
            "name": self.name,
            "kind": self.kind.value,
            "value": num(self.value),
            "lower": num(self.lower),
            "upper": num(self.upper),
            "seconds": round(self.seconds, 6),
            "method": self.method,
            "iterations": self.iterations,
            "converged": self.converged,
            "sound": self.sound,
        }
        if self.exact is not None:
            out["exact"] = f"{self.exact.numerator}/{self.exact.denominator}"
        if self.note:
            out["note"] = self.note
        if len(self.per_initial) > 1:
            out["per_initial"] = [num(v) for v in self.per_initial]
        for key in STRATEGY_NUMBERS:
            number = getattr(self, key)
            if number is not None:
                out[key] = number.to_json()
        if self.memory:
            out["memory"] = dict(self.memory)
        if self.full_observation is not None:
            out["full_observation"] = self.full_observation.to_json()
        if self.optimum is not None:
            out["optimum"] = self.optimum.to_json()
        if self.maximizing is not None:
            out["direction"] = "max" if self.maximizing else "min"
        if self.synthesis is not None:
            out.update(self.synthesis)
        if self.multi is not None:
            out["multi"] = {"kind": self.multi.kind.value, "lp_states": self.multi.states}
            if self.front is not None:
                out["front"] = self.front.to_json()
            elif self.kind is ResultKind.BOOLEAN:
                out["multi"].update(decided=self.multi.decided, margin=num(self.multi.margin),
                                    proven=self.multi.proven)
            else:
                out["multi"].update(certified=num(self.multi.certified),
                                    minimised=self.multi.minimised)
        return out
