"""Expressions: PRISM precedence, exact literals, calls, temporal operators, spans; the grammar."""

from __future__ import annotations

from fractions import Fraction

import pytest
from lark.parsers.lalr_analysis import LALR_Analyzer

from posgmc.errors import ParseError, SourceSpan
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    DoubleLit,
    Function,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    Temporal,
    TemporalOp,
    TimeBound,
    Unary,
    UnaryOp,
)
from posgmc.syntax.lalr import lark_parser
from posgmc.syntax.parser import parse_expression

a, b, c, d = Ident("a"), Ident("b"), Ident("c"), Ident("d")


def B(op: BinaryOp, left: object, right: object) -> Binary:
    return Binary(op, left, right)  # type: ignore[arg-type]


def test_grammar_has_no_lalr_conflicts() -> None:
    # lark's strict mode needs the optional `interegular` package, so run its LALR analysis in
    # strict mode directly: any shift/reduce or reduce/reduce conflict raises GrammarError.
    analyzer = LALR_Analyzer(lark_parser().parser.parser_conf, strict=True)
    analyzer.compute_lalr()


def test_parser_is_built_once() -> None:
    assert lark_parser() is lark_parser()


@pytest.mark.parametrize(
    ("text", "tree"),
    [
        # & binds tighter than |, which binds tighter than =>
        ("a | b & c", B(BinaryOp.OR, a, B(BinaryOp.AND, b, c))),
        ("a => b | c", B(BinaryOp.IMPLIES, a, B(BinaryOp.OR, b, c))),
        # => is right associative, <=> and - are left associative
        ("a => b => c", B(BinaryOp.IMPLIES, a, B(BinaryOp.IMPLIES, b, c))),
        ("a <=> b <=> c", B(BinaryOp.IFF, B(BinaryOp.IFF, a, b), c)),
        ("a - b - c", B(BinaryOp.SUB, B(BinaryOp.SUB, a, b), c)),
        # ! binds weaker than = (PRISM): !a = b is !(a = b)
        ("!a = b", Unary(UnaryOp.NOT, B(BinaryOp.EQ, a, b))),
        ("!a & b", B(BinaryOp.AND, Unary(UnaryOp.NOT, a), b)),
        # relational above equality above arithmetic
        ("a < b = c", B(BinaryOp.EQ, B(BinaryOp.LT, a, b), c)),
        ("a + b * c", B(BinaryOp.ADD, a, B(BinaryOp.MUL, b, c))),
        ("-a * b", B(BinaryOp.MUL, Unary(UnaryOp.NEG, a), b)),
        ("a / b / c", B(BinaryOp.DIV, B(BinaryOp.DIV, a, b), c)),
        # ? : is the loosest and right associative
        ("a ? b : c ? d : a", Ite(a, b, Ite(c, d, a))),
        ("a | b ? c : d", Ite(B(BinaryOp.OR, a, b), c, d)),
        ("(a | b) & c", B(BinaryOp.AND, B(BinaryOp.OR, a, b), c)),
        ("1-s-f", B(BinaryOp.SUB, B(BinaryOp.SUB, IntLit(1), Ident("s")), Ident("f"))),
    ],
)
def test_precedence(text: str, tree: object) -> None:
    assert parse_expression(text) == tree
    assert parse_expression(text, model=True) == tree


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("0.1", Fraction(1, 10)),
        ("1e-3", Fraction(1, 1000)),
        ("2.5E2", Fraction(250)),
        (".5", Fraction(1, 2)),
        ("0.3333333333333333", Fraction(3333333333333333, 10**16)),
    ],
)
def test_double_literals_are_exact(text: str, value: Fraction) -> None:
    assert parse_expression(text) == DoubleLit(value)


def test_int_and_bool_literals() -> None:
    # ints are 64-bit (docs/language.md): the largest literal is 2^63 - 1
    assert parse_expression("9223372036854775807") == IntLit(2**63 - 1)
    for text in ("9223372036854775808", "123456789012345678901", "1" * 5000):
        with pytest.raises(ParseError, match="beyond 64-bit integers") as info:
            parse_expression(text)
        assert info.value.span is not None and info.value.span.column == 1
    assert parse_expression("true") == BoolLit(True)
    assert parse_expression("false", model=True) == BoolLit(False)


def test_range_dots_are_not_a_decimal_point() -> None:
    # `0..N` in `[0..N]` must lex as 0, .., N
    from posgmc.syntax.parser import parse_model

    model = parse_model("mdp module m x : [0..N] init 0; endmodule")
    var = model.modules[0].variables[0]  # type: ignore[union-attr]
    assert (var.low, var.high) == (IntLit(0), Ident("N"))


@pytest.mark.parametrize(
    ("text", "call"),
    [
        ("min(a, b, c)", Call(Function.MIN, (a, b, c))),
        ("max(a, 1)", Call(Function.MAX, (a, IntLit(1)))),
        ("floor(a)", Call(Function.FLOOR, (a,))),
        ("ceil (a)", Call(Function.CEIL, (a,))),
        ("round(a)", Call(Function.ROUND, (a,))),
        ("pow(a, 2)", Call(Function.POW, (a, IntLit(2)))),
        ("mod(a, 2)", Call(Function.MOD, (a, IntLit(2)))),
        ("log(a, 2)", Call(Function.LOG, (a, IntLit(2)))),
        ("func(min, a, b)", Call(Function.MIN, (a, b))),
        ("func(mod, a, b)", Call(Function.MOD, (a, b))),
    ],
)
def test_function_calls(text: str, call: Call) -> None:
    assert parse_expression(text, model=True) == call
    assert parse_expression(text) == call


def test_function_names_are_ordinary_names_without_parentheses() -> None:
    # dice-and-coin has a variable `round`
    assert parse_expression("round < 3", model=True) == B(BinaryOp.LT, Ident("round"), IntLit(3))


def test_property_keywords_are_names_in_model_expressions() -> None:
    # pomdp/drone-4-1 declares `const int R = 1;` and uses `ax-dx < R + 1`
    tree = parse_expression("x < R + F", model=True)
    assert tree == B(BinaryOp.LT, Ident("x"), B(BinaryOp.ADD, Ident("R"), Ident("F")))


def test_time_is_an_identifier() -> None:
    # a keyword in Storm's property language, an ordinary name in PRISM (smg/mdsm2304)
    assert parse_expression("time = max_time") == B(BinaryOp.EQ, Ident("time"), Ident("max_time"))


class TestTemporal:
    def test_f_applies_to_the_whole_state_formula(self) -> None:
        # PRISM: F binds weaker than the boolean operators
        assert parse_expression("F a & b") == Temporal(
            TemporalOp.EVENTUALLY, (B(BinaryOp.AND, a, b),)
        )

    def test_until_binds_weaker_than_unary_operators(self) -> None:
        assert parse_expression("F a U b") == Temporal(
            TemporalOp.UNTIL, (Temporal(TemporalOp.EVENTUALLY, (a,)), b)
        )

    def test_nesting(self) -> None:
        goal = LabelRef("goal1")
        assert parse_expression('F G "goal1"') == Temporal(
            TemporalOp.EVENTUALLY, (Temporal(TemporalOp.GLOBALLY, (goal,)),)
        )
        assert parse_expression('X X "goal1"') == Temporal(
            TemporalOp.NEXT, (Temporal(TemporalOp.NEXT, (goal,)),)
        )
        assert parse_expression('(F "a") | (F "b")') == B(
            BinaryOp.OR,
            Temporal(TemporalOp.EVENTUALLY, (LabelRef("a"),)),
            Temporal(TemporalOp.EVENTUALLY, (LabelRef("b"),)),
        )

    def test_weak_until_and_release(self) -> None:
        assert parse_expression("a W b") == Temporal(TemporalOp.WEAK_UNTIL, (a, b))
        assert parse_expression("a R b") == Temporal(TemporalOp.RELEASE, (a, b))

    @pytest.mark.parametrize(
        ("text", "bound"),
        [
            ("F<=k a", TimeBound(upper=Ident("k"))),
            ("F<5 a", TimeBound(upper=IntLit(5), upper_strict=True)),
            ("F>=2 a", TimeBound(lower=IntLit(2))),
            ("F>2 a", TimeBound(lower=IntLit(2), lower_strict=True)),
            ("F=3 a", TimeBound(lower=IntLit(3), upper=IntLit(3))),
            (
                "F[1,k+1] a",
                TimeBound(lower=IntLit(1), upper=B(BinaryOp.ADD, Ident("k"), IntLit(1))),
            ),
            ("F<=2*k a", TimeBound(upper=B(BinaryOp.MUL, IntLit(2), Ident("k")))),
            ("F<=(T-1) a", TimeBound(upper=B(BinaryOp.SUB, Ident("T"), IntLit(1)))),
        ],
    )
    def test_bounds(self, text: str, bound: TimeBound) -> None:
        assert parse_expression(text) == Temporal(TemporalOp.EVENTUALLY, (a,), bound)

    def test_bound_followed_by_parenthesised_operand(self) -> None:
        # `F<=k (c=2)` is not a call of k (PRISM takes the identifier alone)
        assert parse_expression("F<=k (c=2)") == Temporal(
            TemporalOp.EVENTUALLY,
            (B(BinaryOp.EQ, c, IntLit(2)),),
            TimeBound(upper=Ident("k")),
        )

    def test_bounded_until_and_globally(self) -> None:
        assert parse_expression("a U<=3 b") == Temporal(
            TemporalOp.UNTIL, (a, b), TimeBound(upper=IntLit(3))
        )
        assert parse_expression("G<=3 c!=2") == Temporal(
            TemporalOp.GLOBALLY, (B(BinaryOp.NE, c, IntLit(2)),), TimeBound(upper=IntLit(3))
        )

    def test_f_then_name_c_is_not_fc(self) -> None:
        assert parse_expression("F c=2") == Temporal(
            TemporalOp.EVENTUALLY, (B(BinaryOp.EQ, c, IntLit(2)),)
        )


def test_spans() -> None:
    tree = parse_expression("x +\n  foo * 2", file="e.txt")
    assert isinstance(tree, Binary)
    assert tree.span == SourceSpan(1, 1, 2, 10, "e.txt")
    assert tree.right.span == SourceSpan(2, 3, 2, 10, "e.txt")
    assert tree.left.span == SourceSpan(1, 1, 1, 2, "e.txt")


def test_comments_are_ignored() -> None:
    assert parse_expression("a // a comment\n & b") == B(BinaryOp.AND, a, b)


def test_model_expressions_reject_labels() -> None:
    with pytest.raises(ParseError) as info:
        parse_expression('"goal" & x', model=True)
    assert (info.value.span.line, info.value.span.column) == (1, 1)  # type: ignore[union-attr]


@pytest.mark.parametrize("text", ["0." + "0" * 6000 + "1", "1" * 6000 + ".5"])
def test_a_double_with_thousands_of_digits_is_a_positioned_error(text: str) -> None:
    # found by fuzzing: Python refuses to convert more than 4300 digits ("internal error")
    with pytest.raises(ParseError, match="has more than 1000 digits") as info:
        parse_expression(text)
    assert info.value.span is not None and info.value.span.column == 1
