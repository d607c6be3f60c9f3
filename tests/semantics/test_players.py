"""Players: ownership of modules and actions. PRISM-games' rules, read in
``prism/src/parser/ast/ModulesFile.java`` (checkPlayerDefns): games must declare players, other
types must not; unknown module/action names and doubly owned ones are errors."""

from __future__ import annotations

from posgmc.semantics.stages import instantiate

from ._helpers import lint, model

GAME = """smg
player p1 m1, [a] endplayer
player p2 m2, [b] endplayer
module m1
  x : [0..1];
  [a] true -> (x'=1);
  [] x=1 -> (x'=0);
endmodule
module m2
  y : [0..1];
  [b] true -> (y'=1);
  [a] true -> true;
endmodule
"""


def test_players_are_built() -> None:
    fm = instantiate(model(GAME))
    assert [(p.name, p.modules, p.actions, p.observables) for p in fm.players] == [
        ("p1", ("m1",), ("a",), None),
        ("p2", ("m2",), ("b",), None),
    ]


def test_module_owned_by_two_players() -> None:
    text = GAME.replace("player p2 m2, [b]", "player p2 m2, m1, [b]")
    assert lint(text) == [
        ("SemanticError", 'module "m1" is already owned by player "p1" (line 2)', 3, 15),
    ]


def test_action_owned_by_two_players() -> None:
    text = GAME.replace("player p2 m2, [b]", "player p2 m2, [b], [a]")
    assert lint(text) == [
        ("SemanticError", 'action "a" is already owned by player "p1" (line 2)', 3, 20),
    ]


def test_unknown_module_and_action_in_player() -> None:
    text = GAME.replace("player p2 m2, [b]", "player p2 m2, [b], nomod, [noact], [m1], b")
    assert lint(text) == [
        ("SemanticError", 'unknown module "nomod" in player "p2"', 3, 20),
        ("SemanticError", 'unknown action "noact" in player "p2"', 3, 27),
        ("SemanticError", 'unknown action "m1" in player "p2"', 3, 36),
        ("SemanticError", 'unknown module "b" in player "p2"', 3, 42),
    ]


def test_hints_for_module_action_mixups() -> None:
    from posgmc.semantics.stages import check_model

    errs = check_model(model(GAME.replace("player p2 m2, [b]", "player p2 m2, [b], [m1], a")))
    hints = [e.hint for e in errs]
    assert hints[0] == '"m1" is a module; write it without brackets'
    assert hints[-1] == '"a" is an action; write it in brackets: [a]'


def test_doubly_defined_player() -> None:
    text = GAME.replace("player p2 m2, [b]", "player p1 m2, [b]")
    assert lint(text) == [("SemanticError", 'player "p1" is already defined (line 2)', 3, 1)]


def test_game_without_players() -> None:
    text = "\n".join(GAME.splitlines()[:1] + GAME.splitlines()[3:]) + "\n"
    got = lint(text)
    assert [d[:2] for d in got] == [("SemanticError", "a game (smg) must declare its players")]
    assert got[0][2] == 1


def test_players_in_a_non_game() -> None:
    assert lint(GAME.replace("smg", "mdp", 1)) == [
        (
            "SemanticError",
            "player blocks are only allowed in games (smg, posg), not in an mdp",
            2,
            1,
        ),
    ]
