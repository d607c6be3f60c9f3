"""From a checked property to engine calls: which numerical question each query asks.

This module owns the meaning of queries on fully observable models:

* ``<<C>> Pmax=? [path]``: the states of players in ``C`` maximise, all others minimise; without a
  coalition on a game every player is in it (PRISM-games); on an MDP the single scheduler optimises.
* Threshold forms decide the direction from the comparison: ``P>=p`` holds for an MDP when even the
  minimising scheduler reaches ``p``; for ``<<C>> P>=p`` when ``C`` can ensure it (``C`` maximises).
* ``G``, ``W``, ``R`` and negated path formulas are answered through the complement,
  ``P_max(G a) = 1 - P_min(F !a)``, flipping every state's optimisation direction.
* Any other path formula is LTL. A co-safe one is translated to a DFA and solved as reachability
  on the product; if the formula is not co-safe but its negation is, the complement is used.
  Otherwise (``G F a``, ``F G a``, ...) a dtmc or mdp gets the limit-deterministic Büchi
  automaton of :mod:`posgmc.engines.ltl.ldba`: the maximal probability of reaching an accepting
  end component of the product, and ``Pmin(phi) = 1 - Pmax(!phi)``; games refuse it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from posgmc.checking import intervals as iv
from posgmc.checking.ctl import quantified_states
from posgmc.checking.filters import apply_filter
from posgmc.checking.intervals import QueryValue
from posgmc.checking.results import PropertyResult, ResultKind
from posgmc.checking.states import evaluate_call, evaluate_states
from posgmc.engines import objectives as obj
from posgmc.engines.options import SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.steady import long_run_average
from posgmc.engines.step_bounds import interval_reach_probability
from posgmc.errors import SemanticError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.semantics.evaluate import Value
from posgmc.semantics.queries import reward_structure
from posgmc.syntax.ast import (
    NO_SPAN,
    Binary,
    BinaryOp,
    Call,
    Coalition,
    ComparisonOp,
    Direction,
    Expr,
    Filter,
    Ite,
    MultiQuery,
    PathQuantifier,
    ProbQuery,
    RewardKind,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TemporalOp,
    TimeBound,
    Unary,
    UnaryOp,
)
from posgmc.syntax.printer import format_expr
from posgmc.syntax.traversal import contains_query, is_temporal

__all__ = ["CheckOptions", "PropertyChecker", "QueryValue"]

CoalitionResolver = Callable[[Coalition | None], frozenset[int] | None]
"""Maps a query's coalition to 0-based player indices (None: no coalition written)."""

ScalarEvaluator = Callable[[Expr], Value]
"""Evaluates a constant expression (a bound, a threshold, a discount factor) to a Python value."""


@dataclass(frozen=True)
class CheckOptions:
    """How to check: the numerical method and precision, and what to keep."""

    solver: SolverOptions = SolverOptions()
    keep_values: bool = False
    keep_strategy: bool = False
    # PRISM's -exact: rational arithmetic throughout (posgmc.checking.exact_checker)
    exact: bool = False


_COMPARISON = {
    ComparisonOp.GE: BinaryOp.GE,
    ComparisonOp.GT: BinaryOp.GT,
    ComparisonOp.LE: BinaryOp.LE,
    ComparisonOp.LT: BinaryOp.LT,
}


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
        self._everywhere = True  # set by query(): whether every state's value is needed

    # -- entry point -----------------------------------------------------------------------------

    def check(self, expr: Expr, *, text: str, name: str | None = None) -> PropertyResult:
        """Check one property and report its value at the initial states."""
        if self.options.solver.want_strategy and not self.options.keep_strategy:
            # the report drops the strategy, so the engines need not compute it (on a game of
            # infinite reward its positive-Büchi strategy costs many times the value itself)
            lean = replace(self.options, solver=replace(self.options.solver, want_strategy=False))
            return PropertyChecker(
                self.model, coalition_of=self.coalition_of, scalar=self.scalar, options=lean
            ).check(expr, text=text, name=name)
        if isinstance(expr, MultiQuery):
            from posgmc.checking.multi import check_multi

            return check_multi(self, expr, text=text, name=name)
        start = time.perf_counter()
        init = self.model.initial_states
        if isinstance(expr, (ProbQuery, RewardQuery)) and expr.threshold is None:
            q = self.query(expr, everywhere=False)
            kind = ResultKind.PROBABILITY if isinstance(expr, ProbQuery) else ResultKind.REWARD
        else:
            q = self.state_value(expr)
            kind = ResultKind.BOOLEAN if q.values.dtype == np.bool_ else ResultKind.NUMBER
            init = self.model.initial_states
            if kind is ResultKind.BOOLEAN and not np.all(q.decided[init]) and contains_query(expr):
                q = self._finer(
                    lambda checker: checker.state_value(expr),
                    lambda r: bool(np.all(r.decided[init])),
                ) or q
        seconds = time.perf_counter() - start
        vals = q.values[init]
        if kind is ResultKind.BOOLEAN:
            # PRISM: a Boolean holds when it holds in every initial state; decided only on proof
            proven, possible = bool(np.all(q.lower[init])), bool(np.all(q.upper[init]))
            value: float | bool | None = proven if proven == possible else None
            lower = upper = None
            per_initial: tuple[float | bool | None, ...] = tuple(
                bool(lo) if lo == hi else None for lo, hi in zip(q.lower[init], q.upper[init])
            )
        else:
            value = float(vals[0])
            lower, upper = float(q.lower[init[0]]), float(q.upper[init[0]])
            per_initial = tuple(float(v) for v in vals)
            if np.isnan([value, lower, upper]).any():  # undefined (0/0): no bound holds
                q = replace(q, sound=False)
        eng = q.engine
        return PropertyResult(
            property=text,
            name=name,
            kind=kind,
            value=value,
            lower=lower,
            upper=upper,
            seconds=seconds,
            method=q.method,
            iterations=q.iterations,
            # a Boolean decided on proven bounds is final, however far the iteration got
            converged=q.converged or (q.is_boolean and value is not None),
            sound=q.sound,
            per_initial=per_initial,
            values=q.values if self.options.keep_values else None,
            strategy=eng.strategy if (eng is not None and self.options.keep_strategy) else None,
        )

    # -- state formulas and arithmetic -------------------------------------------------------------

    def state_value(self, expr: Expr) -> QueryValue:
        """Evaluate a state expression in every state; over nested queries with interval
        arithmetic (:mod:`posgmc.checking.intervals`), so the bounds hold through every operator."""
        if isinstance(expr, (ProbQuery, RewardQuery)):
            q = self.query(expr)
            if expr.threshold is None:
                return q
            return self._threshold(expr, q)
        if isinstance(expr, PathQuantifier):
            return iv.exact(quantified_states(self.model, expr, self._states))
        if isinstance(expr, SteadyQuery):
            weight = self._states(expr.operand).astype(np.float64)
            q = self._long_run(weight)
            if expr.threshold is None:
                return q
            bound = float(self.scalar(expr.threshold.value))
            cmp = _COMPARISON[expr.threshold.op]
            return iv.binary(cmp, q, iv.exact(np.full(self.model.num_states, bound)))
        if isinstance(expr, Filter):
            states = (np.ones(self.model.num_states, dtype=np.bool_) if expr.states is None
                      else self._states(expr.states))
            text = format_expr(expr.states) if expr.states is not None else "true"
            return apply_filter(self.model, expr.op, self.state_value(expr.operand), states,
                                span=expr.span, states_text=text)
        if not contains_query(expr):
            return iv.exact(evaluate_states(self.model, expr))
        if isinstance(expr, Unary):
            q = self.state_value(expr.operand)
            return iv.logical_not(q) if expr.op is UnaryOp.NOT else iv.negate(q)
        if isinstance(expr, Binary):
            return iv.binary(expr.op, self.state_value(expr.left), self.state_value(expr.right))
        if isinstance(expr, Ite):
            return iv.ite(*(self.state_value(e) for e in (expr.cond, expr.then, expr.otherwise)))
        if isinstance(expr, Call):
            args = [self.state_value(a) for a in expr.args]
            # the domain rules of state formulas, decided on the reported values
            evaluate_call(self.model, expr, [a.values for a in args])
            return iv.call(expr.function, args)
        raise UnsupportedError(f"cannot evaluate {type(expr).__name__} over states", expr.span)

    def _threshold(self, expr: ProbQuery | RewardQuery, q: QueryValue) -> QueryValue:
        """``P>=p [...]``: true where the proven bounds are above the threshold, false where they
        are below, undecided (``lower < upper``) where the interval straddles it after
        refinement (see :meth:`_refined`)."""
        assert expr.threshold is not None  # noqa: S101 - guaranteed by caller
        bound = float(self.scalar(expr.threshold.value))
        cmp = _COMPARISON[expr.threshold.op]
        threshold = iv.exact(np.full(self.model.num_states, bound))
        decided = iv.binary(cmp, q, threshold)
        init = self.model.initial_states
        if not np.all(decided.decided[init]):
            q = self._refined(
                expr, q, lambda r: bool(np.all(iv.binary(cmp, r, threshold).decided[init]))
            )
            decided = iv.binary(cmp, q, threshold)
        return replace(decided, engine=q.engine, method=q.method)

    def _refined(self, expr: ProbQuery | RewardQuery, q: QueryValue, done) -> QueryValue:  # type: ignore[no-untyped-def]
        """The query solved again until ``done``: with finer precision (:meth:`_finer`), then, for
        an unbounded reachability probability on a small model, exactly in rational arithmetic.
        Returns the last answer (still undecided if nothing decided it)."""
        bare = replace(expr, threshold=None, direction=self.direction_of(expr))
        q = self._finer(lambda checker: checker.query(bare), done) or q
        if done(q):
            return q
        exact = self._rational(bare)
        return exact if exact is not None and done(exact) else q

    def _finer(self, solve, done) -> QueryValue | None:  # type: ignore[no-untyped-def]
        """``solve`` with a precision 100 times finer each round, down to 1e-12, until ``done``;
        the last answer (None if the precision was already that fine)."""
        solver = self.options.solver
        precision, q = solver.precision, None
        while precision > 1e-12:
            precision = max(precision / 100, 1e-12)
            finer = replace(
                self.options, solver=replace(solver, precision=precision, relative=False)
            )
            checker = PropertyChecker(
                self.model, coalition_of=self.coalition_of, scalar=self.scalar, options=finer
            )
            q = solve(checker)
            if done(q):
                break
        return q

    def _rational(self, expr: ProbQuery | RewardQuery) -> QueryValue | None:
        """The exact value of an unbounded ``P[a U b]`` (or ``F``) on a model of at most
        ``_RATIONAL_LIMIT`` states, by policy iteration in rational arithmetic (probabilities read
        as the decimals the model was written with); None for anything else."""
        from posgmc.engines.rational import exact_rational_reach

        path = expr.path if isinstance(expr, ProbQuery) else None
        if (
            path is not None
            and self.model.num_states <= _RATIONAL_LIMIT
            and is_temporal(path)
            and not _is_simple_path(path)
        ):
            if self.model.model_type.is_game:
                return None
            fractions = self._omega_fractions(
                path, self._maximize(expr), limit=_RATIONAL_LIMIT, everywhere=True
            )
            if fractions is None:
                return None
            return _outward_values(fractions)
        if (
            path is None
            or self.model.num_states > _RATIONAL_LIMIT
            or not isinstance(path, Temporal)
            or path.bound is not None
            or path.op not in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL)
            or any(is_temporal(o) for o in path.operands)
        ):
            return None
        if path.op is TemporalOp.UNTIL:
            remain, target = self._states(path.operands[0]), self._states(path.operands[1])
        else:
            remain, target = None, self._states(path.operands[0])
        values = exact_rational_reach(
            self.model, target, remain=remain, maximize=self._maximize(expr)
        )
        return _outward_values(values)

    # -- queries -------------------------------------------------------------------------------

    def _maximize(self, expr: ProbQuery | RewardQuery) -> np.ndarray:
        players = self.coalition_of(expr.coalition)
        return obj.maximize_mask(self.model, direction=self.direction_of(expr), coalition=players)

    def direction_of(self, expr: ProbQuery | RewardQuery) -> Direction:
        """The direction in which the query's coalition optimises (a threshold decides it when
        none is written: ``P>=p`` on an MDP means "for all schedulers", so the minimum)."""
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
                # PRISM and Storm refuse to guess which optimum is meant
                kind = "P" if isinstance(expr, ProbQuery) else "R"
                raise SemanticError(
                    f"{kind}=? on {_article(self.model.model_type.value)} needs a direction: the "
                    "value depends on how the nondeterminism is resolved",
                    expr.span,
                    hint=f"write {kind}max=? or {kind}min=?",
                )
            else:
                direction = Direction.MAX  # dtmc: irrelevant
        return direction

    def query(self, expr: ProbQuery | RewardQuery, *, everywhere: bool = True) -> QueryValue:
        """The query's value in every state (``everywhere``), or where only the initial states'
        values are read (a top-level query): then an LTL product follows the initial states'
        paths only, and other states' values are NaN."""
        maximize = self._maximize(expr)
        self._everywhere = everywhere
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
        if isinstance(path, Unary) and path.op is UnaryOp.NOT and is_temporal(path.operand):
            return _flip(self._probability(path.operand, ~maximize))
        if isinstance(path, Temporal) and all(not is_temporal(o) for o in path.operands):
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

    # -- LTL -------------------------------------------------------------------------------

    def _ltl_product(self, path: Expr):  # type: ignore[no-untyped-def]
        from posgmc.engines import ltl

        everywhere = self._everywhere  # read before the atoms' own (nested) queries reset it
        atoms = ltl.extract_atoms(path)
        ltl.check_atoms(path, atoms)  # before evaluating them
        atom_values = self._atom_values(atoms)
        starts = np.arange(self.model.num_states) if everywhere else None
        # the automaton over the letters of this model, in its orders, not all 2**n
        graph = ltl.letter_graph(self.model, atom_values, starts)
        dfa = ltl.to_dfa(path, atoms, alphabet=graph)
        return ltl.product(self.model, dfa, atom_values, starts=starts), starts

    def _ltl_probability(self, path: Expr, maximize: np.ndarray) -> QueryValue:
        from posgmc.engines import ltl

        if not ltl.is_cosafe(path):
            negated = Unary(UnaryOp.NOT, path, span=path.span)
            if ltl.is_cosafe(negated):
                return _flip(self._ltl_probability(negated, ~maximize))
            return self._omega_probability(path, maximize)
        prod, starts = self._ltl_product(path)
        pmax = maximize[prod.state_of]
        r = obj.reach_probability(
            prod.model, prod.accepting, maximize=pmax, options=self.options.solver
        )
        return self._project(prod, _from_engine(r), starts)

    def _omega_probability(self, path: Expr, maximize: np.ndarray) -> QueryValue:
        """General (not co-safe) LTL on a dtmc or mdp: the LDBA product's maximal probability of
        reaching an accepting end component; a minimum through the negation, ``Pmin(phi) =
        1 - Pmax(!phi)`` (:mod:`posgmc.engines.ltl.omega`)."""
        from posgmc.engines import ltl

        if self._omega_minimises(path, maximize):
            negated = Unary(UnaryOp.NOT, path, span=path.span)
            return _flip(self._omega_probability(negated, ~maximize))
        prod, starts = self._omega_product(path)
        goal = ltl.accepting_end_components(prod)
        everyone = np.ones(prod.num_states, dtype=bool)
        r = obj.reach_probability(prod.model, goal, maximize=everyone, options=self.options.solver)
        q = _from_engine(r)
        return self._project(prod, replace(q, method=f"LTL via LDBA ({q.method})"), starts)

    def _omega_minimises(self, path: Expr, maximize: np.ndarray) -> bool:
        """Whether a general LTL query asks a minimum (answered as ``1 - Pmax(!phi)``).

        Raises:
            UnsupportedError: on a game (the LDBA is good for one optimiser only)."""
        if self.model.model_type.is_game:
            raise UnsupportedError(
                f"LTL that is neither co-safe nor safety is not supported on "
                f"{_article(self.model.model_type.value)}; on games posgmc checks co-safe LTL "
                "(X, F, U, bounded G) and its negation",
                path.span,
                hint="non-co-safe LTL (G F, F G, ...) is supported on dtmcs and mdps",
            )
        return self.model.model_type.is_nondeterministic and not bool(np.all(maximize))

    def _omega_fractions(
        self, path: Expr, maximize: np.ndarray, *, limit: int, everywhere: bool
    ) -> list[Fraction | None] | None:
        """A general LTL probability in rational arithmetic: per state (None where the product
        did not start), or None when the product has more than ``limit`` states."""
        from posgmc.engines import ltl
        from posgmc.engines.rational import exact_rational_reach

        minimise = self._omega_minimises(path, maximize)
        if minimise:
            path = Unary(UnaryOp.NOT, path, span=path.span)
        prod, starts = self._omega_product(path, everywhere=everywhere)
        if prod.num_states > limit:
            return None
        goal = ltl.accepting_end_components(prod)
        reach = exact_rational_reach(
            prod.model, goal, maximize=np.ones(prod.num_states, dtype=bool)
        )
        out: list[Fraction | None] = [None] * self.model.num_states
        origin = self.model.initial_states if starts is None else starts
        for s, p in zip(origin.tolist(), prod.initial_map.tolist()):
            out[s] = 1 - reach[p] if minimise else reach[p]
        return out

    def _omega_product(self, path: Expr, *, everywhere: bool | None = None):  # type: ignore[no-untyped-def]
        """The product of the model with the LDBA of ``path`` (over the model's letters), from
        every state (``everywhere``; default: as the current query needs) or the initial ones."""
        from posgmc.engines import ltl

        everywhere = self._everywhere if everywhere is None else everywhere
        atoms = ltl.extract_atoms(path)
        ltl.check_atoms(path, atoms)
        atom_values = self._atom_values(atoms)
        starts = np.arange(self.model.num_states) if everywhere else None
        alphabet = np.unique(ltl.pack_letters(atom_values))
        ldba = ltl.to_ldba(path, atoms, alphabet=alphabet)
        return ltl.omega_product(self.model, ldba, atom_values, starts=starts), starts

    def _atom_values(self, atoms: tuple[Expr, ...]) -> np.ndarray:
        """bool[len(atoms), S]: where each atom holds."""
        if atoms:
            return np.stack([self._states(a) for a in atoms])
        return np.zeros((0, self.model.num_states), dtype=bool)

    def _project(self, prod, q: QueryValue, starts: np.ndarray | None) -> QueryValue:  # type: ignore[no-untyped-def]
        """Values of the original states: those of the product state each starts in.

        With ``starts`` None the product followed the initial states only, and the other states
        get NaN; a nested query's product starts in every state."""
        S = self.model.num_states
        start = np.full(S, -1, dtype=np.int64)
        start[self.model.initial_states if starts is None else starts] = prod.initial_map

        def pick(a: np.ndarray) -> np.ndarray:
            out = np.full(S, np.nan)
            ok = start >= 0
            out[ok] = a[start[ok]]
            return out

        return replace(
            q, values=pick(q.values), lower=pick(q.lower), upper=pick(q.upper), engine=q.engine
        )

    # -- rewards -------------------------------------------------------------------------------

    def _reward(self, expr: RewardQuery, maximize: np.ndarray) -> QueryValue:
        m, opts = self.model, self.options.solver
        rm = reward_structure(m, expr)
        objective = expr.objective
        kind = objective.kind
        choice_rewards = rm.choice_rewards(m.row_groups)
        if kind is RewardKind.STEADY:
            return self._long_run(choice_rewards)  # a dtmc: one choice per state
        if kind is RewardKind.INSTANTANEOUS:
            k = self._int(objective.bound)
            state_rewards = rm.state if rm.state is not None else np.zeros(m.num_states)
            return _from_engine(
                obj.instantaneous_reward(m, state_rewards, steps=k, maximize=maximize, options=opts)
            )
        if kind is RewardKind.CUMULATIVE:
            k = self._int(objective.bound)
            return _from_engine(
                obj.cumulative_reward(m, choice_rewards, steps=k, maximize=maximize, options=opts)
            )
        if kind is RewardKind.TOTAL:
            return _from_engine(
                obj.total_reward(m, choice_rewards, maximize=maximize, options=opts)
            )
        if kind is RewardKind.DISCOUNTED_TOTAL:
            g = self._discount(objective.discount)
            return _from_engine(
                obj.discounted_total_reward(
                    m, choice_rewards, discount=g, maximize=maximize, options=opts
                )
            )
        assert objective.target is not None  # noqa: S101 - the parser gives F/F0/Fc/LTL a target
        if kind is RewardKind.DISCOUNTED_REACH:
            g = self._discount(objective.discount)
            t = self._states(objective.target)
            return _from_engine(
                obj.discounted_reach_reward(
                    m, choice_rewards, t, discount=g, maximize=maximize, options=opts
                )
            )
        mode = {
            RewardKind.REACH: obj.ReachRewardMode.INFINITY,
            RewardKind.REACH_ZERO: obj.ReachRewardMode.ZERO,
            RewardKind.REACH_CUMULATIVE: obj.ReachRewardMode.CUMULATIVE,
            RewardKind.LTL: obj.ReachRewardMode.INFINITY,
        }[kind]
        target_expr = objective.target
        if kind is RewardKind.LTL or is_temporal(target_expr):
            return self._ltl_reward(expr, target_expr, maximize, mode)
        t = self._states(target_expr)
        return _from_engine(
            obj.expected_reach_reward(
                m, choice_rewards, t, maximize=maximize, mode=mode, options=opts
            )
        )

    def _ltl_reward(
        self, expr: RewardQuery, path: Expr, maximize: np.ndarray, mode: obj.ReachRewardMode
    ) -> QueryValue:
        from posgmc.engines import ltl

        if not ltl.is_cosafe(path):
            raise UnsupportedError(
                "expected rewards need a co-safe LTL objective; this formula is not co-safe",
                path.span,
                hint="use X, F, U and bounded G (a finite prefix must decide the formula)",
            )
        prod, starts = self._ltl_product(path)
        rm = reward_structure(prod.model, expr)
        rewards = rm.choice_rewards(prod.model.row_groups)
        pmax = maximize[prod.state_of]
        r = obj.expected_reach_reward(
            prod.model,
            rewards,
            prod.accepting,
            maximize=pmax,
            mode=mode,
            options=self.options.solver,
        )
        return self._project(prod, _from_engine(r), starts)

    def _long_run(self, weight: np.ndarray) -> QueryValue:
        """The long-run average of a per-state weight (S, R[S]; dtmcs)."""
        r = long_run_average(self.model, weight, options=self.options.solver)
        return QueryValue(r.values, r.lower, r.upper, iterations=r.iterations,
                          converged=r.converged, sound=r.sound,
                          method="steady state (exact BSCCs)" if r.sound else "steady state")

    def for_model(self, model: ExplicitModel) -> PropertyChecker:
        """A checker of the same queries, constants and options on another model (a product)."""
        return PropertyChecker(
            model, coalition_of=self.coalition_of, scalar=self.scalar, options=self.options
        )

    def step_bound(self, e: Expr | None) -> int:
        """A step bound's value: a non-negative integer (SemanticError with its position)."""
        return self._int(e)

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
        g = float(self.scalar(e))
        if not 0.0 <= g < 1.0:
            raise SemanticError(f"the discount factor {g:g} is not in [0, 1)", e.span)
        return g


_RATIONAL_LIMIT = 300
"""Models up to this many states may be solved in rational arithmetic to decide a threshold."""


def _outward_values(values: list[Fraction] | list[Fraction | None]) -> QueryValue:
    """Fractions rounded outwards to the floats around them: bounds that hold (None: NaN, a
    state the computation did not cover)."""
    nearest = np.array([np.nan if v is None else float(v) for v in values])
    below = np.array([v is not None and float(v) > v for v in values])
    above = np.array([v is not None and float(v) < v for v in values])
    lower = np.where(below, np.nextafter(nearest, -np.inf), nearest)
    upper = np.where(above, np.nextafter(nearest, np.inf), nearest)
    return QueryValue((lower + upper) / 2, lower, upper, method="exact (rational)")


def _is_simple_path(path: Expr) -> bool:
    """One temporal operator over state formulas (what the reachability engines answer)."""
    return isinstance(path, Temporal) and not any(is_temporal(o) for o in path.operands)


def _article(model_type: str) -> str:
    """``mdp`` -> "an MDP" (the article as the abbreviation is spoken)."""
    name = model_type.upper()
    return f"an {name}" if name[0] in "AEFHILMNORSX" else f"a {name}"
