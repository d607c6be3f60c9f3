"""Machine-generated expressions, wide and deep, build and check.

Each of these is deep or wide enough to raise "internal error: SyntaxError: too many nested
parentheses" (in generated numpy code) or RecursionError in a naive compiler, while ``lint``
would say ok for the same files. Expected
values are hand derivations given beside each case.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.compiler.compile_expr import Columns, ExprType, compile_expr
from posgmc.syntax.ast import Binary, BinaryOp, Ident, IntLit, Unary, UnaryOp

GOAL = 'Pmax=? [ F "goal" ]'


def _model(tmp_path: Path, guard: str, *, consts: str = "", label: str = "x=1") -> str:
    path = tmp_path / "big.prism"
    path.write_text(
        f"mdp\n{consts}\nmodule m\n  x : [0..200] init 0;\n"
        f"  [] {guard} -> (x'=min(x+1, 200));\nendmodule\nlabel \"goal\" = {label};\n"
    )
    return str(path)


def _check(model: str, *props: str) -> list[float]:
    session = api.load(model)
    assert api.lint(model, property_texts=props) == []
    built = api.build(session)
    report = api.check(session, properties=props, built=built)
    assert not report.errors
    return [float(r.value) for r in report.results]


def test_wide_disjunction_guard(tmp_path: Path) -> None:
    # x=0|...|x=199 enables the step in every state below 200: "goal" (x=200) is reached surely
    model = _model(tmp_path, "|".join(f"x={i}" for i in range(200)), label="x=200")
    assert api.build(api.load(model)).model.num_states == 201
    assert _check(model, GOAL) == [1.0]


def test_constant_summing_340_terms(tmp_path: Path) -> None:
    # A = 0+1+...+339 = 339*340/2 = 57630 > 0, so the guard holds
    terms = "+".join(str(i) for i in range(340))
    model = _model(tmp_path, "x=0 & A=57630", consts=f"const int A = {terms};")
    assert _check(model, GOAL) == [1.0]


@pytest.mark.parametrize(
    "guard, enabled",
    [
        ("-" * 500 + "x >= 0", True),  # an even number of minus signs: x >= 0
        ("!" * 500 + "(x=0)", True),  # 500 negations: x=0
        ("!" * 501 + "(x=0)", False),  # 501: x!=0, never enabled at x=0
        ("(" + "x=0 ? 1 : " * 500 + "0)=1", True),  # 500 nested ?: all true at x=0
    ],
)
def test_500_chained_unary_and_conditional(tmp_path: Path, guard: str, enabled: bool) -> None:
    model = _model(tmp_path, f"x<1 & {guard}")
    assert _check(model, GOAL) == [1.0 if enabled else 0.0]


def test_300_nested_next_in_a_property(tmp_path: Path) -> None:
    # a coin tossed each step: after 300 steps x=1 with probability 1/2 (hand derivation)
    path = tmp_path / "coin.prism"
    path.write_text(
        "mdp\nmodule m\n  x : [0..1] init 0;\n  [] true -> 0.5:(x'=1) + 0.5:(x'=0);\n"
        'endmodule\nlabel "goal" = x=1;\n'
    )
    flat = "Pmax=? [ " + "X " * 300 + '"goal" ]'
    nested = "Pmax=? [ " + "X (" * 300 + '"goal"' + ")" * 300 + " ]"
    for value in _check(str(path), flat, nested):
        assert value == pytest.approx(0.5, abs=1e-5)


def test_deeper_than_the_stack_is_a_clear_error(tmp_path: Path) -> None:
    model = _model(tmp_path, "!" * 30000 + "(x=0)")
    r = CliRunner().invoke(main, ["build", model])
    assert r.exit_code == 2 and "nests too deeply" in r.output and "internal" not in r.output


def test_compiled_code_never_nests_deeply() -> None:
    # the generated source cuts deep expressions into temporaries (Python refuses > 200 brackets)
    e = Ident("x")
    for _ in range(1000):
        e = Unary(UnaryOp.NEG, e)
    chain = Binary(BinaryOp.EQ, Ident("x"), IntLit(0))
    for i in range(1, 500):
        chain = Binary(BinaryOp.OR, chain, Binary(BinaryOp.EQ, Ident("x"), IntLit(i)))
    slots = {"x": (0, ExprType.INT)}
    cols = Columns([np.array([3, 700])], 2)
    assert compile_expr(e, slots).evaluate(cols).tolist() == [3, 700]
    compiled = compile_expr(chain, slots)
    assert compiled.evaluate(cols).tolist() == [True, False]
    assert max(_nesting(line) for line in compiled.source.splitlines()) <= 60


def _nesting(line: str) -> int:
    depth = deepest = 0
    for ch in line:
        depth += ch in "(["
        depth -= ch in ")]"
        deepest = max(deepest, depth)
    return deepest


# -- one rule for integers: 64-bit, an error on overflow (docs/language.md) -----------------------


def _cube_model(tmp_path: Path, guard: str) -> str:
    path = tmp_path / "cube.prism"
    path.write_text(
        "mdp\nconst int B = 3000000000;\nmodule m\n  x : [0..3000000000] init 3000000000;\n"
        f"  y : [0..1] init 0;\n  [] y=0 & {guard} -> (y'=1);\nendmodule\n"
    )
    return str(path)


@pytest.mark.parametrize("guard, column", [("x*x*x > 0", 12), ("B*B*B > 0", 12)])
def test_int_overflow_is_an_error_for_variables_and_constants(
    tmp_path: Path, guard: str, column: int
) -> None:
    # 3e9^3 = 2.7e28 > 2^63: numpy would wrap the variable product to 0 while the constant one is
    # exact; both are the same positioned error
    r = CliRunner().invoke(main, ["build", _cube_model(tmp_path, guard)])
    assert r.exit_code == 2, r.output
    assert f"cube.prism:6:{column}: error: integer overflow" in r.output
    assert "27000000000000000000000000000 is beyond 64-bit integers" in r.output


def test_overflow_in_an_untaken_branch_is_no_error(tmp_path: Path) -> None:
    # PRISM evaluates only the branch taken; an overflow elsewhere must not fail the build
    model = _cube_model(tmp_path, "(x < 5 ? x*x*x : 1) > 0")
    assert api.build(api.load(model)).model.num_states == 2


@pytest.mark.parametrize(
    "text, message",
    [
        ("x : [0..18446744073709551616] init 0;", "beyond 64-bit integers"),
        ("x : [0..pow(10,400)] init 0;", "pow() of two ints overflows 64-bit integers"),
        ("x : [0..9223372036854775807+1] init 0;", "integer overflow"),
    ],
)
def test_huge_integer_ranges_are_positioned_errors(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "r.prism"
    path.write_text(f"mdp\nmodule m\n  {text}\n  [] true -> true;\nendmodule\n")
    for verb in ("lint", "build"):
        r = CliRunner().invoke(main, [verb, str(path)])
        assert r.exit_code == 2 and message in r.output and "r.prism:3:" in r.output, r.output


def test_an_int_constant_beyond_64_bits_names_the_option(tmp_path: Path) -> None:
    path = tmp_path / "c.prism"
    path.write_text(
        "mdp\nconst int N;\nmodule m\n  x : [0..1] init 0;\n  [] x<N -> true;\nendmodule\n"
    )
    r = CliRunner().invoke(main, ["build", str(path), "--const", "N=99999999999999999999"])
    assert r.exit_code == 2 and "--const:1:1" in r.output and "beyond 64-bit" in r.output
