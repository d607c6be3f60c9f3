"""Property files: queries, coalitions, reward objectives, layout, and ``// RESULT`` capture."""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc.errors import ParseError, SourceSpan
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    Coalition,
    CoalitionKind,
    ComparisonOp,
    Direction,
    DoubleLit,
    ExpectedResult,
    Ident,
    IntLit,
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
    VarType,
)
from posgmc.syntax.parser import parse_expression, parse_properties, parse_property

GOAL = LabelRef("goal")
F_GOAL = Temporal(TemporalOp.EVENTUALLY, (GOAL,))


class TestProbabilityQueries:
    @pytest.mark.parametrize(
        ("text", "direction", "threshold"),
        [
            ('P=? [F "goal"]', None, None),
            ('Pmax=? [F "goal"]', Direction.MAX, None),
            ('Pmin=? [F "goal"]', Direction.MIN, None),
            ('P max=? [F "goal"]', Direction.MAX, None),
            ('P>=0.9 [F "goal"]', None, Threshold(ComparisonOp.GE, DoubleLit(Fraction(9, 10)))),
            ('P<0.1 [F "goal"]', None, Threshold(ComparisonOp.LT, DoubleLit(Fraction(1, 10)))),
            ('P>0 [F "goal"]', None, Threshold(ComparisonOp.GT, IntLit(0))),
            ('P<=p [F "goal"]', None, Threshold(ComparisonOp.LE, Ident("p"))),
        ],
    )
    def test_operator_forms(
        self, text: str, direction: Direction | None, threshold: Threshold | None
    ) -> None:
        assert parse_property(text).expr == ProbQuery(None, direction, threshold, F_GOAL)


class TestCoalitions:
    @pytest.mark.parametrize(
        ("text", "coalition"),
        [
            ("<<p1,p2>>", Coalition((PlayerRef(name="p1"), PlayerRef(name="p2")))),
            ("<<1>>", Coalition((PlayerRef(number=1),))),
            ("<<1, 2>>", Coalition((PlayerRef(number=1), PlayerRef(number=2)))),
            ("<<0>>", Coalition((PlayerRef(number=0),))),
            ("<<*>>", Coalition((), all_players=True)),
            ("<<>>", Coalition(())),
            ("[[p1]]", Coalition((PlayerRef(name="p1"),), kind=CoalitionKind.BRACKET)),
            (
                "[[1,p2]]",
                Coalition(
                    (PlayerRef(number=1), PlayerRef(name="p2")), kind=CoalitionKind.BRACKET
                ),
            ),
        ],
    )
    def test_forms(self, text: str, coalition: Coalition) -> None:
        query = parse_property(f'{text} Pmax=? [F "goal"]').expr
        assert isinstance(query, ProbQuery)
        assert query.coalition == coalition

    def test_player_named_like_a_keyword(self) -> None:
        query = parse_property('<<P>> Pmax=? [F "goal"]').expr
        assert isinstance(query, ProbQuery) and query.coalition is not None
        assert query.coalition.players == (PlayerRef(name="P"),)

    def test_coalition_span(self) -> None:
        query = parse_property('<<p1, 2>> Pmax=? [F "goal"]').expr
        assert isinstance(query, ProbQuery) and query.coalition is not None
        assert query.coalition.span == SourceSpan(1, 1, 1, 10)
        assert query.coalition.players[1].span == SourceSpan(1, 7, 1, 8)

    def test_nested_brackets_close(self) -> None:
        # `]]` closes two brackets here, it is not the end of a [[...]] coalition
        expr = parse_property('P>=1 [ F P>=0.5 [ F "a" ]]').expr
        assert isinstance(expr, ProbQuery) and isinstance(expr.path, Temporal)
        assert isinstance(expr.path.operands[0], ProbQuery)


class TestRewardQueries:
    @pytest.mark.parametrize(
        ("body", "objective"),
        [
            ('F "goal"', RewardObjective(RewardKind.REACH, target=GOAL)),
            ('(F "goal")', RewardObjective(RewardKind.REACH, target=GOAL)),
            ('F0 "goal"', RewardObjective(RewardKind.REACH_ZERO, target=GOAL)),
            ('Fc "goal"', RewardObjective(RewardKind.REACH_CUMULATIVE, target=GOAL)),
            ("C<=k", RewardObjective(RewardKind.CUMULATIVE, bound=Ident("k"))),
            ("C", RewardObjective(RewardKind.TOTAL)),
            ("I=4", RewardObjective(RewardKind.INSTANTANEOUS, bound=IntLit(4))),
            (
                "Cdiscount=0.95",
                RewardObjective(RewardKind.DISCOUNTED_TOTAL, discount=DoubleLit(Fraction(19, 20))),
            ),
            (
                'Fdiscount=0.95 "goal"',
                RewardObjective(
                    RewardKind.DISCOUNTED_REACH, target=GOAL, discount=DoubleLit(Fraction(19, 20))
                ),
            ),
            (
                '(F "a") | (F "b")',
                RewardObjective(
                    RewardKind.LTL,
                    target=Binary(
                        BinaryOp.OR,
                        Temporal(TemporalOp.EVENTUALLY, (LabelRef("a"),)),
                        Temporal(TemporalOp.EVENTUALLY, (LabelRef("b"),)),
                    ),
                ),
            ),
            (
                'X F ("a" | "b")',
                RewardObjective(
                    RewardKind.LTL,
                    target=Temporal(
                        TemporalOp.NEXT,
                        (
                            Temporal(
                                TemporalOp.EVENTUALLY,
                                (Binary(BinaryOp.OR, LabelRef("a"), LabelRef("b")),),
                            ),
                        ),
                    ),
                ),
            ),
            (
                # a bounded F is not the reachability reward: it stays a path formula
                'F<=3 "goal"',
                RewardObjective(
                    RewardKind.LTL,
                    target=Temporal(TemporalOp.EVENTUALLY, (GOAL,), TimeBound(upper=IntLit(3))),
                ),
            ),
        ],
    )
    def test_objectives(self, body: str, objective: RewardObjective) -> None:
        query = parse_property(f"Rmin=? [ {body} ]").expr
        assert isinstance(query, RewardQuery)
        assert query.objective == objective

    def test_f_space_c_is_reachability_of_c(self) -> None:
        query = parse_property("R=? [F c=2]").expr
        assert isinstance(query, RewardQuery)
        assert query.objective == RewardObjective(
            RewardKind.REACH, target=Binary(BinaryOp.EQ, Ident("c"), IntLit(2))
        )

    def test_fc_is_the_operator(self) -> None:
        query = parse_property('R=? [Fc "x"]').expr
        assert isinstance(query, RewardQuery)
        assert query.objective == RewardObjective(RewardKind.REACH_CUMULATIVE, target=LabelRef("x"))

    def test_names_starting_with_fc_are_names(self) -> None:
        query = parse_property("R=? [F Fcost>1]").expr
        assert isinstance(query, RewardQuery)
        assert query.objective.target == Binary(BinaryOp.GT, Ident("Fcost"), IntLit(1))

    @pytest.mark.parametrize(
        ("text", "reward", "direction", "threshold"),
        [
            ('R{"cost"}min=? [C]', "cost", Direction.MIN, None),
            ("R{2}max=? [C]", 2, Direction.MAX, None),
            ("Rmax=? [C]", None, Direction.MAX, None),
            ("R=? [C]", None, None, None),
            ('R{"cost"}=? [C]', "cost", None, None),
            ("R>=5 [C]", None, None, Threshold(ComparisonOp.GE, IntLit(5))),
            ('R{"a"}<3 [C]', "a", None, Threshold(ComparisonOp.LT, IntLit(3))),
        ],
    )
    def test_operator_forms(
        self,
        text: str,
        reward: str | int | None,
        direction: Direction | None,
        threshold: Threshold | None,
    ) -> None:
        query = parse_property(text).expr
        assert query == RewardQuery(
            None, reward, direction, threshold, RewardObjective(RewardKind.TOTAL)
        )

    def test_long_run_average(self) -> None:
        prop = parse_property('R{"r"}=? [ S ]', file="<prop>")
        assert isinstance(prop.expr, RewardQuery) and prop.expr.objective.kind is RewardKind.STEADY


class TestFileLayout:
    def test_semicolons_are_optional(self) -> None:
        props = parse_properties('P=? [F "a"]\nPmax=? [F "b"];;\n"c": Pmin=? [F "c"];\n')
        assert [p.name for p in props.properties] == [None, None, "c"]
        assert [p.text for p in props.properties] == [
            'P=? [F "a"]',
            'Pmax=? [F "b"]',
            '"c": Pmin=? [F "c"]',
        ]

    def test_declarations(self) -> None:
        text = (
            "const int k;\nconst double p = 0.5;\nformula near = x < 2;\n"
            'label "far" = x > 5;\nP>=p [F<=k "far"]\n'
        )
        props = parse_properties(text, file="d.props")
        assert [(c.name, c.type, c.value) for c in props.constants] == [
            ("k", VarType.INT, None),
            ("p", VarType.DOUBLE, DoubleLit(Fraction(1, 2))),
        ]
        assert [f.name for f in props.formulas] == ["near"]
        assert [lab.name for lab in props.labels] == ["far"]
        assert props.file == "d.props"
        assert props.properties[0].span == SourceSpan(5, 1, 5, 18, "d.props")

    def test_arithmetic_and_state_formulas_over_queries(self) -> None:
        expr = parse_property('P>=1 [F "a"] & x=1').expr
        assert isinstance(expr, Binary) and expr.op is BinaryOp.AND
        assert isinstance(expr.left, ProbQuery)
        expr = parse_property('(1/2) * <<p1,p2>> R{"v"}max=? [F time=max_time]').expr
        assert isinstance(expr, Binary) and isinstance(expr.right, RewardQuery)

    def test_builtin_labels(self) -> None:
        expr = parse_property('P=? [!"deadlock" U "init"]').expr
        assert isinstance(expr, ProbQuery) and isinstance(expr.path, Temporal)
        assert expr.path.operands[1] == LabelRef("init")

    def test_temporal_operator_outside_a_query_is_an_error(self) -> None:
        with pytest.raises(ParseError) as info:
            parse_properties('P=? [F "a"] & (F "b")', file="t.props")
        err = info.value
        assert "temporal operator F" in err.message
        assert err.span == SourceSpan(1, 16, 1, 21, "t.props")

    def test_parse_expression_accepts_path_formulas(self) -> None:
        assert parse_expression('"a" U "b"') == Temporal(
            TemporalOp.UNTIL, (LabelRef("a"), LabelRef("b"))
        )


class TestResults:
    TEXT = """// a property without expectations
P=? [F "a"]

// RESULT: 0.5
// RESULT (k=3, N=2): 19/15   // trailing remark
// a note between
P=? [F "b"];  // RESULT: 7 belongs to the next property, as in PRISM
Pmax=? [F "c"]
// RESULT: Error:co-safe
R=? [F G "d"]
"""

    def test_capture(self) -> None:
        props = parse_properties(self.TEXT, file="r.props").properties
        assert [len(p.expected) for p in props] == [0, 2, 1, 1]
        assert props[1].expected == (
            ExpectedResult("0.5"),
            ExpectedResult("19/15", (("k", "3"), ("N", "2"))),
        )
        assert props[1].expected[1].span == SourceSpan(5, 4, 5, 28, "r.props")
        assert props[2].expected == (ExpectedResult("7"),)
        assert props[3].expected == (ExpectedResult("Error:co-safe"),)

    def test_commented_out_property_is_not_a_property(self) -> None:
        props = parse_properties('//"min": Pmin=? [F x=1];\n"max": Pmax=? [F x=1];')
        assert [p.name for p in props.properties] == ["max"]

    def test_badly_formed_result(self) -> None:
        with pytest.raises(ParseError) as info:
            parse_properties('// RESULT (k): 1\nP=? [F "a"]', file="b.props")
        assert "badly formed RESULT" in info.value.message
        assert info.value.span == SourceSpan(1, 4, 1, 17, "b.props")


def test_parse_property_single() -> None:
    prop = parse_property('"best": <<p1>> Pmax=? [ F "goal" ];', file="<--prop>")
    assert prop.name == "best"
    assert prop.text == '"best": <<p1>> Pmax=? [ F "goal" ]'
    assert prop.span.file == "<--prop>"
    assert prop.expected == ()


# -- Storm's unparenthesised temporal operands (Storm's FormulaParser accepts; PRISM does not) --


@pytest.mark.parametrize(
    ("storm", "prism"),
    [
        ('P=? [ F ("a" & X "b") ]', 'P=? [ F ("a" & (X "b")) ]'),
        ('P=? [ ("a" U "b") & F "c" ]', 'P=? [ ("a" U "b") & (F "c") ]'),
        ('P=? [ "a" | G<=3 "b" ]', 'P=? [ "a" | (G<=3 "b") ]'),
        ('P=? [ F "a" & "b" ]', 'P=? [ F ("a" & "b") ]'),  # PRISM's reading is kept
        ('P=? [ "a" & F "b" & "c" ]', 'P=? [ ("a" & (F "b")) & "c" ]'),
    ],
)
def test_storm_temporal_operands_parse_as_parenthesised(storm: str, prism: str) -> None:
    assert parse_property(storm).expr == parse_property(prism).expr


@pytest.mark.parametrize(
    ("storm", "parenthesised"),
    [
        ("P=? [ F (y=5 & X y=6) ]", "P=? [ F (y=5 & X (y=6)) ]"),
        ("P=? [ F (a & X x+1>=2) ]", "P=? [ F (a & X ((x+1)>=2)) ]"),
        ("P=? [ F<=3 (a & F<=2 x*2=4) ]", "P=? [ F<=3 (a & F<=2 (x*2=4)) ]"),
        ("P=? [ X y=6 ]", "P=? [ X (y=6) ]"),
    ],
)
def test_temporal_operand_of_a_comparison_is_read_as_storm_reads_it(
    storm: str, parenthesised: str
) -> None:
    # PRISM's precedence makes X y=6 into (X y)=6, a type error; Storm 2.0 reads
    # P=? [F (y=5 & X y=6)] as P=? [F ((y = 5) & (X (y = 6)))] (its printed formula)
    got = parse_property(storm).expr
    assert got == parse_property(parenthesised).expr
    assert isinstance(got, ProbQuery) and isinstance(got.path, Temporal)


def test_parenthesised_temporal_compared_stays_an_error() -> None:
    with pytest.raises(ParseError) as info:
        parse_property("P=? [ F (a & (X x)=1) ]")
    err = info.value
    assert 'cannot be an operand of "="' in err.message
    assert err.span is not None and (err.span.line, err.span.column) == (1, 15)
    assert "X (x = 1)" in (err.hint or "")


@pytest.mark.parametrize(
    "text", ['P=? [ F "a" & X "b" ]', 'P=? [ X "a" & X "b" ]', 'P=? [ G "a" | F "b" ]']
)
def test_temporal_inside_a_temporal_operand_is_ambiguous(text: str) -> None:
    # PRISM reads F a & X b as F (a & X b), Storm as (F a) & (X b): neither is guessed
    with pytest.raises(ParseError) as info:
        parse_property(text)
    err = info.value
    assert err.message.startswith("ambiguous temporal operator")
    second = max(text.rfind("& "), text.rfind("| ")) + 2  # 0-based index of the inner operator
    assert err.span is not None and err.span.column == second + 1
    assert "(" in (err.hint or "") and "or" in (err.hint or "")
