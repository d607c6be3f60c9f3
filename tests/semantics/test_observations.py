"""Observables: where they may be declared, what they may name, and how they reach the FlatModel.

PRISM-games evidence (``prism/src/parser/ast/ModulesFile.java``, checkObservables/addObservable):
pomdps must specify observables; an observables list names variables only; observable names are
*quoted* identifiers (the namespace of labels), so an observable may be named like a variable.
"""

from __future__ import annotations

from posgmc.semantics.stages import instantiate
from posgmc.syntax.ast import Binary, BinaryOp, Ident, IntLit

from ._helpers import lint, model

BODY = """module m
  x : [0..3] init 0;
  y : [0..3] init 0;
  [a] true -> (x'=1);
  [b] true -> (y'=1);
endmodule
"""


def test_pomdp_observables_reach_the_flat_model() -> None:
    text = (
        'pomdp\nobservables x endobservables\nobservable "low" = y < 2;\nobservable "yy" = y;\n'
        + BODY
    )
    fm = instantiate(model(text))
    assert fm.observables is not None
    assert [(o.name, o.expr) for o in fm.observables] == [
        ("x", Ident("x")),
        ("low", Binary(BinaryOp.LT, Ident("y"), IntLit(2))),
        ("yy", Ident("y")),
    ]
    # Boolean observables are usable as labels (PRISM's FindAllObsRefs); int ones are not labels
    assert dict(fm.labels) == {"low": Binary(BinaryOp.LT, Ident("y"), IntLit(2))}


def test_pomdp_needs_observables() -> None:
    got = lint("pomdp\n" + BODY)
    assert [d[:2] for d in got] == [("SemanticError", "a pomdp must declare observables")]
    assert got[0][2:] == (1, 1)


def test_mdp_cannot_declare_observables() -> None:
    assert lint("mdp\nobservables x endobservables\n" + BODY) == [
        ("SemanticError", "an mdp cannot declare observables", 2, 1),
    ]


def test_observable_that_is_not_a_variable() -> None:
    text = (
        "pomdp\nconst int k = 1;\nformula f = x + 1;\nobservables x, k, f, nope endobservables\n"
        + BODY
    )
    assert lint(text) == [
        (
            "SemanticError",
            'observable "k" is not a variable (it is a constant); use observable "k" = expr;',
            4,
            16,
        ),
        (
            "SemanticError",
            'observable "f" is not a variable (it is a formula); use observable "f" = expr;',
            4,
            19,
        ),
        ("SemanticError", 'undefined name "nope"', 4, 22),
    ]


def test_named_observable_errors() -> None:
    text = 'pomdp\nobservable "o" = x + true;\nobservable "d" = x / 2;\n' + BODY
    got = lint(text)
    assert got == [
        ("SemanticError", '"+" needs numbers, found bool', 2, 22),
        ("UnsupportedError", 'observable "d" is a double; observables must be int or bool', 3, 18),
    ]


def test_observable_named_like_a_variable_is_legal() -> None:
    # PRISM-games puts observable names among quoted names (labels), not among variables, so
    # attacker-defender's 'observable "d1y" = d1y;' and even pursuit-evasion's
    # 'observable "p2x" = p1x;' are accepted (Storm rejects them; see LINT_EXCEPTIONS)
    text = 'pomdp\nobservable "x" = x;\nobservable "y" = x > 1;\n' + BODY
    assert lint(text) == []
    fm = instantiate(model(text))
    assert fm.observables is not None and [o.name for o in fm.observables] == ["x", "y"]


def test_observable_and_label_share_a_namespace() -> None:
    text = (
        'pomdp\nobservables x endobservables\nobservable "x" = y;\n' + BODY + 'label "x" = true;\n'
    )
    assert lint(text) == [
        ("SemanticError", 'observable "x" has the name of label "x" (line 10)', 2, 13),
        ("SemanticError", 'observable "x" has the name of label "x" (line 10)', 3, 1),
    ]
    text = 'pomdp\nobservables x endobservables\nobservable "x" = y;\n' + BODY
    assert lint(text) == [("SemanticError", 'observable "x" is already declared (line 2)', 3, 1)]


def test_smg_top_level_observables_are_kept() -> None:
    # PAYNT's POSMG sources: an smg with top-level observables (PRISM-games itself rejects these)
    text = 'smg\nplayer p1 m, [a] endplayer\nplayer p2 [b] endplayer\nobservable "o" = x;\n' + BODY
    fm = instantiate(model(text))
    assert fm.observables is not None and [o.name for o in fm.observables] == ["o"]
    assert [p.observables for p in fm.players] == [None, None]


def test_player_observables_only_in_posg() -> None:
    text = (
        "smg\nplayer p1 m, [a] observables x endobservables endplayer\nplayer p2 [b] endplayer\n"
        + BODY
    )
    got = lint(text)
    assert got == [
        (
            "SemanticError",
            "observables inside a player block are only allowed in a posg, not in an smg",
            2,
            18,
        )
    ]


POSG = """posg
player p1 m, [a] observables x endobservables observable "hi" = y > 1; endplayer
player p2 [b] observables x endobservables endplayer
""" + BODY


def test_posg_per_player_observables() -> None:
    fm = instantiate(model(POSG))
    assert fm.observables is None
    obs = {p.name: [(o.name, o.expr) for o in p.observables or ()] for p in fm.players}
    assert obs == {
        "p1": [("x", Ident("x")), ("hi", Binary(BinaryOp.GT, Ident("y"), IntLit(1)))],
        "p2": [("x", Ident("x"))],  # the same name with the same meaning in two players is fine
    }
    assert dict(fm.labels) == {"hi": Binary(BinaryOp.GT, Ident("y"), IntLit(1))}
    # a player without observables observes everything
    fm2 = instantiate(
        model(POSG.replace("player p2 [b] observables x endobservables", "player p2 [b]"))
    )
    assert fm2.players[1].observables is None


def test_posg_observable_errors() -> None:
    text = POSG.replace(
        "player p2 [b] observables x endobservables", 'player p2 [b] observable "hi" = y > 2;'
    )
    assert lint(text) == [
        (
            "SemanticError",
            'observable "hi" of player "p2" differs from observable "hi" of player "p1" (line 2)',
            3,
            15,
        )
    ]
    assert lint(POSG.replace("posg\n", 'posg\nobservable "t" = x;\n')) == [
        (
            "SemanticError",
            "a posg declares observables inside player blocks, not at the top level",
            2,
            1,
        ),
    ]
    no_obs = "posg\nplayer p1 m, [a] endplayer\nplayer p2 [b] endplayer\n" + BODY
    assert lint(no_obs) == [
        ("SemanticError", "a posg must declare observables in at least one player block", 2, 1),
    ]
