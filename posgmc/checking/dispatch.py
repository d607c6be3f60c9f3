"""From a checked property to engine calls: which numerical question each query asks.

This module owns the meaning of queries on fully observable models:

* ``<<C>> Pmax=? [path]``: the states of players in ``C`` maximise, all others minimise; without a
  coalition on a game every player is in it (PRISM-games); on an MDP the single scheduler optimises.
* Threshold forms decide the direction from the comparison: ``P>=p`` holds for an MDP when even the
  minimising scheduler reaches ``p``; for ``<<C>> P>=p`` when ``C`` can ensure it (``C`` maximises).
* ``G``, ``W``, ``R`` and negated path formulas are answered through the complement,
  ``P_max(G a) = 1 - P_min(F !a)``, flipping every state's optimisation direction.
* Any other path formula is co-safe LTL: translated to a DFA, solved as reachability on the product.
  If the formula is not co-safe but its negation is, the complement is used; otherwise the query
  is rejected (PRISM-games' ``Error:co-safe``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from posgmc.checking import intervals as iv
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.checking.states import evaluate_states
from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.step_bounds import interval_reach_probability
from posgmc.errors import SemanticError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.traversal import contains
from posgmc.syntax.ast import (
    NO_SPAN,
    Binary,
    BinaryOp,
    Call,
    Coalition,
    ComparisonOp,
    Direction,
    Expr,
    Function,
    Ite,
    ProbQuery,
    RewardKind,
    RewardQuery,
    Temporal,
    TemporalOp,
    TimeBound,
    Unary,
    UnaryOp,
)

__all__ = ["CheckOptions", "PropertyChecker", "QueryValue"]

CoalitionResolver = Callable[[Coalition | None], frozenset[int] | None]
"""Maps a query's coalition to 0-based player indices (None: no coalition written)."""

ScalarEvaluator = Callable[[Expr], object]
"""Evaluates a constant expression (a bound, a threshold, a discount factor) to a Python value."""


@dataclass(frozen=True)
class CheckOptions:
    """How to check: the numerical method and precision, and what to keep."""

    solver: SolverOptions = SolverOptions()
    keep_values: bool = False
    keep_strategy: bool = False


@dataclass(frozen=True, eq=False)
class QueryValue:
    """The per-state answer to one query (or sub-expression): values with proven bounds."""

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    engine: EngineResult | None = None
    iterations: int = 0
    converged: bool = True
    sound: bool = True
    method: str = "exact"


def _flip(q: QueryValue) -> QueryValue:
    """1 - q, with the bounds swapped."""
    return replace(q, values=1.0 - q.values, lower=1.0 - q.upper, upper=1.0 - q.lower)


def _from_engine(r: EngineResult) -> QueryValue:
    return QueryValue(
        values=r.values,
        lower=r.lower,
        upper=r.upper,
        engine=r,
        iterations=r.iterations,
        converged=r.converged,
        sound=r.sound,
        method=r.method.value,
    )


class PropertyChecker:
    """Checks properties on one explicit model (read as fully observable).

    Args:
        model: the explicit model.
        coalition_of: resolves a query's coalition to player indices.
        scalar: evaluates constant expressions (bounds, thresholds, discount factors).
        options: solver configuration.
    """

    def __init__(
        self,
        model: ExplicitModel,
        *,
        coalition_of: CoalitionResolver,
        scalar: ScalarEvaluator,
        options: CheckOptions = CheckOptions(),
    ) -> None:
        self.model = model
        self.coalition_of = coalition_of
        self.scalar = scalar
        self.options = options
        self._guessed = False  # set when a nested Boolean was undecided and its estimate used

    # -- entry point -----------------------------------------------------------------------------

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        """Check one property and report its value at the initial states.

        A comparison or threshold is decided only on proven bounds: while the bounds at an initial
        state straddle the threshold, the property is solved again with a tighter precision (down
        to 1e-12), then exactly (``Method.EXACT``) when the model has at most
        :data:`EXACT_REFINEMENT_STATES` states; if it is still undecided the result is ``unknown``.
        """
        start = time.perf_counter()
        outcome = self._evaluate(expr)
        for options in self._refinements():
            if outcome.settled(self.model.initial_states):
                break
            refined = PropertyChecker(
                self.model, coalition_of=self.coalition_of, scalar=self.scalar, options=options
            )
            try:
                outcome = refined._evaluate(expr)
            except UnsupportedError:
                break  # an objective the exact engines do not handle: keep the proven bounds
        return outcome.result(
            self.model.initial_states,
            text=text,
            name=name,
            seconds=time.perf_counter() - start,
            keep_values=self.options.keep_values,
            keep_strategy=self.options.keep_strategy,
        )

    def _refinements(self) -> list[CheckOptions]:
        """The options of each refinement round: tighter precisions, then an exact solve."""
        solver = self.options.solver
        if solver.method is not Method.INTERVAL:
            return []
        rounds = [
            replace(self.options, solver=replace(solver, precision=p))
            for p in REFINEMENT_PRECISIONS
            if p < solver.precision
        ]
        if self.model.num_states <= EXACT_REFINEMENT_STATES:
            rounds.append(replace(self.options, solver=replace(solver, method=Method.EXACT)))
        return rounds

    def _evaluate(self, expr: Expr) -> _Outcome:
        self._guessed = False
        if isinstance(expr, (ProbQuery, RewardQuery)) and expr.threshold is None:
            q = self.query(expr)
            kind = ResultKind.PROBABILITY if isinstance(expr, ProbQuery) else ResultKind.REWARD
            b = iv.Bounds(q.values, q.lower, q.upper, ~np.isnan(q.values))
            return _Outcome(kind, b, [q], guessed=self._guessed)
        queries: list[QueryValue] = []
        b = self._bounds(expr, queries)
        kind = ResultKind.BOOLEAN if b.is_bool else ResultKind.NUMBER
        return _Outcome(kind, b, queries, guessed=self._guessed)

    # -- state formulas and arithmetic -------------------------------------------------------------

    def state_value(self, expr: Expr) -> QueryValue:
        """Evaluate a state expression over all states; bounds over nested queries by interval
        arithmetic (:mod:`posgmc.checking.intervals`). Where a Boolean is undecided the reported
        value is the estimate's and the checker remembers that it guessed."""
        if isinstance(expr, (ProbQuery, RewardQuery)) and expr.threshold is None:
            return self.query(expr)
        queries: list[QueryValue] = []
        b = self._bounds(expr, queries)
        if b.is_bool and not bool(np.all(b.decided)):
            self._guessed = True
        sound = all(q.sound for q in queries) and bool(np.all(b.defined))
        method = queries[0].method if queries else "exact"
        return QueryValue(b.value, b.lower, b.upper, sound=sound, method=method,
                          iterations=sum(q.iterations for q in queries),
                          converged=all(q.converged for q in queries))

    def _bounds(self, expr: Expr, queries: list[QueryValue]) -> iv.Bounds:
        """Per-state bounds of ``expr``; the queries it asked are appended to ``queries``."""
        if isinstance(expr, (ProbQuery, RewardQuery)):
            q = self.query(expr)
            queries.append(q)
            b = iv.Bounds(q.values, q.lower, q.upper, ~np.isnan(q.values) & ~np.isnan(q.lower))
            if expr.threshold is None:
                return b
            bound = self.scalar(expr.threshold.value)
            threshold = iv.point(np.full(self.model.num_states, float(bound)))  # type: ignore[arg-type]
            return iv.binary(_THRESHOLD_OPS[expr.threshold.op], b, threshold)
        if not contains(expr, (ProbQuery, RewardQuery)):
            return iv.point(evaluate_states(self.model, expr))
        if isinstance(expr, Unary):
            operand = self._bounds(expr.operand, queries)
            return iv.unary(expr.op, _boolean(operand) if expr.op is UnaryOp.NOT else operand)
        if isinstance(expr, Binary):
            left, right = self._bounds(expr.left, queries), self._bounds(expr.right, queries)
            if expr.op in _CONNECTIVES:
                left, right = _boolean(left), _boolean(right)
            return iv.binary(expr.op, left, right)
        if isinstance(expr, Ite):
            cond, then, otherwise = (self._bounds(e, queries) for e in (expr.cond, expr.then, expr.otherwise))
            if then.is_bool or otherwise.is_bool:
                then, otherwise = _boolean(then), _boolean(otherwise)
            return iv.ite(_boolean(cond), then, otherwise)
        if isinstance(expr, Call):
            args = [self._bounds(a, queries) for a in expr.args]
            if expr.function in (Function.FLOOR, Function.CEIL, Function.ROUND):
                self._check_finite(expr, args[0])
            return iv.call(expr.function, args)
        return iv.point(evaluate_states(self.model, expr))  # raises the positioned error

    def _check_finite(self, expr: Call, arg: iv.Bounds) -> None:
        """PRISM: floor/ceil/round of an infinite or undefined value is an error."""
        init = self.model.initial_states
        bad = ~np.isfinite(arg.value[init]) & (arg.lower[init] == arg.upper[init])
        if np.any(bad):
            v = arg.value[init][np.flatnonzero(bad)[0]]
            raise SemanticError(
                f"{expr.function.value}() of {v} (the value in an initial state) is not an integer",
                expr.span,
                hint="PRISM refuses to round an infinite or undefined value; compare the query "
                "with a number instead",
            )

    # -- queries -------------------------------------------------------------------------------

    def _maximize(self, expr: ProbQuery | RewardQuery) -> np.ndarray:
        direction = expr.direction
        if direction is None:
            if expr.threshold is not None:
                upper_bound = expr.threshold.op in (ComparisonOp.LE, ComparisonOp.LT)
                coalition = expr.coalition is not None or self.model.model_type.is_game
                # MDP: "for all schedulers"; game: "the coalition can ensure".
                if coalition:
                    direction = Direction.MIN if upper_bound else Direction.MAX
                else:
                    direction = Direction.MAX if upper_bound else Direction.MIN
            elif self.model.model_type.is_nondeterministic:
                raise SemanticError(
                    f"{'P' if isinstance(expr, ProbQuery) else 'R'}=? needs min or max on "
                    f"{_phrase(self.model)}: the value depends on how the choices are resolved",
                    expr.span,
                    hint=f"write {'P' if isinstance(expr, ProbQuery) else 'R'}max=? or "
                    f"{'P' if isinstance(expr, ProbQuery) else 'R'}min=? (as PRISM and Storm require)",
                )
            else:
                direction = Direction.MAX  # dtmc: irrelevant
        players = self.coalition_of(expr.coalition)
        return obj.maximize_mask(self.model, direction=direction, coalition=players)

    def query(self, expr: ProbQuery | RewardQuery) -> QueryValue:
        maximize = self._maximize(expr)
        if isinstance(expr, ProbQuery):
            return self._probability(expr.path, maximize)
        return self._reward(expr, maximize)

    def _states(self, e: Expr) -> np.ndarray:
        v = self.state_value(e).values
        if v.dtype != np.bool_:
            raise SemanticError("expected a boolean state formula", e.span)
        return v

    def _step_interval(self, bound: TimeBound) -> tuple[int, int | None]:
        """The inclusive step interval ``[lo, hi]`` of a bound (``hi`` None: unbounded), normalised
        as PRISM does (``>k`` is ``>=k+1``, ``<k`` is ``<=k-1``); like PRISM (and the co-safe LTL
        translation) an empty interval is rejected."""
        lo, hi = 0, None
        for value, strict, is_lower in (
            (bound.lower, bound.lower_strict, True),
            (bound.upper, bound.upper_strict, False),
        ):
            if value is None:
                continue
            k = self.scalar(value)
            if not isinstance(k, int) or isinstance(k, bool) or k < 0:
                span = value.span if value.span != NO_SPAN else bound.span
                raise SemanticError("a step bound must be a non-negative integer", span)
            if is_lower:
                lo = k + 1 if strict else k
            else:
                hi = k - 1 if strict else k
        if hi is not None and lo > hi:
            raise SemanticError(
                f"the step bound admits no step (interval [{lo}, {hi}] is empty)",
                bound.span,
                hint="use a bound such as <=k with k >= 0, or [a,b] with a <= b",
            )
        return lo, hi

    def _probability(self, path: Expr, maximize: np.ndarray) -> QueryValue:
        m, opts = self.model, self.options.solver
        if isinstance(path, Unary) and path.op is UnaryOp.NOT and _is_temporal(path.operand):
            return _flip(self._probability(path.operand, ~maximize))
        if isinstance(path, Temporal) and all(not _is_temporal(o) for o in path.operands):
            op = path.op
            if op is TemporalOp.NEXT:
                if path.bound is not None:
                    raise UnsupportedError(
                        "the next operator X cannot have a step bound",
                        path.bound.span if path.bound.span != NO_SPAN else path.span,
                        hint="write X X a for 'a after two steps'",
                    )
                t = self._states(path.operands[0])
                return _from_engine(obj.next_probability(m, t, maximize=maximize, options=opts))
            if op in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL):
                if op is TemporalOp.UNTIL:
                    remain, target = self._states(path.operands[0]), self._states(path.operands[1])
                else:
                    remain, target = None, self._states(path.operands[0])
                return self._until(remain, target, path.bound, maximize)
            if op is TemporalOp.GLOBALLY:
                bad = ~self._states(path.operands[0])
                return _flip(self._until(None, bad, path.bound, ~maximize))
            if op is TemporalOp.WEAK_UNTIL:  # a W b = !( (a & !b) U (!a & !b) ), as in PRISM
                a, b = self._states(path.operands[0]), self._states(path.operands[1])
                return _flip(self._until(a & ~b, ~a & ~b, path.bound, ~maximize))
            if op is TemporalOp.RELEASE:  # a R b = !( !a U !b )
                a, b = self._states(path.operands[0]), self._states(path.operands[1])
                return _flip(self._until(~a, ~b, path.bound, ~maximize))
        return self._ltl_probability(path, maximize)

    def _until(
        self,
        remain: np.ndarray | None,
        target: np.ndarray,
        bound: TimeBound | None,
        maximize: np.ndarray,
    ) -> QueryValue:
        m, opts = self.model, self.options.solver
        if bound is None:
            r = obj.reach_probability(m, target, remain=remain, maximize=maximize, options=opts)
        else:
            lo, hi = self._step_interval(bound)
            r = interval_reach_probability(
                m,
                target,
                remain=remain,
                lower_steps=lo,
                upper_steps=hi,
                maximize=maximize,
                options=opts,
            )
        return _from_engine(r)

    # -- co-safe LTL -----------------------------------------------------------------------------

    def _ltl_product(self, path: Expr):  # type: ignore[no-untyped-def]
        from posgmc.engines import ltl

        atoms = ltl.extract_atoms(path)
        dfa = ltl.to_dfa(path, atoms)
        if atoms:
            atom_values = np.stack([self._states(a) for a in atoms])
        else:
            atom_values = np.zeros((0, self.model.num_states), dtype=bool)
        return ltl.product(self.model, dfa, atom_values)

    def _ltl_probability(self, path: Expr, maximize: np.ndarray) -> QueryValue:
        from posgmc.engines import ltl

        if not ltl.is_cosafe(path):
            negated = Unary(UnaryOp.NOT, path, span=path.span)
            if ltl.is_cosafe(negated):
                return _flip(self._ltl_probability(negated, ~maximize))
            raise UnsupportedError(
                "this path formula is not co-safe LTL (nor is its negation)",
                path.span,
                hint="use X, F, U, bounded G and boolean connectives (co-safe), or G of a state "
                "formula (safety)",
            )
        prod = self._ltl_product(path)
        pmax = maximize[prod.state_of]
        r = obj.reach_probability(prod.model, prod.accepting, maximize=pmax, options=self.options.solver)
        return self._project(prod, _from_engine(r))

    def _project(self, prod, q: QueryValue) -> QueryValue:  # type: ignore[no-untyped-def]
        """Values of the original states: those of the product state each starts in.

        Only the initial states' values are meaningful for a product; other states get the value
        of their own product start state where it exists in the product, else NaN."""
        S = self.model.num_states
        start = np.full(S, -1, dtype=np.int64)
        start[self.model.initial_states] = prod.initial_map

        def pick(a: np.ndarray) -> np.ndarray:
            out = np.full(S, np.nan)
            ok = start >= 0
            out[ok] = a[start[ok]]
            return out

        return replace(q, values=pick(q.values), lower=pick(q.lower), upper=pick(q.upper), engine=q.engine)

    # -- rewards -------------------------------------------------------------------------------

    def _reward(self, expr: RewardQuery, maximize: np.ndarray) -> QueryValue:
        m, opts = self.model, self.options.solver
        rm = m.reward_model(expr.reward)
        objective = expr.objective
        kind = objective.kind
        choice_rewards = rm.choice_rewards(m.row_groups)
        if kind is RewardKind.INSTANTANEOUS:
            k = self._int(objective.bound)
            state_rewards = rm.state if rm.state is not None else np.zeros(m.num_states)
            return _from_engine(
                obj.instantaneous_reward(m, state_rewards, steps=k, maximize=maximize, options=opts)
            )
        if kind is RewardKind.CUMULATIVE:
            k = self._int(objective.bound)
            return _from_engine(obj.cumulative_reward(m, choice_rewards, steps=k, maximize=maximize, options=opts))
        if kind is RewardKind.TOTAL:
            return _from_engine(obj.total_reward(m, choice_rewards, maximize=maximize, options=opts))
        if kind is RewardKind.DISCOUNTED_TOTAL:
            g = self._discount(objective.discount)
            return _from_engine(
                obj.discounted_total_reward(m, choice_rewards, discount=g, maximize=maximize, options=opts)
            )
        assert objective.target is not None  # noqa: S101 - the parser gives F/F0/Fc/LTL a target
        if kind is RewardKind.DISCOUNTED_REACH:
            g = self._discount(objective.discount)
            t = self._states(objective.target)
            return _from_engine(
                obj.discounted_reach_reward(m, choice_rewards, t, discount=g, maximize=maximize, options=opts)
            )
        mode = {
            RewardKind.REACH: obj.ReachRewardMode.INFINITY,
            RewardKind.REACH_ZERO: obj.ReachRewardMode.ZERO,
            RewardKind.REACH_CUMULATIVE: obj.ReachRewardMode.CUMULATIVE,
            RewardKind.LTL: obj.ReachRewardMode.INFINITY,
        }[kind]
        target_expr = objective.target
        if kind is RewardKind.LTL or _is_temporal(target_expr):
            return self._ltl_reward(expr, target_expr, maximize, mode)
        t = self._states(target_expr)
        return _from_engine(
            obj.expected_reach_reward(m, choice_rewards, t, maximize=maximize, mode=mode, options=opts)
        )

    def _ltl_reward(
        self, expr: RewardQuery, path: Expr, maximize: np.ndarray, mode: "obj.ReachRewardMode"
    ) -> QueryValue:
        from posgmc.engines import ltl

        if not ltl.is_cosafe(path):
            raise UnsupportedError(
                "expected rewards need a co-safe LTL objective; this formula is not co-safe",
                path.span,
                hint="use X, F, U and bounded G (a finite prefix must decide the formula)",
            )
        prod = self._ltl_product(path)
        rm = prod.model.reward_model(expr.reward)
        rewards = rm.choice_rewards(prod.model.row_groups)
        pmax = maximize[prod.state_of]
        r = obj.expected_reach_reward(
            prod.model, rewards, prod.accepting, maximize=pmax, mode=mode, options=self.options.solver
        )
        return self._project(prod, _from_engine(r))

    def _int(self, e: Expr | None) -> int:
        if e is None:
            raise SemanticError("a step bound is missing")
        k = self.scalar(e)
        if not isinstance(k, int) or isinstance(k, bool) or k < 0:
            raise SemanticError("a step bound must be a non-negative integer", e.span)
        return k

    def _discount(self, e: Expr | None) -> float:
        if e is None:
            raise SemanticError("a discount factor is missing")
        g = float(self.scalar(e))  # type: ignore[arg-type]
        if not 0.0 <= g < 1.0:
            raise SemanticError(f"a discount factor must lie in [0, 1); got {g}", e.span)
        return g


REFINEMENT_PRECISIONS = (1e-8, 1e-10, 1e-12)
"""Precisions of the refinement rounds for an undecided threshold (those tighter than asked)."""

EXACT_REFINEMENT_STATES = 100_000
"""The largest model solved exactly (policy iteration, sparse LU) as the last refinement round."""

_THRESHOLD_OPS = {
    ComparisonOp.GE: BinaryOp.GE,
    ComparisonOp.GT: BinaryOp.GT,
    ComparisonOp.LE: BinaryOp.LE,
    ComparisonOp.LT: BinaryOp.LT,
}


_CONNECTIVES = (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF)


def _boolean(b: iv.Bounds) -> iv.Bounds:
    """A Boolean operand as bool bounds: a Boolean state variable arrives as its 0/1 column
    (the explicit model stores valuations as ints; the type checker has made sure it is one)."""
    return b if b.is_bool else iv.point(np.asarray(b.value != 0))


def _phrase(model: ExplicitModel) -> str:
    return {"mdp": "an mdp", "smg": "a game (smg)", "pomdp": "a pomdp", "posg": "a game (posg)"}.get(
        model.model_type.value, model.model_type.value
    )


@dataclass(frozen=True, eq=False)
class _Outcome:
    """One evaluation of a property: its per-state bounds and the queries it asked."""

    kind: ResultKind
    bounds: iv.Bounds
    queries: list[QueryValue]
    guessed: bool  # a nested Boolean was undecided somewhere and its estimate was used

    def settled(self, init: np.ndarray) -> bool:
        """Nothing left to refine: no guess, and a Boolean answer decided in every initial state."""
        if self.guessed:
            return False
        if self.kind is ResultKind.BOOLEAN:
            return bool(np.all(self.bounds.decided[init]))
        return True

    def result(
        self,
        init: np.ndarray,
        *,
        text: str,
        name: str | None,
        seconds: float,
        keep_values: bool,
        keep_strategy: bool,
    ) -> PropertyResult:
        b = self.bounds
        qs = self.queries
        sound = all(q.sound for q in qs) and not self.guessed and bool(np.all(b.defined[init]))
        lower: float | None
        upper: float | None
        value: float | bool | None
        if self.kind is ResultKind.BOOLEAN:
            proven_true, proven_false = b.lower[init], ~b.upper[init]
            if bool(np.all(proven_true)):
                value = True
            elif bool(np.any(proven_false)):
                value = False  # PRISM: a Boolean holds when it holds in every initial state
            else:
                value = None
            per_initial: tuple[float | bool | None, ...] = tuple(
                True if t else (False if f else None) for t, f in zip(proven_true, proven_false)
            )
            lower = upper = None
            if value is None:
                sound = False
        else:
            value = float(b.value[init[0]])
            lower, upper = float(b.lower[init[0]]), float(b.upper[init[0]])
            per_initial = tuple(float(v) for v in b.value[init])
            if math.isnan(value):
                sound = False
        engine = qs[0].engine if len(qs) == 1 else None
        return PropertyResult(
            property=text,
            name=name,
            kind=self.kind,
            value=value,
            lower=lower,
            upper=upper,
            seconds=seconds,
            method=qs[0].method if qs else "exact",
            iterations=sum(q.iterations for q in qs),
            converged=all(q.converged for q in qs),
            sound=sound,
            per_initial=per_initial,
            values=b.value if keep_values else None,
            strategy=engine.strategy if (engine is not None and keep_strategy) else None,
        )


def _is_temporal(e: Expr) -> bool:
    """Whether a path formula contains a temporal operator outside nested queries."""
    return contains(e, Temporal, into_queries=False)
