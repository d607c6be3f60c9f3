"""Syntax errors: each one names what was found and what was expected, at the right place."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.errors import InputError, ParseError, PosgmcError, SourceSpan, UnsupportedError
from posgmc.syntax.parser import load_model, parse_expression, parse_model, parse_properties

MODULE_HEAD = "dtmc\nmodule m\n  x : [0..1] init 0;\n"


def _model_error(text: str) -> PosgmcError:
    with pytest.raises(PosgmcError) as info:
        parse_model(text, file="m.prism")
    return info.value


def _props_error(text: str) -> PosgmcError:
    with pytest.raises(PosgmcError) as info:
        parse_properties(text, file="p.props")
    return info.value


def _where(err: PosgmcError) -> tuple[int, int]:
    assert err.span is not None
    return err.span.line, err.span.column


@pytest.mark.parametrize(
    ("text", "message", "line", "column"),
    [
        # 1. missing ';' after a command: reported at the next command's '['
        (
            MODULE_HEAD + "  [] x=0 -> (x'=1)\n  [] x=1 -> true;\nendmodule\n",
            "expected '&' or ';' but found '['",
            5,
            3,
        ),
        # 2. missing ';' after a variable declaration
        (
            MODULE_HEAD.replace("init 0;", "init 0") + "  [] x=0 -> (x'=1);\nendmodule\n",
            "expected ';' but found '['",
            4,
            3,
        ),
        # 3. an expression is missing
        ("dtmc\nconst int N = ;\n", "expected an expression but found ';'", 2, 15),
        # 4. unbalanced parenthesis
        (
            MODULE_HEAD + "  [] x=0 -> (x'=(x+1);\nendmodule\n",
            "expected ')' but found ';'",
            4,
            22,
        ),
        # 5. a misspelt model type is one unexpected word, not `dtmc` followed by `c`
        (
            "dtmcc\nmodule m x : bool; endmodule\n",
            "expected a model type or a declaration (module, const, formula, label, ...) "
            "or the end of the text but found 'dtmcc'",
            1,
            1,
        ),
        # 6. label names are quoted
        ('dtmc\nlabel goal = x=1;\n', "expected a quoted name (\"...\") but found 'goal'", 2, 7),
        # 7. a probability without ':'
        (
            MODULE_HEAD + "  [] x=0 -> 0.5:(x'=1) + 0.5 (x'=0);\nendmodule\n",
            "expected ':' but found '('",
            4,
            30,
        ),
        # 8. an unknown character
        (MODULE_HEAD + "  [] x=0 -> (x'=1) @;\nendmodule\n", "unexpected character '@'", 4, 20),
        # 9. a call of something that is not a function
        (
            MODULE_HEAD + "  [] x=0 -> (x'=foo(x));\nendmodule\n",
            "'foo' is not a function: found '(' after it",
            4,
            20,
        ),
        # 10. wrong number of arguments
        (
            MODULE_HEAD + "  [] x=0 -> (x'=pow(x));\nendmodule\n",
            "pow takes 2 arguments, not 1",
            4,
            17,
        ),
        # 11. label names must be identifiers
        ('dtmc\nlabel "a b" = true;\n', "label names must be identifiers", 2, 7),
        # 12. player items need commas
        ("smg\nplayer p m1 [a] endplayer\n", "expected ',' between the items of player 'p'", 2, 13),
        # 13. two model types
        ("dtmc\nmdp\n", "there are multiple model type declarations", 2, 1),
        # 14. labels are not model expressions
        ('dtmc\nformula f = "a" & x;\n', 'expected an expression but found "a"', 2, 13),
    ],
)
def test_model_syntax_errors(text: str, message: str, line: int, column: int) -> None:
    err = _model_error(text)
    assert isinstance(err, ParseError)
    assert message in err.message
    assert _where(err) == (line, column)
    assert err.span is not None and err.span.file == "m.prism"


def test_missing_endmodule_before_next_module() -> None:
    err = _model_error(MODULE_HEAD + "  [] x=0 -> (x'=1);\nmodule n\n  y : bool;\nendmodule\n")
    assert err.message == (
        "expected '[' or 'endmodule' but found 'module': the module opened at line 2 is not closed"
    )
    assert _where(err) == (5, 1)
    assert err.hint == "add 'endmodule' to close the module that starts at line 2"


def test_missing_endmodule_at_end_of_file() -> None:
    err = _model_error(MODULE_HEAD + "  [] x=0 -> (x'=1);\n")
    assert err.message == (
        "the text ends inside the module opened at line 2: expected '[' or 'endmodule'"
    )
    # just past the last token, `;` ending at column 19 of line 4
    assert err.span == SourceSpan(4, 20, 4, 21, "m.prism")


def test_missing_endrewards_at_end_of_file() -> None:
    err = _model_error('dtmc\nrewards "r"\n  true : 1;\n')
    assert "the text ends inside the reward structure opened at line 2" in err.message
    assert err.hint is not None and "endrewards" in err.hint


def test_primed_variable_outside_parentheses() -> None:
    err = _model_error(MODULE_HEAD + "  [] x=0 -> x'=1;\nendmodule\n")
    assert err.message == "expected an expression but found \"x'\""
    assert _where(err) == (4, 13)
    assert err.hint is not None and "(x'=x+1)" in err.hint


def test_update_without_prime() -> None:
    err = _model_error(MODULE_HEAD + "  [] x=0 -> (x=1);\nendmodule\n")
    assert err.message == "expected ':' but found ';'"
    assert _where(err) == (4, 18)
    assert err.hint is not None and "primed" in err.hint


def test_unsupported_model_type() -> None:
    err = _model_error("ctmc\nmodule m x : bool; endmodule\n")
    assert isinstance(err, UnsupportedError)
    assert err.message == "model type 'ctmc' is not supported"
    assert err.span == SourceSpan(1, 1, 1, 5, "m.prism")


def test_render_shows_the_line_and_a_caret() -> None:
    err = _model_error("dtmc\nconst int N = 3\nmodule m x : bool; endmodule\n")
    assert err.render() == (
        "m.prism:3:1: error: expected ';' but found 'module'\n"
        "  module m x : bool; endmodule\n"
        "  ^~~~~~"
    )


class TestPropertyErrors:
    def test_time_bound_with_minus(self) -> None:
        err = _props_error('Pmax=? [F<=T-1 "goal"]')
        assert err.message == "expected ']' but found \"goal\""
        assert _where(err) == (1, 16)
        assert err.hint is not None and "F<=(T-1)" in err.hint

    def test_time_bound_with_plus(self) -> None:
        err = _props_error('Pmax=? [F<=T+1 "goal"]')
        assert err.message == "expected an expression, '*' or '/' but found '+'"
        assert _where(err) == (1, 13)
        assert err.hint is not None and "parentheses" in err.hint

    def test_missing_brackets(self) -> None:
        err = _props_error('Pmax=? F "goal"')
        assert err.message == "expected '[' but found 'F'"
        assert _where(err) == (1, 8)

    def test_temporal_operator_at_top_level(self) -> None:
        err = _props_error('\nF "goal"')
        assert "found 'F'" in err.message
        assert _where(err) == (2, 1)
        assert err.hint is not None and "inside P[...]" in err.hint

    def test_unclosed_bracket(self) -> None:
        err = _props_error('Pmax=? [F "goal"\n')
        assert err.message == "expected ']' but found the end of the text"
        assert _where(err) == (1, 17)

    def test_unclosed_coalition(self) -> None:
        err = _props_error('<<p1 Pmax=? [F "goal"]')
        assert err.message == "expected ',' or '>>' but found 'Pmax'"
        assert _where(err) == (1, 6)

    def test_reward_index_must_be_a_name_or_number(self) -> None:
        err = _props_error('R{x}max=? [F "goal"]')
        assert err.message == "expected a quoted name (\"...\") or an integer but found 'x'"
        assert _where(err) == (1, 3)

    def test_until_is_not_associative(self) -> None:
        err = _props_error('Pmax=? [ "a" U "b" U "c" ]')
        assert err.message == "expected ']' but found 'U'"
        assert _where(err) == (1, 20)


def test_empty_expression() -> None:
    with pytest.raises(ParseError) as info:
        parse_expression("   ")
    assert info.value.message == "expected an expression but found the end of the text"
    assert _where(info.value) == (1, 1)


def test_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(InputError) as info:
        load_model(tmp_path / "missing.prism")
    assert "cannot read" in info.value.message


def test_errors_carry_the_source() -> None:
    err = _model_error("dtmc\nconst int N = ;\n")
    assert err.source is not None and err.source.file == "m.prism"


_SAMPLE_MODEL = """smg
const double p = 0.85;
player p1 host, [send1] endplayer
player p2 client endplayer
module host
  h : [0..2] init 0;
  [send1] h=0 -> (h'=1);
  [] c=0 -> (h'=0);
endmodule
module client
  c : [0..2] init 0;
  [send1] c=0 -> p : (c'=1) + 1-p : (c'=0);
endmodule
rewards "r" [send1] true : 1; endrewards
label "done" = c=1;
"""


@settings(max_examples=60, deadline=None)
@given(
    st.integers(min_value=0, max_value=len(_SAMPLE_MODEL)),
    st.integers(min_value=0, max_value=4),
    st.sampled_from(list(";()[]:=+-&|'\"x0.<>{}\n") + ["endmodule", "module", ""]),
)
def test_damaged_models_fail_with_a_spanned_error(cut: int, drop: int, insert: str) -> None:
    # Invariant: whatever the damage, the result is a tree or a PosgmcError pointing into the
    # text (never a lark exception or a traceback from the transformer).
    text = _SAMPLE_MODEL[:cut] + insert + _SAMPLE_MODEL[cut + drop :]
    try:
        parse_model(text, file="d.prism")
    except PosgmcError as err:
        assert err.span is not None and err.span.file == "d.prism"
        assert 1 <= err.span.line <= text.count("\n") + 1
        assert err.span.column >= 1
        assert err.render().startswith("d.prism:")


def test_huge_exponent_is_rejected() -> None:
    with pytest.raises(ParseError) as info:
        parse_expression("x < 1e999999999", file="e")
    assert "out of range" in info.value.message
    assert info.value.span == SourceSpan(1, 5, 1, 16, "e")


@pytest.mark.parametrize(
    "hole",
    ["hole int o1x in {3,4,5};", "hole double p in {0.1, 0.2};", "hole bool b in {true};"],
)
def test_a_paynt_sketch_is_refused_as_a_family_of_models(hole: str) -> None:
    # PAYNT's sketch.templ files (e.g. pomdp/sketches/avoid-smaller-family) declare holes at the
    # top level, between ordinary declarations: one message at the first hole, whatever follows
    text = "pomdp\nconst int N = 3;\n" + hole + "\n" + hole.replace(" in", "2 in") + "\n"
    err = _model_error(text + "module m\n  x : [0..1] init 0;\n  [] true -> true;\nendmodule\n")
    assert isinstance(err, ParseError)
    assert err.message.startswith("'hole' declares a parameter of a PAYNT sketch: this file ")
    assert "family of models" in err.message
    assert _where(err) == (3, 1)
    assert "const" in (err.hint or "")
