"""Exact checking (PRISM's ``-exact``): values as fractions, thresholds decided on them.

The model must be built in exact mode (:mod:`posgmc.compiler.exact_explore`: its transition
probabilities are Fractions). What is answered exactly:

* next, step-bounded and unbounded reachability and until probabilities, ``P=? [ X b ]``,
  ``P=? [ F<=k b ]``, ``P=? [ a U<=k b ]``, ``P=? [ F b ]``, ``P=? [ a U b ]``, with
  ``min``/``max`` and coalitions on mdps and smgs, by policy iteration in rational arithmetic
  (:func:`posgmc.engines.rational.exact_rational_reach`; step bounds by backward induction,
  :func:`~posgmc.engines.rational.exact_bounded_reach`), and their thresholds ``P>=p [ ... ]``,
  compared with the threshold as a fraction (``P>1/2`` on a value of ``1/2 + 10^-33`` is true);
* cumulative rewards ``R[ C<=k ]`` by backward induction;
* LTL probabilities on dtmcs and mdps (``P=? [ G F a ]``, ...), through the product with the
  formula's limit-deterministic automaton, reachability of its accepting end components in
  rational arithmetic;
* state formulas without queries.

Everything else (rewards, step bounds, LTL on games, arithmetic over queries, partially observable
models) is refused with a message that names the supported fragment: an answer computed in floating
point must not be printed as exact. Dense Gaussian elimination over Fractions: at most
:data:`EXACT_STATE_LIMIT` states with an undecided value.
"""

from __future__ import annotations

import operator
import time
from collections.abc import Sequence
from fractions import Fraction
from typing import TypedDict

import numpy as np

from posgmc.checking.property_checker import PropertyChecker
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.checking.states import evaluate_states
from posgmc.engines.rational import (
    exact_bounded_reach,
    exact_cumulative_reward,
    exact_rational_reach,
)
from posgmc.engines.rational_rewards import exact_reach_reward
from posgmc.engines.steady import as_fractions, long_run_exact
from posgmc.errors import LimitError, UnsupportedError
from posgmc.semantics.queries import reward_structure
from posgmc.syntax.ast import (
    ComparisonOp,
    Expr,
    ProbQuery,
    RewardKind,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TemporalOp,
)
from posgmc.syntax.traversal import contains_query, is_temporal

__all__ = ["EXACT_STATE_LIMIT", "ExactChecker"]

EXACT_STATE_LIMIT = 3000
"""The most states exact checking accepts (its linear algebra is dense, over Fractions)."""

_SUPPORTED = (
    "exact mode answers reachability probabilities (P[ X b ], P[ F b ], P[ G b ], P[ a U b ], with "
    "upper step bounds <=k and with their thresholds), LTL probabilities on dtmcs and mdps, "
    "expected rewards R[F b] (dtmc, mdp) and R[C<=k], steady-state probabilities and long-run "
    "rewards on dtmcs (S, R[S]) and state formulas"
)

_COMPARE = {
    ComparisonOp.GE: operator.ge,
    ComparisonOp.GT: operator.gt,
    ComparisonOp.LE: operator.le,
    ComparisonOp.LT: operator.lt,
}


def _outward(v: Fraction) -> tuple[float, float]:
    """The doubles just below and above ``v`` (equal when ``v`` is a double)."""
    near = float(v)
    lower = near if near <= v else float(np.nextafter(near, -np.inf))
    upper = near if near >= v else float(np.nextafter(near, np.inf))
    return lower, upper


def _at(values: Sequence[Fraction | None], states: np.ndarray) -> list[Fraction]:
    """The values at ``states`` (the initial states, where every exact answer has its value; an
    LTL one has it only there)."""
    out: list[Fraction] = []
    for s in states.tolist():
        v = values[s]
        if v is None:  # pragma: no cover - see above
            raise RuntimeError("exact checking found no value at an initial state")
        out.append(v)
    return out


class _Common(TypedDict):
    """The fields every result of exact checking shares."""

    property: str
    name: str | None
    method: str


class ExactChecker(PropertyChecker):
    """Checks properties exactly on a model built in exact mode (see the module docstring)."""

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        start = time.perf_counter()
        model = self.model
        if model.exact_probabilities is None:
            raise UnsupportedError(
                "exact checking needs a model built in exact mode (its probabilities as fractions)",
                hint="a model read from DRN has floating-point probabilities; check it without "
                     "--exact",
            )
        if model.model_type.is_partially_observable or model.observations:
            raise UnsupportedError(
                f"exact mode does not cover partially observable models ({model.model_type.value})"
            )
        init = model.initial_states
        common: _Common = {"property": text, "name": name, "method": "exact (rational)"}
        if isinstance(expr, ProbQuery):
            at_init = _at(self._reach(expr), init)
            if expr.threshold is None:
                lower, upper = _outward(at_init[0])
                return PropertyResult(
                    kind=ResultKind.PROBABILITY,
                    value=float(at_init[0]),
                    lower=lower,
                    upper=upper,
                    seconds=time.perf_counter() - start,
                    per_initial=tuple(float(v) for v in at_init),
                    exact=at_init[0],
                    **common,
                )
            bound = Fraction(self.scalar(expr.threshold.value))
            holds = [_COMPARE[expr.threshold.op](v, bound) for v in at_init]
            return PropertyResult(
                kind=ResultKind.BOOLEAN,
                value=all(holds),
                lower=None,
                upper=None,
                seconds=time.perf_counter() - start,
                per_initial=tuple(holds),
                **common,
            )
        if (isinstance(expr, RewardQuery) and expr.objective.kind is RewardKind.REACH
                and expr.objective.target is not None and not is_temporal(expr.objective.target)
                and not contains_query(expr.objective.target)):
            return self._reach_reward(expr, common, start)
        if isinstance(expr, RewardQuery) and expr.objective.kind is RewardKind.CUMULATIVE:
            return self._cumulative_reward(expr, common, start)
        steady = self._steady(expr)
        if steady is not None:
            at_init = [steady[int(s)] for s in init]
            threshold = expr.threshold if isinstance(expr, SteadyQuery) else None
            if threshold is None:
                lower, upper = _outward(at_init[0])
                kind = (
                    ResultKind.PROBABILITY if isinstance(expr, SteadyQuery) else ResultKind.REWARD
                )
                return PropertyResult(
                    kind=kind, value=float(at_init[0]), lower=lower, upper=upper,
                    seconds=time.perf_counter() - start,
                    per_initial=tuple(float(v) for v in at_init), exact=at_init[0],
                    **common,
                )
            bound = Fraction(self.scalar(threshold.value))
            holds = [_COMPARE[threshold.op](v, bound) for v in at_init]
            return PropertyResult(
                kind=ResultKind.BOOLEAN, value=all(holds), lower=None, upper=None,
                seconds=time.perf_counter() - start, per_initial=tuple(holds),
                **common,
            )
        if contains_query(expr):
            raise UnsupportedError(f"{_SUPPORTED}; this property is not one of them", expr.span)
        values_np = evaluate_states(model, expr)
        if values_np.dtype != np.bool_:
            raise UnsupportedError(
                f"{_SUPPORTED}; a numeric state formula is evaluated in floating point", expr.span
            )
        holds = [bool(values_np[s]) for s in init]
        return PropertyResult(
            kind=ResultKind.BOOLEAN,
            value=all(holds),
            lower=None,
            upper=None,
            seconds=time.perf_counter() - start,
            per_initial=tuple(holds),
            **common,
        )

    def _cumulative_reward(self, expr: RewardQuery, common: _Common,
                           start: float) -> PropertyResult:
        """``R[ C<=k ]`` (and its thresholds) exactly, by backward induction."""
        self._check_size()
        model = self.model
        rewards = as_fractions(reward_structure(model, expr).choice_rewards(model.row_groups))
        steps = self._int(expr.objective.bound)
        values = exact_cumulative_reward(
            model, rewards, steps=steps, maximize=self._maximize(expr)
        )
        at_init = [values[int(s)] for s in model.initial_states]
        seconds = time.perf_counter() - start
        if expr.threshold is not None:
            bound = Fraction(self.scalar(expr.threshold.value))
            holds = [_COMPARE[expr.threshold.op](v, bound) for v in at_init]
            return PropertyResult(kind=ResultKind.BOOLEAN, value=all(holds), lower=None,
                                  upper=None, seconds=seconds, per_initial=tuple(holds),
                                  **common)
        lower, upper = _outward(at_init[0])
        return PropertyResult(kind=ResultKind.REWARD, value=float(at_init[0]), lower=lower,
                              upper=upper, seconds=seconds, exact=at_init[0],
                              per_initial=tuple(float(v) for v in at_init),
                              **common)

    def _reach_reward(self, expr: RewardQuery, common: _Common,
                      start: float) -> PropertyResult:
        """``R[F b]`` (and its thresholds) exactly; infinite values are exact too."""
        self._check_size()
        model = self.model
        assert expr.objective.target is not None  # noqa: S101 - checked by the caller
        target = self._states(expr.objective.target)
        rewards = as_fractions(reward_structure(model, expr).choice_rewards(model.row_groups))
        maximize = bool(self._maximize(expr).any())
        values, infinite = exact_reach_reward(model, rewards, target, maximize=maximize)
        init = [int(s) for s in model.initial_states]
        seconds = time.perf_counter() - start
        if expr.threshold is not None:
            bound = Fraction(self.scalar(expr.threshold.value))
            above = expr.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
            # an infinite value is above every threshold
            holds = [above if infinite[s] else _COMPARE[expr.threshold.op](values[s], bound)
                     for s in init]
            return PropertyResult(kind=ResultKind.BOOLEAN, value=all(holds), lower=None,
                                  upper=None, seconds=seconds, per_initial=tuple(holds),
                                  **common)
        s0 = init[0]
        if infinite[s0]:
            return PropertyResult(kind=ResultKind.REWARD, value=float("inf"), lower=float("inf"),
                                  upper=float("inf"), seconds=seconds,
                                  per_initial=tuple(float("inf") if infinite[s] else
                                                    float(values[s]) for s in init),
                                  **common)
        lower, upper = _outward(values[s0])
        return PropertyResult(kind=ResultKind.REWARD, value=float(values[s0]), lower=lower,
                              upper=upper, seconds=seconds, exact=values[s0],
                              per_initial=tuple(float("inf") if infinite[s] else float(values[s])
                                                for s in init),
                              **common)

    def _ltl(self, expr: ProbQuery) -> list[Fraction | None]:
        """An LTL probability exactly: the LDBA product's maximal probability of reaching an
        accepting end component in rational arithmetic (a dtmc's, or an mdp's ``max``), ``min``
        as ``1 - max`` of the negation (:mod:`posgmc.engines.ltl.omega`). Values at the
        initial states only (None elsewhere)."""
        fractions = self._omega_fractions(
            expr.path, self._maximize(expr), limit=EXACT_STATE_LIMIT, everywhere=False
        )
        if fractions is None:
            raise LimitError(
                f"exact mode solves models of at most {EXACT_STATE_LIMIT} states; the product of "
                "this model with the formula's automaton has more",
                expr.span,
                hint="check without --exact: the default interval method gives proven bounds",
            )
        return fractions

    def _check_size(self) -> None:
        if self.model.num_states > EXACT_STATE_LIMIT:
            raise LimitError(
                f"exact mode solves models of at most {EXACT_STATE_LIMIT} states; this one has "
                f"{self.model.num_states}",
                hint="check without --exact: the default interval method gives proven bounds",
            )

    def _steady(self, expr: Expr) -> list[Fraction] | None:
        """``S [ phi ]`` and ``R [ S ]`` per state, exactly (None for other properties)."""
        if isinstance(expr, SteadyQuery):
            weight = [Fraction(int(b)) for b in self._states(expr.operand)]
        elif (isinstance(expr, RewardQuery) and expr.objective.kind is RewardKind.STEADY
              and expr.threshold is None):
            rm = reward_structure(self.model, expr)
            weight = as_fractions(rm.choice_rewards(self.model.row_groups))
        else:
            return None
        self._check_size()
        return long_run_exact(self.model, weight)

    def _reach(self, expr: ProbQuery) -> Sequence[Fraction | None]:
        path = expr.path
        bound = getattr(path, "bound", None)
        if (isinstance(path, Temporal) and path.op is TemporalOp.GLOBALLY
                and not any(is_temporal(o) or contains_query(o) for o in path.operands)
                and (bound is None or (self._step_interval(bound)[0] == 0
                                       and self._step_interval(bound)[1] is not None))):
            # G a = !F !a: the complement, with the opposite optimum (PRISM does the same)
            self._check_size()
            bad = ~self._states(path.operands[0])
            flipped = ~self._maximize(expr)
            if bound is None:
                reach = exact_rational_reach(self.model, bad, maximize=flipped)
            else:
                steps = int(self._step_interval(bound)[1])  # type: ignore[arg-type]
                reach = exact_bounded_reach(self.model, bad, remain=None, steps=steps,
                                            maximize=flipped, next_only=False)
            return [1 - v for v in reach]
        if (
            not isinstance(path, Temporal)
            or path.op not in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL, TemporalOp.NEXT)
            or any(is_temporal(o) or contains_query(o) for o in path.operands)
            or (
                bound is not None
                and (
                    path.op is TemporalOp.NEXT
                    or self._step_interval(bound)[0] != 0
                    or self._step_interval(bound)[1] is None
                )
            )
        ):
            if is_temporal(path) and not contains_query(path):
                return self._ltl(expr)
            raise UnsupportedError(f"{_SUPPORTED}; this path formula is not one of them", expr.span)
        self._check_size()
        if path.op is TemporalOp.UNTIL:
            remain, target = self._states(path.operands[0]), self._states(path.operands[1])
        else:
            remain, target = None, self._states(path.operands[0])
        if path.op is TemporalOp.NEXT or bound is not None:
            steps = 1 if bound is None else int(self._step_interval(bound)[1])  # type: ignore[arg-type]
            return exact_bounded_reach(
                self.model, target, remain=remain, steps=steps, maximize=self._maximize(expr),
                next_only=path.op is TemporalOp.NEXT,
            )
        return exact_rational_reach(
            self.model, target, remain=remain, maximize=self._maximize(expr)
        )
