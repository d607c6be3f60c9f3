"""Properties checked against a model and resolved for the engines: labels, reward structures,
coalitions (1-based as in PRISM-games' ``PropertiesSemanticCheck``, 0-based on request as in
Storm/PAYNT), properties-file constants/formulas/labels, and types."""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc.errors import ConstantError, MultipleErrors, SemanticError
from posgmc.semantics.properties import CheckedProperty
from posgmc.semantics.stages import instantiate, instantiate_properties
from posgmc.semantics.symbols import Type
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    CoalitionKind,
    DoubleLit,
    Ident,
    IntLit,
    LabelRef,
    ProbQuery,
    RewardQuery,
    Temporal,
    Unary,
    UnaryOp,
)
from posgmc.syntax.parser import parse_properties

from ._helpers import lint_props, model

GAME = """smg
const int K = 2;
player p1 m1 endplayer
player p2 m2 endplayer
formula done = x = K;
module m1
  x : [0..3] init 0;
  [] true -> (x'=1);
endmodule
module m2
  y : [0..3] init 0;
  [] true -> (y'=1);
endmodule
label "goal" = x=3;
observable "lowy" = y < 2;
observable "yy" = y;
rewards "r" true : 1; endrewards
rewards "s" true : 2; endrewards
"""


def checked(props: str, *, text: str = GAME, **kw: object) -> tuple[CheckedProperty, ...]:
    m = model(text)
    fm = instantiate(m, allow_extra_constants=True, constants=kw.get("constants"))  # type: ignore[arg-type]
    return instantiate_properties(parse_properties(props, file="p.props"), fm, model=m, **kw)  # type: ignore[arg-type]


def test_coalition_naming_no_player() -> None:
    got = lint_props(GAME, '<<nobody>> Pmax=? [F "goal"]\n')
    assert got == [("SemanticError", 'unknown player "nobody" in coalition', 1, 3)]


def test_player_zero_without_the_zero_based_option() -> None:
    props = parse_properties('<<0>> Pmax=? [F "goal"]\n', file="p.props")
    from posgmc.semantics.stages import check_properties

    (err,) = check_properties(props, model(GAME))
    assert (err.message, err.span.line, err.span.column) == (  # type: ignore[union-attr]
        "player number 0 does not exist: PRISM-games numbers players from 1, while Storm and "
        "PAYNT number them from 0",
        1,
        3,
    )
    assert err.hint is not None
    assert "--zero-based-players" in err.hint and "zero_based_players=True" in err.hint


def test_player_numbers_out_of_range() -> None:
    assert lint_props(GAME, '<<3>> Pmax=? [F "goal"]\n') == [
        (
            "SemanticError",
            "player number 3 does not exist: the model has 2 players (1: p1, 2: p2)",
            1,
            3,
        )
    ]
    assert lint_props(GAME, '<<2>> Pmax=? [F "goal"]\n', zero_based_players=True) == [
        (
            "SemanticError",
            "player number 2 does not exist: the model has 2 players (0: p1, 1: p2)",
            1,
            3,
        )
    ]


def test_coalitions_resolve_to_zero_based_indices() -> None:
    props = (
        '<<1>> Pmax=? [F "goal"]\n<<p2>> Pmin=? [F "goal"]\n<<*>> Pmax=? [F "goal"]\n'
        '[[p1,2]] Pmax=? [F "goal"]\nPmax=? [F "goal"]\n'
    )
    got = [(q.coalition, q.coalition_kind) for p in checked(props) for q in p.queries]
    assert got == [
        (frozenset({0}), CoalitionKind.ANGLE),
        (frozenset({1}), CoalitionKind.ANGLE),
        (frozenset({0, 1}), CoalitionKind.ANGLE),
        (frozenset({0, 1}), CoalitionKind.BRACKET),
        (None, None),  # no coalition written: the engines decide (PRISM-games: all cooperate)
    ]
    zero = checked('<<0>> Pmax=? [F "goal"]\n<<1>> Pmax=? [F "goal"]\n', zero_based_players=True)
    assert [q.coalition for p in zero for q in p.queries] == [frozenset({0}), frozenset({1})]


def test_coalition_on_a_non_game() -> None:
    mdp = GAME.replace("smg", "mdp").replace("player p1 m1 endplayer\nplayer p2 m2 endplayer\n", "")
    mdp = mdp.replace('observable "lowy" = y < 2;\nobservable "yy" = y;\n', "")
    assert lint_props(mdp, '<<p1>> Pmax=? [F "goal"]\n') == [
        ("SemanticError", "a coalition only applies to games (smg, posg), not to an mdp", 1, 1)
    ]


def test_unknown_label() -> None:
    got = lint_props(GAME, '<<p1>> Pmax=? [F "nolabel"]\n')
    assert got == [("SemanticError", 'unknown label "nolabel"', 1, 18)]


def test_labels_observables_and_builtins() -> None:
    (p,) = checked('<<p1>> Pmax=? [!"deadlock" U "goal" & "lowy" & "yy" = 1 & !"init"]\n')
    path = p.queries[0].node.path  # type: ignore[union-attr]
    assert isinstance(path, Temporal)
    left, right = path.operands
    assert left == Unary(UnaryOp.NOT, LabelRef("deadlock"))
    # the int observable "yy" is replaced by its expression; Boolean ones stay labels
    text = repr(right)
    assert "LabelRef(name='goal')" in text and "LabelRef(name='lowy')" in text
    assert "LabelRef(name='yy')" not in text and "Ident(name='y')" in text


def test_unknown_reward_structure() -> None:
    # the position is the query's (which starts at its coalition)
    assert lint_props(GAME, '<<p1>> R{"nor"}max=? [F "goal"]\n') == [
        ("SemanticError", 'unknown reward structure "nor"', 1, 1)
    ]
    assert lint_props(GAME, "<<p1>> R{3}max=? [F x=1]\n") == [
        (
            "SemanticError",
            "reward structure number 3 does not exist: the model has 2 (numbered from 1)",
            1,
            1,
        )
    ]
    no_rewards = GAME.replace(
        'rewards "r" true : 1; endrewards\nrewards "s" true : 2; endrewards\n', ""
    )
    assert lint_props(no_rewards, "<<p1>> Rmax=? [F x=1]\n") == [
        ("SemanticError", "the model has no reward structures", 1, 1)
    ]


def test_reward_structures_resolve_to_indices() -> None:
    props = '<<p1>> Rmax=? [F "goal"]\n<<p1>> R{"s"}max=? [F "goal"]\n<<p1>> R{1}min=? [C<=K]\n'
    assert [q.reward_index for p in checked(props) for q in p.queries] == [0, 1, 0]


def test_properties_file_constants_formulas_labels() -> None:
    props = """const int k;
const double h = k / 4;
formula near = x >= k;
label "close" = near & y < 2;
<<p1>> Pmax=? [F<=k "close"]
<<p1>> P>=h [F done]
"""
    ps = checked(props, constants={"k": "2"})
    assert ps[0].constants == (("k", 2), ("h", Fraction(1, 2)))
    q0 = ps[0].queries[0].node
    assert isinstance(q0, ProbQuery) and isinstance(q0.path, Temporal)
    assert q0.path.bound is not None and q0.path.bound.upper == IntLit(2)
    # the properties-file label is inlined: model formulas and constants resolved
    assert q0.path.operands[0] == Binary(
        BinaryOp.AND,
        Binary(BinaryOp.GE, Ident("x"), IntLit(2)),
        Binary(BinaryOp.LT, Ident("y"), IntLit(2)),
    )
    q1 = ps[1].queries[0].node
    assert isinstance(q1, ProbQuery) and q1.threshold is not None
    assert q1.threshold.value == DoubleLit(Fraction(1, 2))
    # the model's formula "done" = x = K with K = 2
    assert q1.path == Temporal(q1.path.op, (Binary(BinaryOp.EQ, Ident("x"), IntLit(2)),))  # type: ignore[union-attr]
    assert [p.type for p in ps] == [Type.DOUBLE, Type.BOOL]


def test_properties_file_name_errors() -> None:
    props = """const int K = 3;
const int j;
formula x = 1;
label "goal" = true;
label "lowy" = true;
label "init" = true;
"maximum": <<p1>> Pmax=? [F "goal"]
"maximum": <<p1>> Pmin=? [F "goal"]
"""
    assert lint_props(GAME, props, constants={"j": 1, "zz": 2}) == [
        (
            "SemanticError",
            'constant "K" is already defined as a constant in the model (line 2)',
            1,
            1,
        ),
        (
            "SemanticError",
            'formula "x" is already defined as a variable in the model (line 7)',
            3,
            1,
        ),
        ("SemanticError", 'label "goal" is already defined in the model (line 14)', 4, 1),
        (
            "SemanticError",
            'label "lowy" has the name of an observable of the model (line 15)',
            5,
            1,
        ),
        ("SemanticError", '"init" is a built-in label and cannot be defined', 6, 1),
        ("SemanticError", 'property "maximum" is already defined (line 7)', 8, 1),
        ("ConstantError", '"zz" is not a constant of the model or the properties', None, None),
    ]


def test_property_type_errors() -> None:
    props = """<<p1>> Pmax=? [F x]
<<p1>> P>=true [F x=1]
<<p1>> Pmax=? [F<=0.5 x=1]
<<p1>> P>=1.5 [F x=1]
<<p1>> R{"r"}max=? [F x+1]
<<p1>> Pmax=? [F z=1]
"""
    assert lint_props(GAME, props) == [
        ("SemanticError", 'the operand of "F" must be Boolean, found int', 1, 18),
        ("SemanticError", "the bound of the P operator must be a number, found bool", 2, 11),
        ("SemanticError", 'the step bound of "F" must be an int, found double', 3, 19),
        ("SemanticError", "the probability bound 1.5 is not in [0, 1]", 4, 11),
        ("SemanticError", 'the target of "F" in the R operator must be Boolean, found int', 5, 23),
        ("SemanticError", 'undefined name "z"', 6, 18),
    ]


def test_undefined_property_constant() -> None:
    m = model(GAME)
    fm = instantiate(m)
    props = parse_properties("const int k;\n<<p1>> Pmax=? [F<=k x=1]\n", file="p.props")
    assert lint_props(GAME, "const int k;\n<<p1>> Pmax=? [F<=k x=1]\n") == []
    with pytest.raises(ConstantError) as exc:
        instantiate_properties(props, fm, model=m)
    assert exc.value.message == 'undefined constant "k" must be given a value'
    assert exc.value.span is not None and exc.value.span.line == 1


def test_instantiate_raises_all_errors() -> None:
    m = model(GAME)
    fm = instantiate(m)
    props = parse_properties(
        '<<nobody>> Pmax=? [F "goal"]\n<<p1>> Pmax=? [F "nolabel"]\n', file="p.props"
    )
    with pytest.raises(MultipleErrors) as exc:
        instantiate_properties(props, fm, model=m)
    assert [e.message for e in exc.value.errors] == [
        'unknown player "nobody" in coalition',
        'unknown label "nolabel"',
    ]
    single = parse_properties('<<nobody>> Pmax=? [F "goal"]\n', file="p.props")
    with pytest.raises(SemanticError):
        instantiate_properties(single, fm, model=m)


def test_scaled_query_keeps_its_resolution() -> None:
    (p,) = checked('(1/2) * <<p1,p2>> R{"s"}max=? [F "goal"]\n')
    assert isinstance(p.expr, Binary) and p.expr.left == DoubleLit(Fraction(1, 2))
    q = p.query(p.expr.right)
    assert isinstance(q.node, RewardQuery)
    assert (q.coalition, q.reward_index) == (frozenset({0, 1}), 1)


def test_cyclic_properties_file_labels() -> None:
    # the parser reads no quoted names inside label definitions; hand-built trees may hold them
    from posgmc.errors import SourceSpan
    from posgmc.semantics.stages import check_properties
    from posgmc.syntax.ast import LabelDecl, PropertiesFile

    a = LabelDecl("a", LabelRef("b"), span=SourceSpan(1, 1))
    b = LabelDecl("b", LabelRef("a"), span=SourceSpan(2, 1))
    (err,) = check_properties(PropertiesFile(labels=(a, b)), model(GAME))
    assert (err.message, err.span) == (
        'cyclic definition of label "a" (a -> b -> a)',
        SourceSpan(1, 1),
    )


def test_temporal_operator_outside_p_or_r() -> None:
    # the parser reads none; a hand-built property may hold one
    from posgmc.errors import SourceSpan
    from posgmc.semantics.stages import check_properties
    from posgmc.syntax.ast import PropertiesFile, Property, TemporalOp

    f = Temporal(TemporalOp.EVENTUALLY, (LabelRef("goal"),), span=SourceSpan(1, 1))
    (err,) = check_properties(PropertiesFile(properties=(Property(f),)), model(GAME))
    assert (err.message, err.span) == (
        'the temporal operator "F" can only appear inside a P or R operator',
        SourceSpan(1, 1),
    )
