"""Parse PRISM model files, property files, single properties and expressions into ``ast.py`` trees.

The grammar is ``grammar/prism.lark``; :mod:`posgmc.syntax.lalr` runs lark's LALR(1) automaton
and contextual lexer over the text and calls the semantic actions of
:mod:`posgmc.syntax.transformer` at each reduction, so the syntax tree is built during the parse
(no lark parse tree, no second pass); syntax errors are worded by
:mod:`posgmc.syntax.diagnostics`. Every error raised here is a :class:`~posgmc.errors.ParseError`
(or, for a model type this build does not handle, an :class:`~posgmc.errors.UnsupportedError`)
carrying a span and the source text, never a lark exception.

Property files additionally keep PRISM's ``// RESULT: v`` / ``// RESULT (k=3): v`` comments
written above each property as :class:`~posgmc.syntax.ast.ExpectedResult` records.
"""

from __future__ import annotations

import bisect
import gc
import re
from pathlib import Path
from typing import Any

from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from posgmc.errors import InputError, ParseError, PosgmcError, SourceSpan, SourceText
from posgmc.syntax import diagnostics, lalr
from posgmc.syntax.ast import (
    RESULT_NUMBERS,
    ConstantDecl,
    ExpectedResult,
    Expr,
    FormulaDecl,
    LabelDecl,
    ModelFile,
    PropertiesFile,
    Property,
)
from posgmc.syntax.transformer import AstBuilder, PropertyItem, check_temporal_placement

__all__ = [
    "parse_model",
    "parse_properties",
    "parse_property",
    "parse_expression",
    "load_model",
    "load_properties",
]

# PRISM's own pattern (parser/ast/Property.java): the expected value is the first word after ':'.
# the value: an interval "[lo, hi]" (spaces allowed inside) or one token
_RESULT = re.compile(r"RESULT[ \t]*(\(([^)]+)\))?[ \t]*:[ \t]*(\[[^\]\n\r]*\]|[^ \t\n\r]+)")
_COMMENT = re.compile(r"//[^\n]*")


def _run(text: str, start: str, file: str | None) -> Any:
    """Parse ``text`` from ``start`` and convert it; every failure becomes a spanned PosgmcError."""
    source = SourceText(text, file)
    builder = AstBuilder(file=file)
    # The parse allocates only acyclic objects (tokens, frozen nodes, lists), so the cycle
    # collector has nothing to free, yet it traverses the growing tree again and again: with it,
    # a large model's parse takes about twice as long. It is paused for the parse and restored
    # after; its first passes over the finished tree then come later, and the total is still lower
    # (docs/performance.md, "Parsing").
    collecting = gc.isenabled()
    try:
        gc.disable()
        result = lalr.parse(text, start, builder)
    except UnexpectedToken as exc:
        raise diagnostics.unexpected_token(exc, text, file, lalr.terminals()).with_source(
            source
        ) from None
    except UnexpectedCharacters as exc:
        raise diagnostics.unexpected_characters(exc, text, file).with_source(source) from None
    except UnexpectedInput as exc:  # pragma: no cover - LALR raises only the two above
        span = SourceSpan(exc.line or 1, exc.column or 1, file=file)
        raise ParseError("syntax error", span).with_source(source) from None
    finally:
        if collecting:
            gc.enable()
    if builder.error is not None:
        # found while converting; reported only now, as a syntax error anywhere comes first
        raise builder.error.with_source(source)
    return result


def _strip_bom(text: str) -> str:
    return text[1:] if text.startswith("\ufeff") else text


# --- public API ---------------------------------------------------------------------------------


def parse_model(text: str, *, file: str | None = None) -> ModelFile:
    """Parse a PRISM model file (dtmc, mdp, pomdp, smg, posg).

    Args:
        text: the model text.
        file: the file name put into every span (for messages).

    Returns:
        The model's syntax tree; a file without a model-type keyword is an MDP with
        ``model_type_given=False`` (PRISM's default).

    Raises:
        ParseError: the text does not follow the grammar (span at the offending token).
        UnsupportedError: the model type is one posgmc does not handle (ctmc, pta, csg, ...).
    """
    result: ModelFile = _run(_strip_bom(text), "model_file", file)
    return result


def parse_properties(text: str, *, file: str | None = None) -> PropertiesFile:
    """Parse a PRISM / PRISM-games property file.

    Properties may be separated by ``;`` or just by layout (as PRISM allows); ``const``,
    ``formula`` and ``label`` declarations may appear between them. The ``// RESULT`` comments
    above each property are attached to it as :class:`ExpectedResult` records.

    Args:
        text: the property file text.
        file: the file name put into every span.

    Returns:
        The declarations and properties in source order.

    Raises:
        ParseError: a syntax error, a temporal operator outside ``P[..]``/``R[..]``, or a badly
            formed ``RESULT`` comment.
    """
    text = _strip_bom(text)
    items: list[Any] = _run(text, "properties_file", file)
    lines = _LineIndex(text)
    constants: list[ConstantDecl] = []
    formulas: list[FormulaDecl] = []
    labels: list[LabelDecl] = []
    properties: list[Property] = []
    previous_end = 0
    source = SourceText(text, file)
    for item in items:
        if isinstance(item, PropertyItem):
            start = lines.offset(item.span.line, item.span.column)
            end = lines.offset(item.span.end_line, item.span.end_column)
            try:
                check_temporal_placement(item.expr, allowed=False)
                expected = _expected_results(text, previous_end, start, lines, file)
            except PosgmcError as err:
                raise err.with_source(source) from None
            properties.append(
                Property(
                    item.expr,
                    name=item.name,
                    text=text[start:end],
                    expected=expected,
                    span=item.span,
                )
            )
        elif isinstance(item, ConstantDecl):
            constants.append(item)
        elif isinstance(item, FormulaDecl):
            formulas.append(item)
        elif isinstance(item, LabelDecl):
            labels.append(item)
        span = getattr(item, "span", None)
        if isinstance(span, SourceSpan) and span.end_line is not None:
            previous_end = lines.offset(span.end_line, span.end_column)
    return PropertiesFile(
        constants=tuple(constants),
        formulas=tuple(formulas),
        labels=tuple(labels),
        properties=tuple(properties),
        file=file,
    )


def parse_property(text: str, *, file: str | None = None) -> Property:
    """Parse one property, e.g. from the command line (``--prop '<<p1>> Pmax=? [F "goal"]'``).

    Args:
        text: the property, optionally named (``"name": ...``) and followed by ``;``.
        file: what to call the text in messages (e.g. ``"<--prop>"``).

    Returns:
        The property; ``text`` is the property as written, ``expected`` is empty.

    Raises:
        ParseError: a syntax error or a temporal operator outside ``P[..]``/``R[..]``.
    """
    text = _strip_bom(text)
    item: PropertyItem = _run(text, "single_property", file)
    try:
        check_temporal_placement(item.expr, allowed=False)
    except PosgmcError as err:
        raise err.with_source(SourceText(text, file)) from None
    lines = _LineIndex(text)
    start = lines.offset(item.span.line, item.span.column)
    end = lines.offset(item.span.end_line, item.span.end_column)
    return Property(item.expr, name=item.name, text=text[start:end], span=item.span)


def parse_expression(text: str, *, file: str | None = None, model: bool = False) -> Expr:
    """Parse one expression.

    Args:
        text: the expression.
        file: what to call the text in messages.
        model: parse with the model grammar (no labels, queries or temporal operators; the
            property keywords such as ``R`` are then ordinary names). By default the property
            grammar is used, which also accepts path formulas (``F "a"``, ``a U<=3 b``).

    Returns:
        The expression tree.

    Raises:
        ParseError: the text is not one expression.
    """
    start = "single_model_expression" if model else "single_expression"
    result: Expr = _run(_strip_bom(text), start, file)
    return result


def _read(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"cannot read {path}: not UTF-8 text ({exc.reason} at byte {exc.start})"
        ) from None
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None


def load_model(path: str | Path) -> ModelFile:
    """Read (UTF-8) and parse a model file; spans carry ``str(path)``.

    Raises:
        InputError: the file cannot be read.
        ParseError: see :func:`parse_model`.
    """
    return parse_model(_read(path), file=str(path))


def load_properties(path: str | Path) -> PropertiesFile:
    """Read (UTF-8) and parse a property file; spans carry ``str(path)``.

    Raises:
        InputError: the file cannot be read.
        ParseError: see :func:`parse_properties`.
    """
    return parse_properties(_read(path), file=str(path))


# --- RESULT comments ------------------------------------------------------------------------------


class _LineIndex:
    """Converts 1-based (line, column) positions to offsets into the text."""

    def __init__(self, text: str) -> None:
        self._starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self._length = len(text)

    def offset(self, line: int | None, column: int | None) -> int:
        if not line or column is None:
            return 0
        base = self._starts[min(line, len(self._starts)) - 1]
        return min(base + column - 1, self._length)

    def position(self, offset: int) -> tuple[int, int]:
        line = bisect.bisect_right(self._starts, offset)
        return line, offset - self._starts[line - 1] + 1


def _expected_results(
    text: str, begin: int, end: int, lines: _LineIndex, file: str | None
) -> tuple[ExpectedResult, ...]:
    """The ``RESULT`` annotations in the comments between offsets ``begin`` and ``end``."""
    results: list[ExpectedResult] = []
    for comment in _COMMENT.finditer(text, begin, end):
        for match in _RESULT.finditer(comment.group()):
            line, column = lines.position(comment.start() + match.start())
            span = SourceSpan(line, column, line, column + len(match.group()), file)
            constants: list[tuple[str, str]] = []
            number: str | None = None
            for part in (match.group(2) or "").split(","):
                if not part.strip():
                    continue
                if part.strip() in RESULT_NUMBERS and number is None:
                    number = part.strip()
                    continue
                pair = part.split("=")
                if len(pair) != 2 or not pair[0].strip() or not pair[1].strip():
                    raise ParseError(
                        f"badly formed RESULT specification: {match.group()!r}",
                        span,
                        hint="write e.g. // RESULT (k=3): 0.5, or name a number: "
                        "// RESULT (guaranteed): 0.9",
                    )
                constants.append((pair[0].strip(), pair[1].strip()))
            value = match.group(3)
            if value.startswith("["):
                value = "".join(value.split())  # "[0.8, 1]" as PRISM writes it: "[0.8,1]"
            results.append(ExpectedResult(value, tuple(constants), span=span, number=number))
    return tuple(results)
