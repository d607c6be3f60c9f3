"""format_expr prints PRISM text that parses back to the same tree (hypothesis round trip)."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.syntax.ast import (
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
    Function,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    PlayerRef,
    ProbQuery,
    RewardKind,
    RewardObjective,
    RewardQuery,
    Temporal,
    TemporalOp,
    Threshold,
    TimeBound,
    Unary,
    UnaryOp,
)
from posgmc.syntax.parser import parse_expression
from posgmc.syntax.printer import format_decimal, format_expr
from posgmc.syntax.transformer import contains_temporal

NAMES = ["a", "b", "x1", "y_2", "N", "sched", "time", "_t", "Fx", "Rmax2"]
ARITY = {
    Function.MIN: 2,
    Function.MAX: 3,
    Function.FLOOR: 1,
    Function.CEIL: 1,
    Function.ROUND: 1,
    Function.POW: 2,
    Function.MOD: 2,
    Function.LOG: 2,
}

# --- model expressions ----------------------------------------------------------------------------

leaves = st.one_of(
    st.sampled_from(NAMES).map(Ident),
    st.integers(min_value=0, max_value=10**6).map(IntLit),
    st.builds(
        lambda n, k: DoubleLit(Fraction(n, 10**k)),
        st.integers(min_value=0, max_value=10**5),
        st.integers(min_value=0, max_value=6),
    ),
    st.booleans().map(BoolLit),
)


def _compound(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    calls = st.sampled_from(list(ARITY)).flatmap(
        lambda f: st.lists(children, min_size=ARITY[f], max_size=ARITY[f]).map(
            lambda args: Call(f, tuple(args))
        )
    )
    return st.one_of(
        st.builds(Unary, st.sampled_from(list(UnaryOp)), children),
        st.builds(Binary, st.sampled_from(list(BinaryOp)), children, children),
        st.builds(Ite, children, children, children),
        calls,
    )


model_exprs = st.recursive(leaves, _compound, max_leaves=12)

# --- property expressions -------------------------------------------------------------------------

state_leaves = st.one_of(leaves, st.sampled_from(["goal", "init", "a1"]).map(LabelRef))
plain_states = st.recursive(state_leaves, _compound, max_leaves=6)

bounds = st.one_of(
    st.none(),
    st.builds(lambda e: TimeBound(upper=e), plain_states),
    st.builds(lambda e: TimeBound(upper=e, upper_strict=True), plain_states),
    st.builds(lambda e: TimeBound(lower=e), plain_states),
    st.builds(lambda e: TimeBound(lower=e, lower_strict=True), plain_states),
    st.builds(lambda e: TimeBound(lower=e, upper=e), plain_states),
    st.builds(lambda lo, hi: TimeBound(lower=lo, upper=hi), plain_states, plain_states),
)


def _paths(states: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    def extend(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
        unary = st.builds(
            lambda op, e, bd: Temporal(op, (e,), bd),
            st.sampled_from([TemporalOp.NEXT, TemporalOp.EVENTUALLY, TemporalOp.GLOBALLY]),
            children,
            bounds,
        )
        binary = st.builds(
            lambda op, left, right, bd: Temporal(op, (left, right), bd),
            st.sampled_from([TemporalOp.UNTIL, TemporalOp.WEAK_UNTIL, TemporalOp.RELEASE]),
            children,
            children,
            bounds,
        )
        boolean = st.builds(
            Binary, st.sampled_from([BinaryOp.AND, BinaryOp.OR]), children, children
        )
        negation = st.builds(lambda e: Unary(UnaryOp.NOT, e), children)
        return st.one_of(unary, binary, boolean, negation)

    return st.recursive(states, extend, max_leaves=5)


coalitions = st.one_of(
    st.none(),
    st.just(Coalition((), all_players=True)),
    st.builds(
        lambda players, kind: Coalition(tuple(players), kind=kind),
        st.lists(
            st.one_of(
                st.sampled_from(["p1", "P", "investor"]).map(lambda n: PlayerRef(name=n)),
                st.integers(min_value=0, max_value=9).map(lambda n: PlayerRef(number=n)),
            ),
            max_size=3,
        ),
        st.sampled_from(list(CoalitionKind)),
    ),
)


def _query_heads() -> st.SearchStrategy[tuple[Direction | None, Threshold | None]]:
    thresholds = st.builds(Threshold, st.sampled_from(list(ComparisonOp)), plain_states)
    return st.one_of(
        st.tuples(st.sampled_from([None, Direction.MIN, Direction.MAX]), st.none()),
        st.tuples(st.none(), thresholds),
    )


def _is_plain_reach(path: Expr) -> bool:
    return (
        isinstance(path, Temporal)
        and path.op is TemporalOp.EVENTUALLY
        and path.bound is None
        and not contains_temporal(path.operands[0])
    )


objectives = st.one_of(
    st.builds(lambda t: RewardObjective(RewardKind.REACH, target=t), plain_states),
    st.builds(lambda t: RewardObjective(RewardKind.REACH_ZERO, target=t), plain_states),
    st.builds(lambda t: RewardObjective(RewardKind.REACH_CUMULATIVE, target=t), plain_states),
    st.builds(lambda b: RewardObjective(RewardKind.CUMULATIVE, bound=b), plain_states),
    st.just(RewardObjective(RewardKind.TOTAL)),
    st.builds(lambda b: RewardObjective(RewardKind.INSTANTANEOUS, bound=b), plain_states),
    st.builds(lambda g: RewardObjective(RewardKind.DISCOUNTED_TOTAL, discount=g), plain_states),
    st.builds(
        lambda g, t: RewardObjective(RewardKind.DISCOUNTED_REACH, target=t, discount=g),
        plain_states,
        plain_states,
    ),
    _paths(plain_states)
    .filter(lambda p: not _is_plain_reach(p))
    .map(lambda p: RewardObjective(RewardKind.LTL, target=p)),
)

prob_queries = st.builds(
    lambda c, head, path: ProbQuery(c, head[0], head[1], path),
    coalitions,
    _query_heads(),
    _paths(plain_states),
)
reward_queries = st.builds(
    lambda c, r, head, obj: RewardQuery(c, r, head[0], head[1], obj),
    coalitions,
    st.one_of(st.none(), st.sampled_from(["cost", "value12"]), st.integers(1, 3)),
    _query_heads(),
    objectives,
)
property_exprs = st.recursive(
    st.one_of(state_leaves, prob_queries, reward_queries), _compound, max_leaves=4
)


@settings(max_examples=150, deadline=None)
@given(model_exprs)
def test_model_expression_round_trip(expr: Expr) -> None:
    text = format_expr(expr)
    assert parse_expression(text, model=True) == expr, text


@settings(max_examples=80, deadline=None)
@given(property_exprs)
def test_property_expression_round_trip(expr: Expr) -> None:
    text = format_expr(expr)
    assert parse_expression(text) == expr, text


@settings(max_examples=80, deadline=None)
@given(_paths(plain_states))
def test_path_formula_round_trip(expr: Expr) -> None:
    text = format_expr(expr)
    assert parse_expression(text) == expr, text


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (Fraction(1, 10), "0.1"),
        (Fraction(3), "3.0"),
        (Fraction(1, 8), "0.125"),
        (Fraction(19, 20), "0.95"),
        (Fraction(0), "0.0"),
        (Fraction(1, 3), "(1/3)"),
    ],
)
def test_format_decimal(value: Fraction, text: str) -> None:
    assert format_decimal(value) == text


@pytest.mark.parametrize(
    ("source", "printed"),
    [
        ('<<1>> Pmax=? [ F<=k c=2 ]', "<<1>> Pmax=? [ F<=k (c = 2) ]"),
        (
            '<<p1,p2>> R{"v"}max=? [F time=max_time]',
            '<<p1,p2>> R{"v"}max=? [ F (time = max_time) ]',
        ),
        (
            'P>=0.9 [ !"hazard" U ("goal1" & (X "goal1")) ]',
            'P>=0.9 [ !"hazard" U ("goal1" & (X "goal1")) ]',
        ),
        ('Rmin=? [ (F "a") | (F "b") ]', 'Rmin=? [ (F "a") | (F "b") ]'),
        ("[[*]] R=? [ C<=10 ]", "[[*]] R=? [ C<=10 ]"),
        ('R{2}>=5 [ Fdiscount=0.9 "a" ]', 'R{2}>=5 [ Fdiscount=0.9 "a" ]'),
        ("!(a = b)", "!(a = b)"),
        ("a - (b - c)", "a - (b - c)"),
        ("(a => b) => c", "(a => b) => c"),
        ("-(-x)", "-(-x)"),
        ("F<=(T-1) x", "F<=(T - 1) x"),
    ],
)
def test_printed_text(source: str, printed: str) -> None:
    assert format_expr(parse_expression(source)) == printed
