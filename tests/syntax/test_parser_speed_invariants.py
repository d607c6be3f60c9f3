"""The fast parse loop (actions run during the LALR parse, own lexing loop, collector paused, grammar
analysis cached) builds exactly the trees, spans and errors of the tree-building parser it replaced.

Evidence, strongest first:

* ``GOLDEN``: for every PRISM-language model and property file among the shared benchmarks and in
  ``models/``, a digest of the whole syntax tree *with every span* (spans take no part in ``==``).
  The digests were recorded with the previous parser (lark parse tree with
  ``propagate_positions=True``, then a ``Transformer``; commit e541142) and have not been
  re-recorded since. A deliberate change of ``ast.py`` changes them; re-record with
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
from fractions import Fraction
from pathlib import Path
from typing import Any, Iterator

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
    """Every field of every node, spans included, in a canonical text form."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = ", ".join(
            f"{f.name}={dump(getattr(value, f.name))}"
            for f in dataclasses.fields(value)
            if not ((type(value).__name__, f.name) in ADDED_LATER and getattr(value, f.name) == f.default)
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
    "benchmarks/pomdp/4x3-95/sketch.props": "f0e519a4cbcb5282",
    "benchmarks/pomdp/crypt-4/sketch.props": "93a66f574f5ca3fe",
    "benchmarks/pomdp/crypt-4/sketch.templ": "00648bde471d8898",
    "benchmarks/pomdp/drone-4-1/sketch.props": "b9a0c726df65949c",
    "benchmarks/pomdp/drone-4-1/sketch.templ": "e02c9f87304a1f80",
    "benchmarks/pomdp/grid-avoid-4-0.1/sketch.props": "a434f8e5484f512b",
    "benchmarks/pomdp/grid-avoid-4-0.1/sketch.templ": "2a116fb6883cb8fb",
    "benchmarks/pomdp/grid-large-10-5/sketch.props": "793b3cee1a3754d1",
    "benchmarks/pomdp/grid-large-10-5/sketch.templ": "40783dffb75a1ff5",
    "benchmarks/pomdp/maze-alex/sketch.props": "47e3970026523a6e",
    "benchmarks/pomdp/maze-alex/sketch.templ": "0e14f565bed2f957",
    "benchmarks/pomdp/network-2-8-20/sketch.props": "eb44255348809dc5",
    "benchmarks/pomdp/network-2-8-20/sketch.templ": "72f5af0fcdba0b0c",
    "benchmarks/pomdp/nrp-8/sketch.props": "03f41f0c18e85253",
    "benchmarks/pomdp/nrp-8/sketch.templ": "282f57936558eb80",
    "benchmarks/pomdp/obstacle/sketch.props": "55f8febe67b2cfff",
    "benchmarks/pomdp/obstacle/sketch.templ": "6f4114a7224ad9bd",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.named-rewards.prism": "9a4b69d9fdba391d",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.named-rewards.props": "90740e1921870ac5",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.prism": "fbdfb41b6d1f5230",
    "benchmarks/pomdp/prism-3x3grid/3x3grid.prism.props": "31aaeb0737eb75da",
    "benchmarks/pomdp/prism-maze/maze.named-rewards.prism": "cc87dee9e7b5b099",
    "benchmarks/pomdp/prism-maze/maze.named-rewards.props": "b5482c19ee1655f1",
    "benchmarks/pomdp/prism-maze/maze.prism": "fcd660b55b06f09f",
    "benchmarks/pomdp/prism-maze/maze.prism.props": "f847e12c857870ab",
    "benchmarks/pomdp/prism-maze/maze.storm.props": "ba8634447cadcdc8",
    "benchmarks/pomdp/query-s2/sketch.props": "bb091420c28dfa24",
    "benchmarks/pomdp/refuel-06/sketch.props": "5fcbeff3044210fe",
    "benchmarks/pomdp/refuel-06/sketch.templ": "fcdcf14e71c128f1",
    "benchmarks/pomdp/rocks-12/sketch.props": "9cbfdb2847bc607b",
    "benchmarks/pomdp/rocks-12/sketch.templ": "e76fb3adfd2da426",
    "benchmarks/posmg/attacker-defender/model.prism": "b64c3eeeb9731779",
    "benchmarks/posmg/attacker-defender/sketch.props": "704eb8404460fd14",
    "benchmarks/posmg/attacker-one-defender/model.prism": "f7cbe7d84f11dd50",
    "benchmarks/posmg/attacker-one-defender/sketch.props": "71cbdd0a23f63f4b",
    "benchmarks/posmg/dice-and-coin/model.prism": "339aaf7b70d94d2a",
    "benchmarks/posmg/dice-and-coin/sketch.props": "5faf9d61d59c1415",
    "benchmarks/posmg/dice-and-coin2/model.prism": "654bd68a4b98a691",
    "benchmarks/posmg/dice-and-coin2/sketch.props": "c446b96b5446f010",
    "benchmarks/posmg/dodge-6-lines/model.prism": "545d2290b1f3dcb0",
    "benchmarks/posmg/dodge-6-lines/sketch.props": "3bc3151aa24dbfad",
    "benchmarks/posmg/dodge-6-lines-position/model.prism": "1dc7ac029ca11db7",
    "benchmarks/posmg/dodge-6-lines-position/sketch.props": "1bc4c3f6fc7002ab",
    "benchmarks/posmg/dodge-8/model.prism": "0477844eb034b7e5",
    "benchmarks/posmg/dodge-8/sketch.props": "44d1dfdc81ddc1e1",
    "benchmarks/posmg/grid-walls/model.prism": "caa308984b3c3205",
    "benchmarks/posmg/grid-walls/sketch.props": "bcf65dacfd4e60a5",
    "benchmarks/posmg/mec-test/sketch.props": "64b849264c5d094a",
    "benchmarks/posmg/multi-dodge4/model.prism": "376357a6d1e76adc",
    "benchmarks/posmg/multi-dodge4/sketch.props": "0b828f9c36a76913",
    "benchmarks/posmg/pomdp-variants/dice-and-coin/sketch.props": "2dc27d19fba8b384",
    "benchmarks/posmg/pomdp-variants/dice-and-coin/sketch.templ": "7338af7c6aad68f6",
    "benchmarks/posmg/pomdp-variants/dice-and-coin2/sketch.props": "c206cbb8ebf1ca59",
    "benchmarks/posmg/pomdp-variants/dice-and-coin2/sketch.templ": "76706b76dced161c",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.opt.props": "f5b542b677dd3459",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.props": "9682dcddae1297ec",
    "benchmarks/posmg/pomdp-variants/dodge-8/sketch.templ": "c64f078813925d97",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.opt.props": "3416eda15d492d6d",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.props": "97e6dd228f59a81e",
    "benchmarks/posmg/pomdp-variants/multi-dodge4/sketch.templ": "55ff33798bc5c594",
    "benchmarks/posmg/prism-models/attacker-defender-pmin.prism": "a67c99f473f11ab5",
    "benchmarks/posmg/prism-models/attacker-defender-rounds.prism": "62a1eb2d747e885e",
    "benchmarks/posmg/prism-models/attacker-defender-rounds2.prism": "b3dd1e98b94f969e",
    "benchmarks/posmg/prism-models/attacker-defender-rounds3.prism": "b4734a8e49e0aaaa",
    "benchmarks/posmg/prism-models/attacker-defender.prism": "af51c7d9a15a1087",
    "benchmarks/posmg/prism-models/attacker-defender2.prism": "2c3e02a43485638b",
    "benchmarks/posmg/prism-models/attacker-defender3.prism": "7787e2ee9e63f35a",
    "benchmarks/posmg/prism-models/attacker-one-defender-rounds.prism": "e012508f5a17e0b2",
    "benchmarks/posmg/prism-models/attacker-one-defender.prism": "43fdfba702e47cb8",
    "benchmarks/posmg/prism-models/attacker-one-defender2.prism": "93a9c72c25768962",
    "benchmarks/posmg/prism-models/dice-and-coin.prism": "eeff37bb61b4a1eb",
    "benchmarks/posmg/prism-models/dice-and-coin2.prism": "411454cf984798be",
    "benchmarks/posmg/prism-models/dice-and-coin_rew.prism": "ecea93445a7404d2",
    "benchmarks/posmg/prism-models/dodge6-lines-position.prism": "d78a389e06a9f786",
    "benchmarks/posmg/prism-models/dodge6-lines.prism": "cea90038ca7e4e28",
    "benchmarks/posmg/prism-models/dodge8.prism": "6f5e04b42b08912e",
    "benchmarks/posmg/prism-models/grid-walls.prism": "94d69105c8a29950",
    "benchmarks/posmg/prism-models/multi-dodge4.prism": "26ec5c9c79c2d7c4",
    "benchmarks/posmg/prism-models/pmax.props": "d2f25972302a16b2",
    "benchmarks/posmg/prism-models/pmin.props": "f3b60a49e9d049f1",
    "benchmarks/posmg/prism-models/pursuit-evasion.prism": "b4c86df9b9dc9fdf",
    "benchmarks/posmg/prism-models/ships.prism": "43f11b51cdde76fd",
    "benchmarks/posmg/prism-models/testing-rewards.prism": "21915fcb1731f29f",
    "benchmarks/posmg/test-game/sketch.props": "6a1c8e4daeb88eb4",
    "benchmarks/posmg/test-game2/sketch.props": "44e30cb1bcf5a063",
    "benchmarks/posmg/testing-rewards/model.prism": "43ffe22748fb79db",
    "benchmarks/posmg/testing-rewards/sketch.props": "29f3c5c402267f11",
    "benchmarks/scale/pursuit.smg": "f114c79b21ae7b81",
    "benchmarks/scale/two_robots.nm": "1d8b96653106c99a",
    "benchmarks/smg/coins/coins.prism": "2f029704393bd254",
    "benchmarks/smg/coins/coins.prism.props": "1b0965e9313adc48",
    "benchmarks/smg/dice/dice.prism": "5706489981fa6a90",
    "benchmarks/smg/dice/dice.props": "14ad2884468d92b4",
    "benchmarks/smg/game/game.prism": "1452f5d2020b5afa",
    "benchmarks/smg/game/game.prism.props": "41a7881fc7bd6b21",
    "benchmarks/smg/game/game.prism.rewards.props": "3f54ff4119ef0b35",
    "benchmarks/smg/investor/investor.prism": "f5ea34fea3ca8f38",
    "benchmarks/smg/investor/investor.prism.props": "a2bfd35d0d777eee",
    "benchmarks/smg/investor/investor.storm.props": "df2d8fd0560708e2",
    "benchmarks/smg/mdsm2304/mdsm2304.prism": "50bf3d6f4e3c42ed",
    "benchmarks/smg/mdsm2304/mdsm2304.props": "4f3e0039cd084bd6",
    "benchmarks/smg/mdsm2304/mdsm2304.storm.props": "93a7deb80b61607d",
    "benchmarks/smg/robot/robot.prism": "65e793740e5bfff1",
    "benchmarks/smg/robot/robot.prism.cosafe.props": "c21180a04e65510f",
    "benchmarks/smg/robot/robot.prism.rewards.cosafe.props": "aeeaf82b03545444",
    "benchmarks/smg/smg_example/smg_example.prism": "d09b011227dd43ca",
    "benchmarks/smg/smg_example/smg_example.prism.cosafe.props": "a6ff40218353d786",
    "benchmarks/smg/smg_example/smg_example.prism.props": "cd6d3133bb4a3dfb",
    "models/rover.posg": "080480d4a712cabd",
    "models/rover.props": "c8b7f85fd57e54d5",  # RESULT lines added (issue #10's posgmc test)
    "models/rover.smg": "cf01a48708b51dd5",
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
        for child in _nodes(getattr(node, f.name)):
            yield child


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
