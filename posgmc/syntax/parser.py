"""Parse PRISM model files, property files, single properties and expressions into ``ast.py`` trees.

The grammar is ``grammar/prism.lark``; lark builds its LALR(1) automaton and contextual lexer once
per process. The parse loop here drives that automaton itself and runs the semantic actions of
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
import functools
import gc
import hashlib
import os
import re
import sys
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Iterator

import lark
from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import LexerThread, TerminalDef
from lark.parsers.lalr_analysis import ParseTableBase, Shift
from lark.parsers.lalr_parser_state import ParseConf, ParserState

from posgmc.errors import InputError, ParseError, PosgmcError, SourceSpan, SourceText
from posgmc.syntax import diagnostics
from posgmc.syntax.ast import (
    ConstantDecl,
    ExpectedResult,
    Expr,
    FormulaDecl,
    LabelDecl,
    ModelFile,
    PropertiesFile,
    Property,
)
from posgmc.syntax.transformer import (
    AstBuilder,
    PropertyItem,
    RuleAction,
    check_temporal_placement,
    rule_actions,
)

__all__ = [
    "parse_model",
    "parse_properties",
    "parse_property",
    "parse_expression",
    "load_model",
    "load_properties",
]

_GRAMMAR_FILE = "prism.lark"
_START_SYMBOLS = (
    "model_file",
    "properties_file",
    "single_property",
    "single_expression",
    "single_model_expression",
)

# PRISM's own pattern (parser/ast/Property.java): the expected value is the first word after ':'.
_RESULT = re.compile(r"RESULT[ \t]*(\(([^)]+)\))?[ \t]*:[ \t]*([^ \t\n\r]+)")
_COMMENT = re.compile(r"//[^\n]*")


# --- grammar and parser ---------------------------------------------------------------------------


def grammar_text() -> str:
    """The text of ``prism.lark``: from the installed package (``posgmc/grammar``) or the source
    tree.

    Raises:
        FileNotFoundError: if neither location holds the grammar (a broken installation).
    """
    try:
        packaged = resources.files("posgmc") / "grammar" / _GRAMMAR_FILE
        if packaged.is_file():
            return packaged.read_text(encoding="utf-8")
    except (ModuleNotFoundError, FileNotFoundError, NotADirectoryError):
        pass
    source_tree = Path(__file__).resolve().parents[2] / "grammar" / _GRAMMAR_FILE
    return source_tree.read_text(encoding="utf-8")


class _WholeWords:
    """A no-op post-lexer whose only job is ``always_accept``: the contextual lexer then matches
    names (and primed names) in every parser state, so ``dtmcc`` is one unexpected word rather
    than the keyword ``dtmc`` followed by ``c``, and a misplaced ``x'`` is reported as such."""

    always_accept = ("IDENT", "IDENTPRIME")

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        return stream


@functools.lru_cache(maxsize=1)
def lark_parser() -> Lark:
    """The LALR(1) parser for all start symbols, built on first use and kept for the process.

    lark's analysis of the grammar (most of the start-up time of a command) is kept between
    processes in the user's cache directory (see :func:`_cache_file`); lark checks that the
    cached analysis belongs to this grammar, these options and this lark version, and
    redoes it otherwise.
    """
    text = grammar_text()
    return Lark(
        text,
        parser="lalr",
        lexer="contextual",
        postlex=_WholeWords(),
        start=list(_START_SYMBOLS),
        maybe_placeholders=False,
        cache=_cache_file(text),
    )


def _cache_file(grammar: str) -> str | bool:
    """The file for lark's ``cache`` option: ``$XDG_CACHE_HOME/posgmc/`` (``~/.cache/posgmc/``),
    or ``False`` (no cache) where that directory cannot be made private to this user.

    lark's own ``cache=True`` would use a predictable name in the shared temporary directory,
    where another user could leave a file that lark unpickles (lark-parser/lark#1628); the
    cache is only as trustworthy as the directory it is in.
    """
    try:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        directory = Path(base) / "posgmc"
        directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        if os.name == "posix":
            status = directory.stat()
            if status.st_uid != os.getuid() or status.st_mode & 0o022:
                return False
    except (OSError, RuntimeError):  # no home directory, read-only file system, ...
        return False
    key = hashlib.sha256(f"{grammar}{lark.__version__}{sys.version_info[:2]}".encode()).hexdigest()
    return str(directory / f"prism-grammar-{key[:16]}.lark")


@functools.lru_cache(maxsize=1)
def _terminals() -> dict[str, TerminalDef]:
    return {t.name: t for t in lark_parser().terminals}


@dataclass(frozen=True)
class _Scanner:
    """One state's terminals, as lark's contextual lexer matches them: one regular expression
    with a named group per terminal, tried in lark's priority order."""

    match: Callable[[str, int], re.Match[str] | None]
    callbacks: dict[str, Callable[[Token], Token]]  # retype a keyword lexed as a name
    ignore: frozenset[str]  # terminals skipped (blanks, comments)
    newlines: frozenset[str]  # terminals that may contain a newline


@dataclass(frozen=True)
class _Automaton:
    """lark's LALR(1) automaton for :func:`_parse`, re-encoded so that one step is one lookup.

    States are lark's (``0 .. num_states-1``); rules are numbered as in ``Lark.rules``.
    """

    # actions[state][terminal]: the state to shift to (>= 0), or ~rule to reduce by (< 0)
    actions: tuple[dict[str, int], ...]
    # goto[state][nonterminal]: the state after reducing to that nonterminal in ``state``
    goto: tuple[dict[str, int], ...]
    # rules[rule]: (number of symbols, the nonterminal it reduces to, its semantic action)
    rules: tuple[tuple[int, str, RuleAction | None], ...]
    # lark's own table, for the ParserState that error messages inspect
    parse_table: ParseTableBase[int]
    # scanners[state]: the contextual lexer's scanner for that state; None until first needed
    scanners: list[_Scanner | None]
    # chains[(below, top, terminal)]: the top state after all the value-preserving one-symbol
    # reductions (mexpr -> ite -> implies -> ... -> munary -> matom) that ``terminal`` triggers
    # in ``top`` with ``below`` under it. They only replace the top state, looking at the state
    # below, so the whole chain is one lookup; filled in as parses meet the combinations.
    chains: dict[tuple[int, int, str], int] = field(default_factory=dict, compare=False)


@functools.lru_cache(maxsize=1)
def _automaton() -> _Automaton:
    parser = lark_parser()
    table: ParseTableBase[int] = parser.parser.parser.parser.parse_table
    numbers = {rule: i for i, rule in enumerate(parser.rules)}
    num_states = len(table.states)
    if set(table.states) != set(range(num_states)):  # pragma: no cover - lark numbers its states
        raise RuntimeError("unexpected LALR state numbering")
    actions: list[dict[str, int]] = [{} for _ in range(num_states)]
    goto: list[dict[str, int]] = [{} for _ in range(num_states)]
    for state, row in table.states.items():
        for symbol, (action, arg) in row.items():
            # plain str keys: lark's rule names are Tokens, whose == is slower than str's
            if not symbol.isupper():  # a nonterminal: lark stores its goto as a shift
                goto[state][str(symbol)] = arg
            elif action is Shift:
                actions[state][str(symbol)] = arg
            else:
                actions[state][str(symbol)] = ~numbers[arg]
    rules = tuple(
        (len(rule.expansion), str(rule.origin.name), action)
        for rule, action in zip(parser.rules, rule_actions(parser.rules))
    )
    return _Automaton(tuple(actions), tuple(goto), rules, table, [None] * num_states)


def _scanner(state: int) -> _Scanner:
    """The contextual lexer's scanner in parser ``state``: lark's own compiled expression for
    that state's terminals (compiled on first use, as lark does), or, if this lark version's
    lexer is laid out differently, one that never matches, which hands lexing over to lark."""
    try:
        basic = lark_parser().parser.lexer.lexer.lexers[state]
        expressions = basic.scanner._mres  # building the scanner also sets .callback
        if len(expressions) == 1:
            return _Scanner(
                expressions[0].match,
                dict(basic.callback),
                frozenset(basic.ignore_types),
                frozenset(basic.newline_types),
            )
    except (AttributeError, KeyError, TypeError):  # pragma: no cover - another lark version
        pass
    return _NO_SCANNER  # pragma: no cover - lark builds one expression unless > 100 terminals


_NO_SCANNER = _Scanner(lambda text, pos: None, {}, frozenset(), frozenset())


def _tokens(text: str, state: ParserState) -> Iterator[Token]:
    """The tokens of ``text`` as lark's contextual lexer makes them for the parser in ``state``,
    then lark's ``$END`` token.

    A faster loop than lark's own over the same scanners (one per parser state, chosen when
    the next token is asked for); where no terminal matches, or when this lark version's lexer
    is laid out differently, lark's lexer takes over from that point, so that a lexical error
    is raised by lark itself, exactly as before.
    """
    lexer: LexerThread = state.lexer
    scanners = _automaton().scanners
    state_stack = state.state_stack
    token: Token | None = None
    pos, line, line_start, size = 0, 1, 0, len(text)
    while pos < size:
        scanner = scanners[state_stack[-1]]
        if scanner is None:
            scanner = scanners[state_stack[-1]] = _scanner(state_stack[-1])
        match = scanner.match(text, pos)
        if match is None:
            break
        value = match.group()
        kind: str = match.lastgroup  # type: ignore[assignment]
        start, start_line, start_column = pos, line, pos - line_start + 1
        if kind in scanner.newlines:
            newlines = value.count("\n")
            if newlines:
                line += newlines
                line_start = pos + value.rindex("\n") + 1
        pos += len(value)
        if kind in scanner.ignore:
            continue
        token = Token(kind, value, start, start_line, start_column, line, pos - line_start + 1, pos)
        if kind in scanner.callbacks:
            token = scanner.callbacks[kind](token)
        yield token
    if pos < size:
        # lark's lexer continues from here (and raises its error where nothing matches)
        counter = lexer.state.line_ctr
        counter.char_pos, counter.line, counter.line_start_pos = pos, line, line_start
        counter.column = pos - line_start + 1
        lexer.state.last_token = token
        for token in lexer.lex(state):
            yield token
    yield Token.new_borrow_pos("$END", "", token) if token else Token("$END", "", 0, 1, 1)


def _parse(text: str, start: str, builder: AstBuilder) -> Any:
    """Run the LALR(1) automaton over ``text`` from ``start``, building the result bottom-up.

    The stacks are those of a lark ``ParserState`` (so the contextual lexer sees the parser's
    state, and error messages can inspect the stacks exactly as lark leaves them); next to
    them, the first and the last token of each stack entry's text give the span of each
    reduction.

    Raises:
        UnexpectedToken, UnexpectedCharacters: a syntax error, as lark raises it.
    """
    automaton = _automaton()
    actions, goto, rules = automaton.actions, automaton.goto, automaton.rules
    chains = automaton.chains
    conf = ParseConf(automaton.parse_table, {}, start)
    end_state = conf.end_state
    state = ParserState(conf, LexerThread.from_text(lark_parser().parser.lexer, text))
    state_stack: list[int] = state.state_stack
    value_stack: list[Any] = state.value_stack
    firsts: list[Token | None] = []  # the first token of each value_stack entry's text
    lasts: list[Token | None] = []  # its last token
    for token in _tokens(text, state):
        kind = token.type
        while True:
            step = actions[state_stack[-1]].get(kind)
            if step is None:
                expected = {s for s in conf.states[state_stack[-1]] if s.isupper()}
                raise UnexpectedToken(token, expected, state=state)
            if step >= 0:
                state_stack.append(step)
                value_stack.append(token)
                firsts.append(token)
                lasts.append(token)
                break
            size, origin, action = rules[~step]
            if action is None:  # one-symbol rules passing their value through: only the state moves
                key = (state_stack[-2], state_stack[-1], kind)
                top = chains.get(key)
                if top is None:
                    top = chains[key] = _chain(automaton, *key)
                state_stack[-1] = top
                continue
            if size == 1:
                value_stack[-1] = action(builder, value_stack[-1:], firsts[-1], lasts[-1])
            elif size:
                first, last = firsts[-size], lasts[-1]
                values = value_stack[-size:]
                # pop all but one entry, which the result then replaces
                del value_stack[1 - size :], firsts[1 - size :], lasts[1 - size :]
                del state_stack[1 - size :]
                value_stack[-1] = action(builder, values, first, last)
                lasts[-1] = last
            else:
                value_stack.append(action(builder, [], None, None))
                firsts.append(None)
                lasts.append(None)
                state_stack.append(state_stack[-1])
            state_stack[-1] = goto[state_stack[-2]][origin]
            if state_stack[-1] == end_state:  # only after the start symbol, on $END
                return value_stack[-1]
    raise AssertionError("unreachable: $END ends every parse")  # pragma: no cover


def _chain(automaton: _Automaton, below: int, top: int, kind: str) -> int:
    """The top state after the pass-through reductions that ``kind`` triggers from ``top``."""
    while True:
        step = automaton.actions[top].get(kind)
        if step is None or step >= 0:
            return top
        _, origin, action = automaton.rules[~step]
        if action is not None:
            return top
        top = automaton.goto[below][origin]


def _run(text: str, start: str, file: str | None) -> Any:
    """Parse ``text`` from ``start`` and convert it; every failure becomes a spanned PosgmcError."""
    source = SourceText(text, file)
    builder = AstBuilder(file=file)
    # The parse allocates only acyclic objects (tokens, frozen nodes, lists), so the cycle
    # collector has nothing to free, yet it traverses the growing tree again and again: with it,
    # 20,000 commands take 4.1 s instead of 2.1 s. It is paused for the parse and restored after;
    # its first passes over the finished tree then come later (about 1.7 s for that file, so the
    # total is still lower; see docs/performance.md, "Parsing").
    collecting = gc.isenabled()
    try:
        gc.disable()
        result = _parse(text, start, builder)
    except UnexpectedToken as exc:
        raise diagnostics.unexpected_token(exc, text, file, _terminals()).with_source(
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
            for part in (match.group(2) or "").split(","):
                if not part.strip():
                    continue
                pair = part.split("=")
                if len(pair) != 2 or not pair[0].strip() or not pair[1].strip():
                    raise ParseError(
                        f"badly formed RESULT specification: {match.group()!r}",
                        span,
                        hint="write e.g. // RESULT (k=3): 0.5",
                    )
                constants.append((pair[0].strip(), pair[1].strip()))
            results.append(ExpectedResult(match.group(3), tuple(constants), span=span))
    return tuple(results)
