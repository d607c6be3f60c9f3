"""Type checking of model expressions, with PRISM's rules (prism-games
``prism/src/parser/visitor/TypeCheck.java``). Each error is checked by message and position
(line, column of the offending sub-expression)."""

from __future__ import annotations

import pytest

from ._helpers import lint


def wrap(body: str, *, decls: str = "") -> str:
    """A one-module mdp around ``body`` (commands), with int x, bool b and double constant p."""
    return (
        "mdp\n"
        "const double p = 0.5;\n"
        f"{decls}"
        "module m\n"
        "  x : [0..3] init 0;\n"
        "  b : bool init false;\n"
        f"{body}"
        "endmodule\n"
    )


# the command line is line 6 (or later by the number of declaration lines)
@pytest.mark.parametrize(
    ("command", "message", "column"),
    [
        ("  [] x -> (x'=0);\n", "a guard must be Boolean, found int", 6),
        ("  [] b -> (x'=true);\n", 'cannot assign a bool value to int variable "x"', 15),
        ("  [] b -> (b'=2);\n", 'cannot assign an int value to bool variable "b"', 15),
        ("  [] b -> (x'=x/2.0);\n", 'cannot assign a double value to int variable "x"', 15),
        ("  [] b -> (x'=p/2);\n", 'cannot assign a double value to int variable "x"', 15),
        ("  [] b -> (x'=p);\n", 'cannot assign a double value to int variable "x"', 15),
        (
            "  [] b -> true : (x'=0);\n",
            "the probability of an update must be a number, found bool",
            11,
        ),
        ("  [] x + b > 0 -> true;\n", '"+" needs numbers, found bool', 10),
        ("  [] x & b -> true;\n", '"&" needs Boolean operands, found int', 6),
        ("  [] !x -> true;\n", '"!" needs a Boolean operand, found int', 7),
        ("  [] b = 1 -> true;\n", '"=" cannot compare bool and int', 6),
        ("  [] b < true -> true;\n", '"<" cannot compare bool and bool', 6),
        (
            "  [] (x > 0 ? b : 1) -> true;\n",
            'the branches of "? :" must have matching types, found bool and int',
            7,
        ),
        ("  [] (x ? b : b) -> true;\n", 'the condition of "? :" must be Boolean, found int', 7),
        ("  [] mod(x, p) = 0 -> true;\n", "mod() needs int arguments, found double", 13),
        ("  [] floor(b) = 0 -> true;\n", "floor() needs numeric arguments, found bool", 12),
        ("  [] y = 0 -> true;\n", 'undefined name "y"', 6),
    ],
)
def test_command_type_errors(command: str, message: str, column: int) -> None:
    assert lint(wrap(command)) == [("SemanticError", message, 6, column)]


def test_well_typed_commands() -> None:
    ok = (
        "  [a] b & x < 3 -> p : (x'=x+1) + (1-p) : (b'=!b);\n"
        "  [] x=3 -> 1/2 : (x'=floor(x/2)) + 0.5 : (x'=mod(x+5, 4)) & (b'=x>1 ? true : b);\n"
        "  [] x=2 => b -> (x'=min(x, 1, round(p)));\n"
    )
    assert lint(wrap(ok)) == []


def test_declaration_type_errors() -> None:
    text = """mdp
const double h = 1.5;
module m
  x : [0..h] init 0;
  y : [true..2] init 0;
  b : bool init 1;
  z : [0..3] init true;
  [] true -> true;
endmodule
label "l" = x;
rewards
  b : 1;
  x : true;
endrewards
"""
    assert lint(text) == [
        ("SemanticError", 'the upper bound of variable "x" must be an int, found double', 4, 11),
        ("SemanticError", 'the lower bound of variable "y" must be an int, found bool', 5, 8),
        ("SemanticError", 'the initial value of variable "b" must be Boolean, found int', 6, 17),
        ("SemanticError", 'the initial value of variable "z" must be an int, found bool', 7, 19),
        ("SemanticError", 'label "l" must be Boolean, found int', 10, 13),
        ("SemanticError", "the guard of a reward item must be Boolean, found int", 13, 3),
        ("SemanticError", "a reward must be a number, found bool", 13, 7),
    ]


def test_init_block() -> None:
    text = """mdp
module m
  x : [0..3] init 0;
  y : [0..3];
  [] true -> true;
endmodule
init x + y endinit
"""
    assert lint(text) == [
        (
            "SemanticError",
            'variable "x" has an initial value, but the model has an init...endinit block',
            3,
            19,
        ),
        ("SemanticError", "the init...endinit predicate must be Boolean, found int", 7, 6),
    ]


def test_non_constant_declarations() -> None:
    text = """mdp
module m
  x : [0..3] init 0;
  y : [0..x] init x;
  [] true -> true;
endmodule
"""
    assert lint(text) == [
        (
            "SemanticError",
            'the upper bound of variable "y" must be constant, but it refers to variable "x"',
            4,
            11,
        ),
        (
            "SemanticError",
            'the initial value of variable "y" must be constant, but it refers to variable "x"',
            4,
            19,
        ),
    ]


def test_init_out_of_range_and_empty_range() -> None:
    text = """mdp
const int N;
module m
  x : [0..N] init 4;
  y : [2..1];
  [] true -> true;
endmodule
"""
    # without N, only what does not depend on it is checked
    assert lint(text) == [("SemanticError", 'the range [2..1] of variable "y" is empty', 5, 3)]
    assert lint(text, constants={"N": 3}) == [
        ("SemanticError", 'the initial value 4 of variable "x" is outside its range [0..3]', 4, 19),
        ("SemanticError", 'the range [2..1] of variable "y" is empty', 5, 3),
    ]


def test_unbounded_int_is_unsupported() -> None:
    text = "mdp\nmodule m\n  x : int;\n  [] true -> true;\nendmodule\n"
    assert lint(text) == [
        (
            "UnsupportedError",
            'variable "x" has no range; unbounded ints are not supported',
            3,
            3,
        )
    ]


def test_errors_inside_formulas_point_into_the_formula() -> None:
    text = """mdp
formula f = x + true;
formula g = x + 1;
module m
  x : [0..3] init 0;
  [] g -> true;
  [] f > 0 -> true;
endmodule
"""
    assert lint(text) == [
        ('SemanticError', '"+" needs numbers, found bool', 2, 17),
        # the use of g as a guard: the error points at the use, not at the definition
        ("SemanticError", "a guard must be Boolean, found int", 6, 6),
    ]


def test_int_division_into_an_int_variable_is_storms_reading() -> None:
    # Storm types int/int as int (Type::divide keeps the larger operand type), so PAYNT's
    # lanes-100-combined-new updates "y'=SIZE/2+1" and geo-2-8 initialises "init gMAX/2":
    # accepted with a warning naming PRISM's rule; strict keeps PRISM's rule as an error
    text = wrap("  [] b -> (x'=(x+1)/2);\n", decls="const int N = 4;\n").replace(
        "init 0;", "init N/2;", 1
    )
    assert lint(text) == []
    strict = lint(text, strict=True)
    assert [(d[0], d[2], d[3]) for d in strict] == [
        ("SemanticError", 5, 19),
        ("SemanticError", 7, 15),
    ]
    assert strict[0][1].startswith('the initial value of int variable "x" divides ints (PRISM')
    assert strict[1][1] == (
        'the value assigned to int variable "x" divides ints (PRISM\'s rule: "/" gives a double, '
        "which an int variable does not take)"
    )


def test_int_division_with_a_double_operand_stays_an_error() -> None:
    # Storm refuses these too ("illegally assigning a value of type 'rational'")
    text = wrap("  [] b -> (x'=(x+p)/2);\n").replace("init 0;", "init 3/2.0;", 1)
    assert lint(text) == [
        ("SemanticError", 'the initial value of variable "x" must be an int, found double', 4, 19),
        ("SemanticError", 'cannot assign a double value to int variable "x"', 6, 15),
    ]


def test_an_initial_int_division_must_be_whole() -> None:
    text = wrap("", decls="const int N = 5;\n").replace("init 0;", "init N/2;", 1)
    ((kind, message, line, column),) = lint(text)
    assert (kind, line, column) == ("SemanticError", 5, 19)
    assert message == 'the initial value 5/2 of int variable "x" is not a whole number'
