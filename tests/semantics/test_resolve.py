"""Names: duplicates, undefined names, cyclic formulas, module renaming, which module may update
which variable. PRISM's rules: prism-games ``prism/src/parser/ast/ModulesFile.java`` (tidyUp,
sortRenamings, checkVarNames), ``visitor/ModulesFileSemanticCheck.java`` (updates) and
``visitor/Rename.java`` ("must rename variable")."""

from __future__ import annotations

from posgmc.semantics.flat import FlatModel
from posgmc.semantics.stages import instantiate
from posgmc.syntax.ast import Binary, BinaryOp, Ident, IntLit

from ._helpers import lint, model


def test_doubly_defined_names() -> None:
    text = """mdp
const int N = 3;
const int N = 4;
formula f = 1;
formula f = 2;
global g : [0..1];
module m
  x : [0..N] init 0;
  [] true -> true;
endmodule
module m
  y : [0..1];
endmodule
module n
  x : [0..1];
  g : bool;
endmodule
label "l" = true;
label "l" = false;
rewards "r" true : 1; endrewards
rewards "r" true : 2; endrewards
"""
    assert lint(text) == [
        ("SemanticError", 'constant "N" is already defined as a constant (line 2)', 3, 1),
        ("SemanticError", 'formula "f" is already defined as a formula (line 4)', 5, 1),
        ("SemanticError", 'module "m" is already defined (line 7)', 11, 1),
        ("SemanticError", 'variable "x" is already defined as a variable (line 8)', 15, 3),
        ("SemanticError", 'variable "g" is already defined as a variable (line 6)', 16, 3),
        ("SemanticError", 'label "l" is already defined (line 18)', 19, 1),
        ("SemanticError", 'reward structure "r" is already defined (line 20)', 21, 1),
    ]


def test_one_namespace_for_constants_formulas_and_variables() -> None:
    text = """mdp
const int x = 1;
formula x = 2;
module m
  x : [0..1];
endmodule
"""
    assert lint(text) == [
        ("SemanticError", 'formula "x" is already defined as a constant (line 2)', 3, 1),
        ("SemanticError", 'variable "x" is already defined as a constant (line 2)', 5, 3),
    ]


def test_module_and_variable_may_share_a_name() -> None:
    # separate namespaces, as in PRISM (the PAYNT models have "module clk ... clk : ...")
    assert lint("mdp\nmodule clk\n  clk : [0..1];\n  [clk] true -> (clk'=1);\nendmodule\n") == []


def test_undefined_name_with_hint() -> None:
    text = (
        "mdp\nmodule m\n  x : [0..1];\n  [] goal -> true;\n  [] m > 0 -> true;\nendmodule\n"
        'label "goal" = x=1;\n'
    )
    got = lint(text)
    assert [d[1:] for d in got] == [
        ('undefined name "goal"', 4, 6),
        ('undefined name "m"', 5, 6),
    ]


def test_cyclic_formulas() -> None:
    text = """mdp
formula a = b + 1;
formula b = c;
formula c = a;
formula d = a + 1;
module m
  x : [0..1];
  [] d > 0 -> true;
endmodule
"""
    # reported once, at the first formula of the cycle; uses of it cause no follow-up errors
    assert lint(text) == [
        ("SemanticError", 'cyclic definition of formula "a" (a -> b -> c -> a)', 2, 1)
    ]


def test_update_of_another_modules_variable() -> None:
    text = """mdp
global g : [0..2];
module m1
  x : [0..1];
  [a] true -> (y'=1) & (g'=1);
endmodule
module m2
  y : [0..1];
  [a] true -> (g'=2) & (y'=0);
  [] true -> (N'=1) & (z'=1);
endmodule
const int N = 1;
"""
    assert lint(text) == [
        ("SemanticError", 'module "m1" cannot modify variable "y" of module "m2"', 5, 15),
        ('SemanticError', 'cannot assign to constant "N"; only variables can be updated', 10, 14),
        ("SemanticError", 'unknown variable "z" in update', 10, 23),
    ]


def test_globals_may_be_updated_by_synchronised_commands() -> None:
    # PRISM's check "Synchronous command cannot modify global variable" is commented out in
    # ModulesFileSemanticCheck.visitPost(Update) and Modules2MTBDD: globals are allowed anywhere
    assert lint("mdp\nglobal g : [0..1];\nmodule m\n  [a] true -> (g'=1);\nendmodule\n") == []


def test_same_variable_twice_in_one_update() -> None:
    text = (
        "mdp\nmodule m\n  x : [0..1];\n"
        "  [] true -> 0.5 : (x'=0) & (x'=1) + 0.5 : (x'=1);\nendmodule\n"
    )
    assert lint(text) == [("SemanticError", 'variable "x" is set twice in the same update', 4, 29)]


RENAMED = """mdp
formula moving = x1 > 0;
module m1
  x1 : [0..2] init 0;
  [go1] !moving -> (x1'=1);
  [] moving & x1 < 2 -> (x1'=x1+1);
endmodule
module m2 = m1 [ x1 = x2, go1 = go2 ] endmodule
"""


def _module(fm: FlatModel, name: str):  # type: ignore[no-untyped-def]
    return next(m for m in fm.modules if m.name == name)


def test_renaming_expands_formulas_first() -> None:
    # PRISM expands formulas before renaming (benchmarks/scale/README.md): inside m2 the inlined
    # "moving" speaks about x2
    fm = instantiate(model(RENAMED))
    m2 = _module(fm, "m2")
    assert m2.variables == ("x2",)
    assert m2.actions == frozenset({"go2"})
    assert m2.commands[1].guard == Binary(
        BinaryOp.AND,
        Binary(BinaryOp.GT, Ident("x2"), IntLit(0)),
        Binary(BinaryOp.LT, Ident("x2"), IntLit(2)),
    )
    assert m2.commands[0].updates[0].assignments[0].variable == "x2"
    assert [v.name for v in fm.variables] == ["x1", "x2"]
    assert fm.variable("x2").module == "m2"


def test_renaming_must_rename_every_variable() -> None:
    text = RENAMED.replace("x1 = x2, ", "")
    assert lint(text) == [
        ("SemanticError", 'module "m2" must rename variable "x1" of module "m1"', 8, 1),
    ]


def test_renaming_errors() -> None:
    text = """mdp
module m1
  x1 : [0..2] init 0;
  [] true -> (x1'=1);
endmodule
module m2 = m1 [ x1 = x2, x1 = x3 ] endmodule
module m3 = nope [ x1 = x4 ] endmodule
module m4 = m1 [ x1 = y ] endmodule
module m5 = m1 [ x1 = y ] endmodule
"""
    assert lint(text) == [
        ("SemanticError", '"x1" is renamed twice in module "m2"', 6, 27),
        ("SemanticError", 'no module "nope" to rename in module "m3"', 7, 1),
        # the new variable's declaration is the "old=new" entry of the renaming
        ("SemanticError", 'variable "y" is already defined as a variable (line 8)', 9, 18),
    ]


def test_renaming_a_formula_follows_storm() -> None:
    # PRISM rejects renaming a formula; Storm substitutes it, and PAYNT's rocks-12 relies on it
    text = """mdp
const int c1 = 1;
const int c2 = 2;
formula near1 = x1 = c1;
formula near2 = x2 = c2;
module m1
  x1 : [0..2] init 0;
  [] near1 -> (x1'=0);
endmodule
module m2 = m1 [ x1 = x2, near1 = near2 ] endmodule
"""
    fm = instantiate(model(text))
    assert _module(fm, "m2").commands[0].guard == Binary(BinaryOp.EQ, Ident("x2"), IntLit(2))
