"""The parse actions of expressions and properties: literals, names, calls, temporal operators,
step bounds, coalitions and ``P``/``R`` queries."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from lark import Token

from posgmc.errors import ParseError, SourceSpan
from posgmc.syntax.actions_base import ActionBase
from posgmc.syntax.ast import (
    FILTER_ALIASES,
    FUNCTION_ARITY,
    INT64_MAX,
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    Coalition,
    CoalitionKind,
    ComparisonOp,
    Direction,
    DoubleLit,
    Expr,
    Filter,
    FilterOp,
    Function,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    MultiQuery,
    PathQuantifier,
    PlayerRef,
    ProbQuery,
    RewardKind,
    RewardObjective,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TemporalOp,
    Threshold,
    TimeBound,
    Unary,
    UnaryOp,
)
from posgmc.syntax.items import AllPlayers, PropertyItem, QueryOp
from posgmc.syntax.placement import contains_temporal

# Decimal exponents beyond this are rejected: doubles overflow long before (1e308).
_MAX_EXPONENT = 400
_MAX_DIGITS = 1000


def _negate_leftmost(e: Expr, span: SourceSpan) -> Expr:
    """``-`` written before ``e``: unary minus binds tighter than every binary operator, so it
    applies to the leftmost operand (``-a + b`` is ``(-a) + b``)."""
    if isinstance(e, Binary):
        return dataclasses.replace(e, left=_negate_leftmost(e.left, span))
    if isinstance(e, Ite):
        return dataclasses.replace(e, cond=_negate_leftmost(e.cond, span))
    start = SourceSpan(span.line, span.column, e.span.end_line, e.span.end_column, span.file)
    return Unary(UnaryOp.NEG, e, span=start)


@dataclass(frozen=True)
class _OldFilter:
    """PRISM's old ``{states}{min}{max}`` suffix inside a query (``PrismParser.jj``, ``Filter``):
    a threshold query is checked for all of ``states``; otherwise ``{min}``, ``{max}``, both
    (the range) or neither (the value in the one state satisfying ``states``)."""

    states: Expr
    minimum: bool
    maximum: bool

    def wrap(self, query: ProbQuery | RewardQuery, span: SourceSpan) -> Filter:
        if query.threshold is not None:
            op = FilterOp.FORALL
        elif self.minimum:
            op = FilterOp.RANGE if self.maximum else FilterOp.MIN
        else:
            op = FilterOp.MAX if self.maximum else FilterOp.STATE
        return Filter(op, query, self.states, span=span)


class ExpressionActions(ActionBase):
    """Actions for the expression and property rules of the grammar (see :class:`ActionBase`)."""

    # --- properties ------------------------------------------------------------------------------

    def property(self, span: SourceSpan, children: Sequence[Expr]) -> PropertyItem:
        return PropertyItem(children[0], None, span)

    def named_property(self, span: SourceSpan, children: Sequence[Any]) -> PropertyItem:
        return PropertyItem(children[1], str(children[0].value)[1:-1], span)

    def minus_property(self, span: SourceSpan, children: Sequence[Expr]) -> PropertyItem:
        return PropertyItem(_negate_leftmost(children[0], span), None, span)

    def named_minus_property(self, span: SourceSpan, children: Sequence[Any]) -> PropertyItem:
        return PropertyItem(_negate_leftmost(children[1], span), str(children[0].value)[1:-1], span)

    # --- expressions -----------------------------------------------------------------------------

    def ite(self, span: SourceSpan, children: Sequence[Expr]) -> Ite:
        return Ite(children[0], children[1], children[2], span=span)

    # The binary operators (implies, iff, or_, and_, eq, ne, lt, le, gt, ge, add, sub, mul, div)
    # have no method: rule_actions builds them directly from _BINARY_OPS, the hottest path.

    def not_(self, span: SourceSpan, children: Sequence[Expr]) -> Unary:
        return Unary(UnaryOp.NOT, children[0], span=span)

    def neg(self, span: SourceSpan, children: Sequence[Expr]) -> Unary:
        return Unary(UnaryOp.NEG, children[0], span=span)

    def int_lit(self, span: SourceSpan, children: Sequence[Token]) -> IntLit:
        text = str(children[0].value)
        # ints are 64-bit (docs/language.md); also keeps int() off 5000-digit strings
        if len(text.lstrip("0")) > 19 or int(text) > INT64_MAX:
            self._fail(
                ParseError(
                    f"the integer {text if len(text) <= 30 else text[:20] + '...'} is beyond "
                    f"64-bit integers (at most {INT64_MAX})",
                    span,
                    hint="write a double (e.g. 1e20) if an approximate value will do",
                )
            )
            return IntLit(0, span=span)
        return IntLit(int(text), span=span)

    def double_lit(self, span: SourceSpan, children: Sequence[Token]) -> DoubleLit:
        text = str(children[0].value)
        mantissa, _, exponent = text.lower().partition("e")
        # an exact Fraction of 1e999999999 would be a billion-digit integer, and Python refuses
        # to convert more than 4300 digits
        if len(mantissa) > _MAX_DIGITS:
            shown = text[:20] + "..."
            self._fail(
                ParseError(f"the number {shown} has more than {_MAX_DIGITS} digits", span)
            )
            return DoubleLit(Fraction(0), span=span)
        if exponent and abs(_small_int(exponent)) > _MAX_EXPONENT:
            self._fail(
                ParseError(
                    f"the number {text} is out of range (exponent beyond ±{_MAX_EXPONENT})", span
                )
            )
            return DoubleLit(Fraction(0), span=span)
        return DoubleLit(_fraction(text), span=span)

    def true_lit(self, span: SourceSpan, children: Sequence[Any]) -> BoolLit:
        return BoolLit(True, span=span)

    def false_lit(self, span: SourceSpan, children: Sequence[Any]) -> BoolLit:
        return BoolLit(False, span=span)

    def ident(self, span: SourceSpan, children: Sequence[Token]) -> Ident:
        return Ident(str(children[0].value), span=span)

    def label_ref(self, span: SourceSpan, children: Sequence[Token]) -> LabelRef:
        return LabelRef(self._quoted_identifier(children[0], "label"), span=span)

    def _make_call(self, name_token: Token, args: Sequence[Expr], span: SourceSpan) -> Call:
        name = str(name_token.value)
        try:
            function = Function(name)
        except ValueError:
            self._fail(
                ParseError(
                    f"'{name}' is not a function",
                    self._tspan(name_token),
                    hint="the functions are min, max, floor, ceil, round, pow, mod and log",
                )
            )
            # a stand-in with the same operands, so that the parse can go on
            return Call(Function.MIN, tuple(args), span=span)
        low, high = FUNCTION_ARITY[function]
        if len(args) < low or (high is not None and len(args) > high):
            if low == high:
                wanted = f"{low}"
            else:
                wanted = f"at least {low}" if high is None else f"{low}-{high}"
            self._fail(
                ParseError(
                    f"{name} takes {wanted} argument{'s' if low != 1 or high is None else ''}, "
                    f"not {len(args)}",
                    span,
                )
            )
        return Call(function, tuple(args), span=span)

    def call(self, span: SourceSpan, children: Sequence[Any]) -> Call:
        return self._make_call(children[0], children[1:], span)

    def old_call(self, span: SourceSpan, children: Sequence[Any]) -> Call:
        return self._make_call(children[0], children[1:], span)

    def power(self, span: SourceSpan, children: Sequence[Expr]) -> Call:
        """``a ^ b`` is PRISM's ``pow(a, b)``: one operator with one meaning."""
        return Call(Function.POW, (children[0], children[1]), span=span)

    # --- temporal operators ----------------------------------------------------------------------

    def _temporal(self, op: TemporalOp, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        bound = next((c for c in children if isinstance(c, TimeBound)), None)
        operands = tuple(c for c in children if not isinstance(c, TimeBound))
        return Temporal(op, operands, bound, span=span)

    def next(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.NEXT, span, children)

    def eventually(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.EVENTUALLY, span, children)

    def globally(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.GLOBALLY, span, children)

    def until(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.UNTIL, span, children)

    def weak_until(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.WEAK_UNTIL, span, children)

    def release(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.RELEASE, span, children)

    def bound_le(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], span=span)

    def bound_lt(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], upper_strict=True, span=span)

    def bound_ge(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], span=span)

    def bound_gt(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], lower_strict=True, span=span)

    def bound_eq(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[0], span=span)

    def bound_interval(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[1], span=span)

    # --- queries ---------------------------------------------------------------------------------

    def coalition_angle(self, span: SourceSpan, children: Sequence[Any]) -> Coalition:
        return self._coalition(CoalitionKind.ANGLE, span, children)

    def coalition_bracket(self, span: SourceSpan, children: Sequence[Any]) -> Coalition:
        return self._coalition(CoalitionKind.BRACKET, span, children)

    def _coalition(
        self, kind: CoalitionKind, span: SourceSpan, children: Sequence[Any]
    ) -> Coalition:
        if children and isinstance(children[0], AllPlayers):
            return Coalition((), True, kind, span=span)
        players = tuple(children[0]) if children else ()
        return Coalition(players, False, kind, span=span)

    def all_players(self, span: None, children: Sequence[Any]) -> AllPlayers:
        return AllPlayers()

    def player_list(self, span: None, children: Sequence[Token]) -> tuple[PlayerRef, ...]:
        refs = []
        for tok in children:
            if tok.type == "INT":
                refs.append(PlayerRef(number=_small_int(str(tok.value)), span=self._tspan(tok)))
            else:
                refs.append(PlayerRef(name=str(tok.value), span=self._tspan(tok)))
        return tuple(refs)

    def relop(self, span: None, children: Sequence[Token]) -> ComparisonOp:
        return ComparisonOp(str(children[0].value))

    def reward_index(self, span: None, children: Sequence[Token]) -> str | int:
        tok = children[0]
        if tok.type == "INT":
            return _small_int(str(tok.value))
        return self._quoted_identifier(tok, "reward structure")

    def _reward_of(self, children: Sequence[Any]) -> str | int | None:
        return next((c for c in children if isinstance(c, (str, int))), None)

    def op_value(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(None, None, self._reward_of(children))

    def op_min(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(Direction.MIN, None, self._reward_of(_no_tokens(children)))

    def op_max(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(Direction.MAX, None, self._reward_of(_no_tokens(children)))

    def op_threshold(self, span: SourceSpan, children: Sequence[Any]) -> QueryOp:
        op: ComparisonOp = children[-2]
        value: Expr = children[-1]
        threshold = Threshold(op, value, span=span)
        return QueryOp(None, threshold, self._reward_of(children[:-2]))

    def prob_query(self, span: SourceSpan, children: Sequence[Any]) -> ProbQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return ProbQuery(coalition, op.direction, op.threshold, children[-1], span=span)

    def filter(self, span: SourceSpan, children: Sequence[Any]) -> Filter:
        token: Token = children[1]
        name = str(token.value)
        op = FILTER_ALIASES.get(name)
        if op is None:
            try:
                op = FilterOp(name)
            except ValueError:
                names = ", ".join(o.value for o in FilterOp)
                self._fail(ParseError(f"'{name}' is not a filter operator", self._tspan(token),
                                      hint=f"the filter operators are {names} (and +, &, |)"))
                op = FilterOp.FORALL  # a stand-in: the parse goes on, the error ends it
        return Filter(op, children[2], children[3] if len(children) > 3 else None, span=span)

    def steady_value(self, span: SourceSpan, children: Sequence[Any]) -> SteadyQuery:
        return SteadyQuery(None, children[-1], span=span)

    def steady_threshold(self, span: SourceSpan, children: Sequence[Any]) -> SteadyQuery:
        op, bound, operand = children[-3:]
        return SteadyQuery(Threshold(op, bound, span=span), operand, span=span)

    def forall_paths(self, span: SourceSpan, children: Sequence[Any]) -> PathQuantifier:
        return PathQuantifier(True, children[1], span=span)

    def exists_paths(self, span: SourceSpan, children: Sequence[Any]) -> PathQuantifier:
        return PathQuantifier(False, children[1], span=span)

    def filter_op(self, span: SourceSpan, children: Sequence[Any]) -> Token:
        token: Token = children[0]
        return token

    def old_filter(self, span: SourceSpan, children: Sequence[Any]) -> _OldFilter:
        mods = {str(t.value) for t in children[1:]}
        return _OldFilter(children[0], "min" in mods, "max" in mods)

    def prob_query_old_filter(self, span: SourceSpan, children: Sequence[Any]) -> Filter:
        old: _OldFilter = children[-1]
        return old.wrap(self.prob_query(span, children[:-1]), span)

    def reward_query_old_filter(self, span: SourceSpan, children: Sequence[Any]) -> Filter:
        old: _OldFilter = children[-1]
        return old.wrap(self.reward_query(span, children[:-1]), span)

    def reward_query(self, span: SourceSpan, children: Sequence[Any]) -> RewardQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return RewardQuery(
            coalition, op.reward, op.direction, op.threshold, children[-1], span=span
        )

    def multi_query(self, span: SourceSpan, children: Sequence[Any]) -> MultiQuery:
        return MultiQuery(tuple(c for c in children if not isinstance(c, Token)), span=span)

    def coalition_multi(self, span: SourceSpan, children: Sequence[Any]) -> MultiQuery:
        coalition, body = children[0], children[-1]
        parts: list[Expr] = []
        stack = [body]
        while stack:  # the conjuncts, left to right
            e = stack.pop()
            if isinstance(e, Binary) and e.op is BinaryOp.AND:
                stack += [e.right, e.left]
            else:
                parts.append(e)
        return MultiQuery(tuple(parts), coalition, span=span)

    def rew_cumulative(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.CUMULATIVE, bound=children[0], span=span)

    def rew_total(self, span: SourceSpan, children: Sequence[Any]) -> RewardObjective:
        return RewardObjective(RewardKind.TOTAL, span=span)

    def rew_instantaneous(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.INSTANTANEOUS, bound=children[0], span=span)

    def rew_reach_cumulative(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.REACH_CUMULATIVE, target=children[0], span=span)

    def rew_reach_zero(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.REACH_ZERO, target=children[0], span=span)

    def rew_discounted_total(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.DISCOUNTED_TOTAL, discount=children[0], span=span)

    def rew_discounted_reach(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(
            RewardKind.DISCOUNTED_REACH, target=children[1], discount=children[0], span=span
        )

    def rew_path(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        path = children[0]
        if (
            isinstance(path, Temporal)
            and path.op is TemporalOp.EVENTUALLY
            and path.bound is None
            and not contains_temporal(path.operands[0])
        ):
            return RewardObjective(RewardKind.REACH, target=path.operands[0], span=span)
        if isinstance(path, Ident) and path.name == "S":
            return RewardObjective(RewardKind.STEADY, span=span)
        return RewardObjective(RewardKind.LTL, target=path, span=span)


def _no_tokens(children: Sequence[Any]) -> list[Any]:
    return [c for c in children if not isinstance(c, Token)]


@functools.lru_cache(maxsize=4096)
def _fraction(text: str) -> Fraction:
    # Fraction(str) parses with a regular expression; generated models repeat a few literals
    # (0.5, 0.1, ...) thousands of times, and a Fraction is immutable, so one may be shared.
    return Fraction(text)


def _small_int(text: str) -> int:
    """``int(text)`` for an index or exponent; beyond 18 digits it is just "too large" (and
    Python refuses to convert more than 4300 digits at all)."""
    sign = -1 if text.startswith("-") else 1
    digits = text.lstrip("+-").lstrip("0") or "0"
    return sign * (int(digits) if len(digits) <= 18 else 10**18)
