"""The fast parse loop (actions run during the LALR parse, own lexing loop, collector paused,
grammar analysis cached) builds exactly the trees, spans and errors of the tree-building parser it
replaced.

Evidence, strongest first:

* ``GOLDEN``: for every PRISM-language model and property file among the vendored benchmarks and in
  ``models/``, a digest of the whole syntax tree *with every span* (spans take no part in ``==``).
  The digests were recorded with the previous parser (lark parse tree with
  ``propagate_positions=True``, then a ``Transformer``; commit e541142). They were re-recorded
  once, when ``ast.py``'s ``Node`` base moved ``span`` ahead of the other fields and the dump
  began to list fields by name: the new digests were computed both on the trees of commit 374b798
  (which matched the e541142 digests) and on the trees after the change, identical for every
  file. A deliberate change of ``ast.py`` changes them; re-record with
  ``python -m tests.syntax.test_parser_speed_invariants`` only after checking the change.
* Span invariants on every node of those files, which say what a span must be (the text of a
  leaf is its lexeme; an operator's span starts at its left operand or the '(' before it).
* The own lexing loop and lark's lexer give the same trees, spans included.
* Errors found while converting wait for the end of the parse, so that a syntax error further on
  is reported first, as when the conversion ran on the finished tree.
"""

from __future__ import annotations

import dataclasses
import enum
import gc
import hashlib
import os
import re
import sys
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest

import posgmc.syntax.lalr as lalr_module
from posgmc.errors import ParseError, PosgmcError, SourceSpan
from posgmc.syntax.ast import (
    Binary,
    BoolLit,
    DoubleLit,
    ExpectedResult,
    Ident,
    IntLit,
    LabelRef,
    ModelFile,
    PropertiesFile,
)
from posgmc.syntax.parser import parse_model, parse_properties
from tests.conftest import BENCHMARKS

ROOT = Path(__file__).resolve().parents[2]
MODELS_DIR = ROOT / "models"
MODEL_SUFFIXES = (".prism", ".nm", ".smg", ".posg")


# --- the files ------------------------------------------------------------------------------------


def _is_drn(path: Path) -> bool:
    # PAYNT's sketch.templ files are either PRISM text or DRN exported by Storm (see
    # tests/syntax/test_benchmarks.py); only the former are PRISM language
    head = path.read_text(encoding="utf-8", errors="replace")[:4000]
    return head.lstrip().startswith("// Exported") or "@type:" in head


def _files() -> list[tuple[str, Path]]:
    """(name used in spans and in GOLDEN, path) of every PRISM-language file."""
    found: list[tuple[str, Path]] = []
    for base, prefix in ((BENCHMARKS, "benchmarks/"), (MODELS_DIR, "models/")):
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*")):
            if not path.is_file():
                continue
            is_model = path.suffix in MODEL_SUFFIXES or path.name == "sketch.templ"
            if (is_model and not _is_drn(path)) or path.suffix == ".props":
                found.append((prefix + path.relative_to(base).as_posix(), path))
    return found


FILES = _files()


def _parse(name: str, path: Path) -> ModelFile | PropertiesFile:
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".props":
        return parse_properties(text, file=name)
    return parse_model(text, file=name)


# --- a dump that includes the spans -------------------------------------------------------------


# fields added after the digests were recorded: left out while at their default, so the recorded
# digests still pin everything else
ADDED_LATER = {("ExpectedResult", "number")}


def dump(value: Any) -> str:
    """Every field of every node, spans included, in a canonical text form (fields sorted by name,
    so that the order in which ``ast.py`` declares them does not matter)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = ", ".join(
            f"{f.name}={dump(getattr(value, f.name))}"
            for f in sorted(dataclasses.fields(value), key=lambda f: f.name)
            if not (
                (type(value).__name__, f.name) in ADDED_LATER
                and getattr(value, f.name) == f.default
            )
        )
        return f"{type(value).__name__}({fields})"
    if isinstance(value, tuple):
        return "(" + ", ".join(dump(v) for v in value) + ")"
    if isinstance(value, list):
        return "[" + ", ".join(dump(v) for v in value) + "]"
    if isinstance(value, enum.Enum):
        return f"{type(value).__name__}.{value.name}"
    return f"{type(value).__name__}:{value!r}"


def digest(value: Any) -> str:
    return hashlib.sha256(dump(value).encode("utf-8")).hexdigest()[:16]


# Recorded with the previous (tree-building) parser, see the module docstring.
GOLDEN: dict[str, str] = {
    "benchmarks/pomdp/4x3-95/sketch.props": "bd749c16ac85e093",
    "benchmarks/pomdp/crypt-4/sketch.props": "0f703077cc3e4ab8",
    "benchmarks/pomdp/crypt-4/sketch.templ": "764a8ab5785a06ac",
    "benchmarks/pomdp/drone-4-1/sketch.props": "2759313e2a22e2d1",
    "benchmarks/pomdp/drone-4-1/sketch.templ": "7aadd65d718c2c1f",
    "benchmarks/pomdp/grid-avoid-4-0.1/sketch.props": "8203de5b85761a2b",
    "benchmarks/pomdp/grid-avoid-4-0.1/sketch.templ": "fe62256f0445eda2",
    "benchmarks/pomdp/grid-large-10-5/sketch.props": "c6d8a27497f372ff",
    "benchmarks/pomdp/grid-large-10-5/sketch.templ": "652f252bce461a28",
    "benchmarks/pomdp/maze-alex/sketch.props": "5366cd1b69e0f399",
    "benchmarks/pomdp/maze-alex/sketch.templ": "8320ffb53b6adc92",
    "benchmarks/pomdp/network-2-8-20/sketch.props": "d3aaf0d7ba6d1557",
    "benchmarks/pomdp/network-2-8-20/sketch.templ": "4ec0c5526a8faea1",
    "benchmarks/pomdp/nrp-8/sketch.props": "647cebc6c9f8dc14",
    "benchmarks/pomdp/nrp-8/sketch.templ": "37bd9fd02e956e6b",
    "benchmarks/pomdp/obstacle/sketch.props": "eff192e766729f21",
    "benchmarks/pomdp/obstacle/sketch.templ": "c0b705526943f020",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.named-rewards.prism": "50b08587b9941c44",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.named-rewards.props": "89e74dc38d7746df",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.prism": "6dc878c7043baef0",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.prism.props": "a48d63c55d5c0b2a",
    "benchmarks/pomdp/prism-maze/maze.named-rewards.prism": "2794cc5c4e4fa398",
    "benchmarks/pomdp/prism-maze/maze.named-rewards.props": "304ec102e1914216",
    "benchmarks/pomdp/prism-maze/maze.prism": "419df49c9ea06fb1",
    "benchmarks/pomdp/prism-maze/maze.prism.props": "a0d33f795683da0b",
    "benchmarks/pomdp/prism-maze/maze.storm.props": "87b2da5a627736dc",
    "benchmarks/pomdp/query-s2/sketch.props": "f4e9f1fea7c98bc6",
    "benchmarks/pomdp/refuel-06/sketch.props": "f76945a158f8ee82",
    "benchmarks/pomdp/refuel-06/sketch.templ": "445d9fc9ee26c721",
    "benchmarks/pomdp/rocks-12/sketch.props": "2dbe81dac1b5c817",
    "benchmarks/pomdp/rocks-12/sketch.templ": "1359c96486392ef2",
    "benchmarks/posmg/attacker-defender/model.prism": "3551a0134d2c2689",
    "benchmarks/posmg/attacker-defender/sketch.props": "d762394c808580cb",
    "benchmarks/posmg/attacker-one-defender/model.prism": "f30348229a7c0522",
    "benchmarks/posmg/attacker-one-defender/sketch.props": "ae8dd9bf6185723b",
    "benchmarks/posmg/dice-and-coin/model.prism": "5d634a30dea8b365",
    "benchmarks/posmg/dice-and-coin/sketch.props": "11b0796b9a094cd7",
    "benchmarks/posmg/dice-and-coin2/model.prism": "35d0b63bfb70f890",
    "benchmarks/posmg/dice-and-coin2/sketch.props": "08f827f27db27a74",
    "benchmarks/posmg/dodge-6-lines/model.prism": "0de63b5651436abe",
    "benchmarks/posmg/dodge-6-lines/sketch.props": "09fa255d80d3641b",
    "benchmarks/posmg/dodge-6-lines-position/model.prism": "d6d976d77e41e6a8",
    "benchmarks/posmg/dodge-6-lines-position/sketch.props": "86fd53fae88a3684",
    "benchmarks/posmg/dodge-8/model.prism": "9f1fb7e6276c8005",
    "benchmarks/posmg/dodge-8/sketch.props": "bec54dbded471ff7",
    "benchmarks/posmg/grid-walls/model.prism": "b6efbc2f005d4884",
    "benchmarks/posmg/grid-walls/sketch.props": "22360da865cb4d38",
    "benchmarks/posmg/mec-test/sketch.props": "61b507f44eb57e8f",
    "benchmarks/posmg/multi-dodge4/model.prism": "a1ec1b6b094034e9",
    "benchmarks/posmg/multi-dodge4/sketch.props": "2181fdf968a7c331",
    "benchmarks/posmg/pomdp-variants/dice-and-coin/sketch.props": "a9fce5081f989d06",
    "benchmarks/posmg/pomdp-variants/dice-and-coin/sketch.templ": "822fe2114542f2af",
    "benchmarks/posmg/pomdp-variants/dice-and-coin2/sketch.props": "c7b16d68f8aae778",
    "benchmarks/posmg/pomdp-variants/dice-and-coin2/sketch.templ": "85b30f3a5e73c96e",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.opt.props": "8f0b07aec788a1b3",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.props": "2db40605cc44ab29",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.templ": "4b04e9f3e119bcb8",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.opt.props": "d72990acc9941ebd",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.props": "cd017309ffce25cb",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.templ": "78154be9189d2fa8",
    "benchmarks/posmg/prism-models/attacker-defender-pmin.prism": "1e99606af9dbf942",
    "benchmarks/posmg/prism-models/attacker-defender-rounds.prism": "604c644bcd91e4d6",
    "benchmarks/posmg/prism-models/attacker-defender-rounds2.prism": "85fe96ed7d9e58da",
    "benchmarks/posmg/prism-models/attacker-defender-rounds3.prism": "ce1712b767203efc",
    "benchmarks/posmg/prism-models/attacker-defender.prism": "63d06084e273e237",
    "benchmarks/posmg/prism-models/attacker-defender2.prism": "01df81c90a7a2c85",
    "benchmarks/posmg/prism-models/attacker-defender3.prism": "bdaca158fa61af4d",
    "benchmarks/posmg/prism-models/attacker-one-defender-rounds.prism": "7f5ac6d63c217465",
    "benchmarks/posmg/prism-models/attacker-one-defender.prism": "dcc535fe33123461",
    "benchmarks/posmg/prism-models/attacker-one-defender2.prism": "0b20e0697050aeb3",
    "benchmarks/posmg/prism-models/dice-and-coin.prism": "d4cd4a1e1e1bbe2a",
    "benchmarks/posmg/prism-models/dice-and-coin2.prism": "ddb377c6a442358f",
    "benchmarks/posmg/prism-models/dice-and-coin_rew.prism": "3c97a72a6ab10347",
    "benchmarks/posmg/prism-models/dodge6-lines-position.prism": "ed2bfe5dc469ff91",
    "benchmarks/posmg/prism-models/dodge6-lines.prism": "8919842fc4dcac55",
    "benchmarks/posmg/prism-models/dodge8.prism": "8934ff09e536e047",
    "benchmarks/posmg/prism-models/grid-walls.prism": "d85030329b945661",
    "benchmarks/posmg/prism-models/multi-dodge4.prism": "b35a76bbed860209",
    "benchmarks/posmg/prism-models/pmax.props": "76be03791e9cae88",
    "benchmarks/posmg/prism-models/pmin.props": "67727b36ffaa84a7",
    "benchmarks/posmg/prism-models/pursuit-evasion.prism": "9f375d25dafc5e29",
    "benchmarks/posmg/prism-models/ships.prism": "5eeff94ba3f87cdb",
    "benchmarks/posmg/prism-models/testing-rewards.prism": "b0c27c060b3076ad",
    "benchmarks/posmg/test-game/sketch.props": "8d504aeead45e69c",
    "benchmarks/posmg/test-game2/sketch.props": "66c7a76434951e86",
    "benchmarks/posmg/testing-rewards/model.prism": "57a74f81f3b1db60",
    "benchmarks/posmg/testing-rewards/sketch.props": "118d612ede0d74ee",
    "benchmarks/scale/pursuit.smg": "13dda8b7c5d0c646",
    "benchmarks/scale/two_robots.nm": "d38003970bb2adf5",
    "benchmarks/smg/coins/coins.prism": "af38ff296898a38f",
    "benchmarks/smg/coins/coins.prism.props": "45182536708749ba",
    "benchmarks/smg/dice/dice.prism": "bc8589d9a5c5d94e",
    "benchmarks/smg/dice/dice.props": "ed39df2caf49ca0b",
    "benchmarks/smg/game/game.prism": "6f74f21ea8e2ecec",
    "benchmarks/smg/game/game.prism.props": "2fb259063518bdc3",
    "benchmarks/smg/game/game.prism.rewards.props": "c3f10fd4db956197",
    "benchmarks/smg/investor/investor.prism": "77f0a65160867e47",
    "benchmarks/smg/investor/investor.prism.props": "0421913ec455ac42",
    "benchmarks/smg/investor/investor.storm.props": "b3aaa1ee659882af",
    "benchmarks/smg/mdsm2304/mdsm2304.prism": "6f99d904bf619651",
    "benchmarks/smg/mdsm2304/mdsm2304.props": "35407ceb7748f9b8",
    "benchmarks/smg/mdsm2304/mdsm2304.storm.props": "2c029a54f8b54512",
    "benchmarks/smg/robot/robot.prism": "080973977e2fd534",
    "benchmarks/smg/robot/robot.prism.cosafe.props": "31090fe022671969",
    "benchmarks/smg/robot/robot.prism.rewards.cosafe.props": "36b0ef66cffd5f40",
    "benchmarks/smg/smg_example/smg_example.prism": "a29728abe69c5a33",
    "benchmarks/smg/smg_example/smg_example.prism.cosafe.props": "48ee9f2792c1de3b",
    "benchmarks/smg/smg_example/smg_example.prism.props": "5b8dfba43edb0c91",
    "models/rover.posg": "0d7910599d19776c",
    "models/rover.props": "f8d27d02260b693e",  # RESULT lines added (issue #10's posgmc test)
    "models/rover.smg": "a8f01c881700421e",
}


@pytest.mark.parametrize(("name", "path"), FILES, ids=[n for n, _ in FILES])
def test_tree_and_spans_as_recorded(name: str, path: Path) -> None:
    if name not in GOLDEN:
        pytest.skip(f"{name} is newer than the recorded digests")
    assert digest(_parse(name, path)) == GOLDEN[name]


def test_recorded_files_are_present(benchmarks: Path) -> None:
    # so that a moved benchmark directory cannot make the test above check nothing
    names = {name for name, _ in FILES}
    assert len(GOLDEN) >= 100
    assert set(GOLDEN) <= names


# --- what a span must be --------------------------------------------------------------------------


def _nodes(value: Any) -> Iterator[Any]:
    """Every dataclass node under ``value`` (itself included), depth first."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        if isinstance(value, SourceSpan):
            return
        yield value
        for f in dataclasses.fields(value):
            yield from _nodes(getattr(value, f.name))
    elif isinstance(value, (tuple, list)):
        for item in value:
            yield from _nodes(item)


def _children(node: Any) -> Iterator[Any]:
    for f in dataclasses.fields(node):
        yield from _nodes(getattr(node, f.name))


class _Text:
    def __init__(self, text: str) -> None:
        self.text = text
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def offset(self, line: int, column: int) -> int:
        return self.starts[line - 1] + column - 1

    def start(self, span: SourceSpan) -> int:
        return self.offset(span.line, span.column)

    def end(self, span: SourceSpan) -> int:
        assert span.end_line is not None and span.end_column is not None
        return self.offset(span.end_line, span.end_column)

    def at(self, span: SourceSpan) -> str:
        return self.text[self.start(span) : self.end(span)]


def _filler(text: str) -> str:
    """``text`` without blanks and comments."""
    return re.sub(r"//[^\n]*|\s+", "", text)


@pytest.mark.parametrize(("name", "path"), FILES, ids=[n for n, _ in FILES])
def test_spans_cover_what_they_should(name: str, path: Path) -> None:
    text = _Text(path.read_text(encoding="utf-8"))
    tree = _parse(name, path)
    checked = 0
    for node in _nodes(tree):
        span = getattr(node, "span", None)
        if not isinstance(span, SourceSpan):
            continue  # PropertiesFile
        assert span.file == name
        assert span.end_line is not None and span.end_column is not None
        assert text.start(span) < text.end(span), node
        for child in _children(node):
            child_span = getattr(child, "span", None)
            if isinstance(child_span, SourceSpan) and not isinstance(child, ExpectedResult):
                # a RESULT comment sits above its property; everything else inside its parent
                assert text.start(span) <= text.start(child_span), (node, child)
                assert text.end(child_span) <= text.end(span), (node, child)
        word = text.at(span)
        if isinstance(node, Ident):
            assert word == node.name
        elif isinstance(node, LabelRef):
            assert word == f'"{node.name}"'
        elif isinstance(node, IntLit):
            assert int(word) == node.value
        elif isinstance(node, DoubleLit):
            assert Fraction(word) == node.value
        elif isinstance(node, BoolLit):
            assert word == ("true" if node.value else "false")
        elif isinstance(node, Binary):
            # (a) + b starts at '(' and a + (b) ends at ')'; the operator is all that is between
            before = text.text[text.start(span) : text.start(node.left.span)]
            between = text.text[text.end(node.left.span) : text.start(node.right.span)]
            after = text.text[text.end(node.right.span) : text.end(span)]
            assert set(_filler(before)) <= {"("}, (node, before)
            assert set(_filler(after)) <= {")"}, (node, after)
            assert _filler(between).strip("()") == node.op.value, (node, between)
        checked += 1
    assert checked > 0


# --- the own lexing loop against lark's lexer -----------------------------------------------------


def test_own_lexing_loop_agrees_with_larks_lexer(
    benchmarks: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fast = {name: dump(_parse(name, path)) for name, path in FILES}
    scanners = lalr_module._automaton().scanners
    saved = list(scanners)
    # a scanner that never matches hands all lexing over to lark's contextual lexer
    monkeypatch.setattr(lalr_module, "_scanner", lambda state: lalr_module._NO_SCANNER)
    scanners[:] = [None] * len(scanners)
    try:
        for name, path in FILES:
            assert dump(_parse(name, path)) == fast[name], name
    finally:
        scanners[:] = saved


def test_lark_lexer_takes_over_where_nothing_matches() -> None:
    # '@' matches no terminal: lark's lexer continues from there and reports it, as it did when
    # it lexed everything (line 3, column 8 of this text, counted by hand)
    text = "dtmc\nmodule m\n  x : [@..1] init 0;\nendmodule\n"
    with pytest.raises(ParseError) as info:
        parse_model(text, file="m.prism")
    assert info.value.message == "unexpected character '@'"
    assert str(info.value.span) == "m.prism:3:8"


# --- errors found while converting ----------------------------------------------------------------


def test_a_syntax_error_further_on_comes_before_a_conversion_error() -> None:
    # The label name is not an identifier (a conversion error, line 1), and line 4 misses the ';'
    # of its command. Converting the finished tree, the old parser never got to the label: it
    # reported the syntax error, with this message and position (recorded from it).
    text = (
        'label "a b" = true;\n'
        "module m\n"
        "  x : [0..1] init 0;\n"
        "  [] x=0 -> (x'=1)\n"
        "endmodule\n"
    )
    with pytest.raises(ParseError) as info:
        parse_model(text, file="m.prism")
    assert info.value.message == "expected '&' or ';' but found 'endmodule'"
    assert str(info.value.span) == "m.prism:5:1"


def test_the_first_conversion_error_is_reported() -> None:
    text = 'label "a b" = true;\nlabel "c d" = false;\n'
    with pytest.raises(ParseError) as info:
        parse_model(text, file="m.prism")
    assert info.value.message == (
        "label names must be identifiers (letters, digits, '_'), not \"a b\""
    )
    assert str(info.value.span) == "m.prism:1:7"


def test_conversion_errors_in_properties_wait_for_the_parse() -> None:
    # pow takes 2 arguments (property 1), and property 2 misses its ']': the syntax error is
    # reported; once it is fixed, the arity. Messages and positions recorded from the old parser.
    with pytest.raises(ParseError) as info:
        parse_properties('Pmax=? [ F pow(2)>1 ];\nPmin=? [ F "goal" ;\n', file="p.props")
    assert info.value.message == "expected ']' but found ';'"
    assert str(info.value.span) == "p.props:2:19"
    with pytest.raises(ParseError) as info:
        parse_properties('Pmax=? [ F pow(2)>1 ];\nPmin=? [ F "goal" ];\n', file="p.props")
    assert info.value.message == "pow takes 2 arguments, not 1"
    assert str(info.value.span) == "p.props:1:12"


# --- the collector is paused only while parsing ---------------------------------------------------


@pytest.mark.parametrize("enabled", [True, False])
@pytest.mark.parametrize("text", ["dtmc module m x : bool; endmodule", "dtmc module m x : bool;"])
def test_collector_state_is_restored(enabled: bool, text: str) -> None:
    was = gc.isenabled()
    try:
        gc.enable() if enabled else gc.disable()
        try:
            parse_model(text)
        except PosgmcError:
            pass
        assert gc.isenabled() is enabled
    finally:
        gc.enable() if was else gc.disable()


# --- the grammar analysis cache -------------------------------------------------------------------


def test_cache_lives_in_a_private_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    where = lalr_module._cache_file("grammar text")
    assert isinstance(where, str)
    assert Path(where).parent == tmp_path / "posgmc"
    if os.name == "posix":
        assert (tmp_path / "posgmc").stat().st_mode & 0o777 == 0o700
    # another grammar (or lark or Python version) gets another file
    assert lalr_module._cache_file("other grammar") != where


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_no_cache_in_a_directory_others_may_write(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "posgmc").mkdir()
    (tmp_path / "posgmc").chmod(0o777)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert lalr_module._cache_file("grammar text") is False


def test_no_cache_where_no_directory_can_be_made(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    assert lalr_module._cache_file("grammar text") is False


def _record() -> None:  # pragma: no cover - run by hand, see the module docstring
    for name, path in FILES:
        print(f'    "{name}": "{digest(_parse(name, path))}",')


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_record())
