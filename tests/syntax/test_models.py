"""Model files: every declaration form, renamed modules, players with observables, spans."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from posgmc.errors import SourceSpan
from posgmc.syntax.ast import (
    ActionRef,
    Assignment,
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    DoubleLit,
    Function,
    Ident,
    IntLit,
    ModelType,
    Module,
    ModuleRef,
    NamedObservable,
    ObservableVars,
    RenamedModule,
    Renaming,
    RewardItem,
    Unary,
    UnaryOp,
    Update,
    VarType,
)
from posgmc.syntax.parser import load_model, parse_model


@pytest.mark.parametrize(
    ("keyword", "model_type"),
    [
        ("dtmc", ModelType.DTMC),
        ("probabilistic", ModelType.DTMC),
        ("mdp", ModelType.MDP),
        ("nondeterministic", ModelType.MDP),
        ("pomdp", ModelType.POMDP),
        ("smg", ModelType.SMG),
        ("posg", ModelType.POSG),
    ],
)
def test_model_types(keyword: str, model_type: ModelType) -> None:
    model = parse_model(f"{keyword}\nmodule m x : bool; endmodule")
    assert model.model_type is model_type
    assert model.model_type_given


def test_missing_model_type_means_mdp() -> None:
    model = parse_model("module m x : bool; endmodule")
    assert model.model_type is ModelType.MDP
    assert not model.model_type_given


def test_empty_model() -> None:
    model = parse_model("// nothing here\n")
    assert model.modules == () and not model.model_type_given


def test_constants() -> None:
    model = parse_model(
        "const int N; const double p = 0.1; const bool b = true; const M = 3; const k;"
    )
    assert [(c.name, c.type, c.value) for c in model.constants] == [
        ("N", VarType.INT, None),
        ("p", VarType.DOUBLE, DoubleLit(Fraction(1, 10))),
        ("b", VarType.BOOL, BoolLit(True)),
        ("M", VarType.INT, IntLit(3)),  # untyped constants are int (PRISM)
        ("k", VarType.INT, None),
    ]


def test_formulas_labels_globals_init() -> None:
    model = parse_model(
        'formula f = x+1;\nlabel "goal" = x=N;\nglobal g : [0..N] init 0;\n'
        "global b : bool;\ninit g=0 & !b endinit\n"
    )
    assert model.formulas[0].name == "f"
    assert model.labels[0].name == "goal"
    assert [(v.name, v.type, v.low, v.high, v.init) for v in model.globals] == [
        ("g", VarType.INT, IntLit(0), Ident("N"), IntLit(0)),
        ("b", VarType.BOOL, None, None, None),
    ]
    assert model.init == Binary(
        BinaryOp.AND, Binary(BinaryOp.EQ, Ident("g"), IntLit(0)), Unary(UnaryOp.NOT, Ident("b"))
    )


def test_module_commands_and_updates() -> None:
    text = """mdp
module m
  x : [0..N] init 0;
  y : bool init false;
  z : [1..2];
  [a] x<N -> 0.3 : (x'=x+1) & (y'=true) + 0.7 : true;
  [] x=N -> (x'=0);
  [] y -> true;
  [go] true -> 1-s-f : (x'=min(x+1,N)) + s : true + f : (x'=0);
endmodule
"""
    (module,) = parse_model(text).modules
    assert isinstance(module, Module)
    assert [(v.name, v.type, v.init) for v in module.variables] == [
        ("x", VarType.INT, IntLit(0)),
        ("y", VarType.BOOL, BoolLit(False)),
        ("z", VarType.INT, None),
    ]
    first, second, third, fourth = module.commands
    assert first.action == "a"
    assert first.updates == (
        Update(
            DoubleLit(Fraction(3, 10)),
            (
                Assignment("x", Binary(BinaryOp.ADD, Ident("x"), IntLit(1))),
                Assignment("y", BoolLit(True)),
            ),
        ),
        Update(DoubleLit(Fraction(7, 10)), ()),
    )
    assert second.action is None
    assert second.updates == (Update(None, (Assignment("x", IntLit(0)),)),)
    assert third.updates == (Update(None, ()),)
    assert [u.probability for u in fourth.updates] == [
        Binary(BinaryOp.SUB, Binary(BinaryOp.SUB, IntLit(1), Ident("s")), Ident("f")),
        Ident("s"),
        Ident("f"),
    ]
    assert fourth.updates[0].assignments[0].value == Call(
        Function.MIN, (Binary(BinaryOp.ADD, Ident("x"), IntLit(1)), Ident("N"))
    )


def test_probability_in_parentheses_is_not_an_assignment() -> None:
    text = "module m x:[0..1]; [] true -> (1-p) : (x'=1) + p : true; endmodule"
    (module,) = parse_model(text).modules
    update = module.commands[0].updates[0]  # type: ignore[union-attr]
    assert update.probability == Binary(BinaryOp.SUB, IntLit(1), Ident("p"))


def test_spans() -> None:
    text = "dtmc\nmodule m\n  x : [0..1] init 0;\n  [] x=0 -> (x'=1);\nendmodule\n"
    model = parse_model(text, file="s.prism")
    module = model.modules[0]
    assert isinstance(module, Module)
    assert module.span == SourceSpan(2, 1, 5, 10, "s.prism")
    assert module.variables[0].span == SourceSpan(3, 3, 3, 21, "s.prism")
    command = module.commands[0]
    assert command.span == SourceSpan(4, 3, 4, 20, "s.prism")
    assert command.guard.span == SourceSpan(4, 6, 4, 9, "s.prism")
    assert command.updates[0].assignments[0].span == SourceSpan(4, 13, 4, 19, "s.prism")


def test_renamed_module() -> None:
    model = parse_model(
        "module a x : bool; [go] true -> (x'=true); endmodule\n"
        "module b = a [x=y, go=stop, min=max] endmodule\n"
    )
    renamed = model.modules[1]
    assert renamed == RenamedModule(
        "b", "a", (Renaming("x", "y"), Renaming("go", "stop"), Renaming("min", "max"))
    )
    assert renamed.span.line == 2


def test_rewards() -> None:
    model = parse_model(
        'rewards "cost"\n  x=1 : 2;\n  [a] true : 1;\n  [] true : 3;\nendrewards\n'
        "rewards\n  true : 1;\nendrewards\n"
    )
    named, unnamed = model.rewards
    assert named.name == "cost" and unnamed.name is None
    assert named.items == (
        RewardItem(False, None, Binary(BinaryOp.EQ, Ident("x"), IntLit(1)), IntLit(2)),
        RewardItem(True, "a", BoolLit(True), IntLit(1)),
        RewardItem(True, None, BoolLit(True), IntLit(3)),
    )


def test_players_and_top_level_observables() -> None:
    text = """smg
player p1
  host, [send1],
  [send2]
endplayer
player p2 client endplayer
observables x, y endobservables
observable "small" = x < 2;
module host x : bool; endmodule
module client y : bool; endmodule
"""
    model = parse_model(text)
    p1, p2 = model.players
    assert p1.modules == (ModuleRef("host"),)
    assert p1.actions == (ActionRef("send1"), ActionRef("send2"))
    assert p1.observables == ()
    assert p2.modules == (ModuleRef("client"),) and p2.actions == ()
    vars_, named = model.observables
    assert isinstance(vars_, ObservableVars)
    assert [v.name for v in vars_.variables] == ["x", "y"]
    assert named == NamedObservable("small", Binary(BinaryOp.LT, Ident("x"), IntLit(2)))


def test_posg_player_observables() -> None:
    text = """posg
player defender
  defender_module, [d_up], [d_down]
  observables d_y, clk endobservables
  observable "sees_attacker" = ax = d_x;
endplayer
player attacker
  observable "clk" = clk;
  attacker_module, [a_right]
endplayer
module defender_module d_y : [0..2]; endmodule
"""
    model = parse_model(text)
    assert model.model_type is ModelType.POSG
    defender, attacker = model.players
    assert defender.modules == (ModuleRef("defender_module"),)
    assert defender.actions == (ActionRef("d_up"), ActionRef("d_down"))
    obs_vars, named = defender.observables
    assert isinstance(obs_vars, ObservableVars)
    assert [v.name for v in obs_vars.variables] == ["d_y", "clk"]
    assert isinstance(named, NamedObservable) and named.name == "sees_attacker"
    assert attacker.observables == (NamedObservable("clk", Ident("clk")),)
    assert attacker.modules == (ModuleRef("attacker_module"),)
    assert attacker.actions == (ActionRef("a_right"),)
    assert model.observables == ()


def test_empty_player() -> None:
    (player,) = parse_model("smg player p endplayer").players
    assert player.modules == () and player.actions == ()


def test_keywords_of_other_tools_are_names() -> None:
    # `end`, `clock` (PRISM: PTA keyword, unused here) and `time` name modules and variables in
    # the benchmarks.
    model = parse_model(
        "module end time : [0..3]; endmodule\nmodule clock c : bool; endmodule\nconst int R = 1;"
    )
    assert [m.name for m in model.modules] == ["end", "clock"]


def test_load_model_reads_utf8_and_sets_file(tmp_path: Path) -> None:
    path = tmp_path / "m.prism"
    path.write_text("\ufeffdtmc // ü\nmodule m x : bool; endmodule\n", encoding="utf-8")
    model = load_model(path)
    assert model.file == str(path)
    assert model.modules[0].span == SourceSpan(2, 1, 2, 29, str(path))
