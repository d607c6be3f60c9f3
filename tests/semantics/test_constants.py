"""Constants: ``--const`` parsing and sweeps, dependency order, cycles, user values and their types.

Rules from PRISM (prism-games ``prism/src/prism/UndefinedConstants.java``: "Constant ... has already
been defined", "Invalid format in definition of undefined constants"; ``ConstantList.findCycles``);
expected values are hand-derived.
"""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc.errors import ConstantError, SourceSpan
from posgmc.semantics.constants import (
    ConstRange,
    ConstSetting,
    convert_user_value,
    expand_sweep,
    parse_const_assignments,
)
from posgmc.semantics.stages import check_model, instantiate
from posgmc.syntax.ast import VarType

from ._helpers import lint, model

MODEL = """dtmc
const int N;
const double p;
const bool b;
const int M = 2*K;
const int K = N + 1;
module m
  x : [0..M] init 0;
  [] b -> p : (x'=0) + 1-p : (x'=min(x+1, M));
endmodule
"""


def test_parse_const_assignments() -> None:
    got = parse_const_assignments("N=4,p=0.9,k=0:5,M=1:2:9, b = true")
    assert got["N"] == ConstSetting("4", SourceSpan(1, 1, 1, 4, "--const"))
    assert got["p"].value == "0.9"  # type: ignore[union-attr]
    assert got["k"] == ConstRange("0", "5", "1", got["k"].span)
    assert got["M"] == ConstRange("1", "9", "2", got["M"].span)
    assert got["b"].value == "true"  # type: ignore[union-attr]
    assert list(got) == ["N", "p", "k", "M", "b"]


@pytest.mark.parametrize(
    ("text", "message", "column"),
    [
        ("N=4,p", '"p" is not of the form name=value', 5),
        ("N=", '"N=" is not of the form name=value', 1),
        ("N=1,N=2", 'constant "N" is given a value twice', 5),
        ("2x=1", '"2x" is not a constant name', 1),
        ("k=0:1:2:3", '"0:1:2:3" is not a range start:stop or start:step:stop', 1),
    ],
)
def test_parse_const_assignment_errors(text: str, message: str, column: int) -> None:
    with pytest.raises(ConstantError) as exc:
        parse_const_assignments(text)
    assert exc.value.message == message
    assert exc.value.span is not None
    assert (exc.value.span.file, exc.value.span.line, exc.value.span.column) == (
        "--const",
        1,
        column,
    )


def test_ranges_and_sweeps() -> None:
    assert ConstRange("0", "5").values() == (0, 1, 2, 3, 4, 5)
    assert ConstRange("1", "9", "2").values() == (1, 3, 5, 7, 9)
    # doubles stay exact: 0.1 steps do not drift
    assert ConstRange("0.1", "0.5", "0.1").values() == tuple(Fraction(i, 10) for i in range(1, 6))
    assert ConstRange("5", "1", "-2").values() == (5, 3, 1)
    with pytest.raises(ConstantError, match="the step of the range 0:0:3 is zero"):
        ConstRange("0", "3", "0").values()
    with pytest.raises(ConstantError, match="is empty"):
        ConstRange("3", "1").values()
    sweep = expand_sweep(parse_const_assignments("k=0:2,N=3,j=1:2"))
    assert [(s["k"].value, s["j"].value) for s in sweep] == [  # type: ignore[union-attr]
        (0, 1), (0, 2), (1, 1), (1, 2), (2, 1), (2, 2)
    ]
    assert all(s["N"].value == "3" for s in sweep)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("var_type", "given", "expected"),
    [
        (VarType.INT, "4", 4),
        (VarType.INT, " -3 ", -3),
        (VarType.INT, 7, 7),
        (VarType.DOUBLE, "0.9", Fraction(9, 10)),
        (VarType.DOUBLE, "1e-3", Fraction(1, 1000)),
        (VarType.DOUBLE, "1/3", Fraction(1, 3)),
        (VarType.DOUBLE, 2, Fraction(2)),  # an int may be given to a double
        (VarType.DOUBLE, 0.9, Fraction(9, 10)),  # a float is read through its repr
        (VarType.BOOL, "true", True),
        (VarType.BOOL, False, False),
    ],
)
def test_convert_user_value(var_type: VarType, given: object, expected: object) -> None:
    v = convert_user_value("c", var_type, given)
    assert v == expected and type(v) is type(expected)


@pytest.mark.parametrize(
    ("var_type", "given", "message"),
    [
        (VarType.INT, "0.5", 'constant "c" is an int, but "0.5" is not an integer'),
        (VarType.INT, 0.5, 'constant "c" is an int, but 0.5 is not an integer'),
        (VarType.INT, Fraction(4), 'constant "c" is an int, but Fraction(4, 1) is not an integer'),
        (VarType.INT, True, 'constant "c" is an int, but True is a Boolean'),
        (VarType.DOUBLE, "abc", 'constant "c" is a double, but "abc" is not a number'),
        (VarType.BOOL, "1", 'constant "c" is a bool, but "1" is not true or false'),
    ],
)
def test_convert_user_value_errors(var_type: VarType, given: object, message: str) -> None:
    with pytest.raises(ConstantError) as exc:
        convert_user_value("c", var_type, given)
    assert exc.value.message == message


def test_dependency_order_and_values() -> None:
    # M depends on K which is declared after it: evaluated in dependency order
    fm = instantiate(model(MODEL), constants={"N": "4", "p": "0.25", "b": "true"})
    assert dict(fm.constants) == {"N": 4, "p": Fraction(1, 4), "b": True, "M": 10, "K": 5}
    assert fm.variable("x").high == 10


def test_lint_without_values_is_clean_but_instantiate_names_undefined() -> None:
    assert lint(MODEL) == []
    with pytest.raises(ConstantError) as exc:
        instantiate(model(MODEL), constants={"p": "0.5"})
    assert exc.value.message == 'undefined constants "N" and "b" must be given values'
    assert exc.value.span is not None and (exc.value.span.line, exc.value.span.column) == (2, 1)
    assert exc.value.hint is not None and "--const N=...,b=..." in exc.value.hint


def test_user_value_errors_point_at_the_setting_or_the_declaration() -> None:
    settings = parse_const_assignments("N=0.5,p=1,b=true,M=4,Q=1")
    assert lint(MODEL, constants=settings) == [
        ("ConstantError", 'constant "N" is an int, but "0.5" is not an integer', 1, 1),
        (
            "ConstantError",
            'constant "M" is already defined in the file, so it cannot be given a value',
            1,
            18,
        ),
        ("ConstantError", '"Q" is not a constant of the model', 1, 22),
    ]
    # plain Python values have no position: the declaration is shown instead
    assert lint(MODEL, constants={"N": 0.5, "p": 1, "b": True}) == [
        ("ConstantError", 'constant "N" is an int, but 0.5 is not an integer', 2, 1),
    ]


def test_unknown_constant_given_by_user() -> None:
    assert lint(MODEL, constants={"N": 1, "p": 1, "b": True, "nope": 3}) == [
        ("ConstantError", '"nope" is not a constant of the model', None, None),
    ]


def test_int_constant_given_non_integer() -> None:
    assert lint(MODEL, constants={"N": "2.5", "p": 1, "b": True}) == [
        ("ConstantError", 'constant "N" is an int, but "2.5" is not an integer', 2, 1),
    ]


def test_cyclic_constants() -> None:
    text = """dtmc
const int a = c + 1;
const int b = 2;
const int c = a;
module m x : [0..b] init 0; [] true -> true; endmodule
"""
    assert lint(text) == [
        ("ConstantError", 'cyclic definition of constant "a" (a -> c -> a)', 2, 1),
    ]
    assert lint("dtmc\nconst int a = a;\nmodule m x : [0..1]; endmodule\n") == [
        ("ConstantError", 'cyclic definition of constant "a" (a -> a)', 2, 1),
    ]


def test_int_constant_defined_by_a_double() -> None:
    # Storm types N/2 as an int (PAYNT's rocks-12 writes "const r1x = N/2;"): a whole value is
    # accepted as an int, anything else is an error at the definition
    text = (
        "dtmc\nconst int N = 12;\nconst r = N/2;\nconst int h = 0.5;\n"
        "module m x : [0..r]; endmodule\n"
    )
    assert lint(text) == [
        ("ConstantError", 'int constant "h" has the value 0.5, which is not a whole number', 4, 15),
    ]
    fm = instantiate(model(text.replace("const int h = 0.5;\n", "")))
    assert dict(fm.constants)["r"] == 6 and type(dict(fm.constants)["r"]) is int


def test_constant_definition_type_errors() -> None:
    text = (
        "dtmc\nconst bool b = 1;\nconst double d = true;\nconst int i = x;\n"
        "module m x : [0..1]; endmodule\n"
    )
    assert lint(text) == [
        ("SemanticError", 'the value of constant "b" must be Boolean, found int', 2, 16),
        ("SemanticError", 'the value of constant "d" must be a number, found bool', 3, 18),
        (
            "SemanticError",
            'the definition of constant "i" must be constant, but it refers to variable "x"',
            4,
            15,
        ),
    ]


def test_properties_constants_in_the_same_mapping() -> None:
    # one mapping for model and properties (the CLI's --const): the model's passes accept the
    # properties' names when told so; check_properties reports names unknown to both files
    from posgmc.semantics.stages import check_properties, instantiate_properties
    from posgmc.syntax.parser import parse_properties

    m = model(MODEL)
    settings = {"N": "1", "p": "0.5", "b": "true", "k": "3"}
    assert [e.message for e in check_model(m, constants=settings)] == [
        '"k" is not a constant of the model'
    ]
    assert check_model(m, constants=settings, allow_extra_constants=True) == []
    fm = instantiate(m, constants=settings, allow_extra_constants=True)
    props = parse_properties("const int k;\nP=? [F<=k x=1]\n")
    assert check_properties(props, m, constants=settings) == []
    (cp,) = instantiate_properties(props, fm, model=m, constants=settings)
    assert cp.constants == (("k", 3),) and cp.property is cp.prop
    assert [e.message for e in check_properties(props, m, constants={**settings, "q": 1})] == [
        '"q" is not a constant of the model or the properties'
    ]
