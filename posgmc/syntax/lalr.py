"""The LALR(1) engine behind :mod:`posgmc.syntax.parser`: lark's automaton and contextual lexer,
driven directly so that the syntax tree is built during the parse.

lark builds the automaton and the per-state scanners from ``grammar/prism.lark`` once per process
(its grammar analysis cached in the user's cache directory, see :func:`_cache_file`).
:func:`parse` runs the automaton over a text and calls the semantic action of each rule
(:func:`posgmc.syntax.transformer.rule_actions`) at each reduction, with the first and last token
of the reduced text for its span; the value-preserving one-symbol reductions of the precedence
chain are taken in one lookup. Syntax errors are lark's own exceptions (``UnexpectedToken``,
``UnexpectedCharacters``), raised with lark's parser state so that
:mod:`posgmc.syntax.diagnostics` can word them; :mod:`posgmc.syntax.parser` turns them into
spanned errors. This module relies on lark's internal tables (hence ``lark<2`` in
``pyproject.toml``); where lark's lexer is laid out differently, lexing falls back to lark's own.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import lark
from lark import Lark, Token
from lark.exceptions import UnexpectedToken
from lark.lexer import LexerThread, TerminalDef
from lark.parsers.lalr_analysis import ParseTableBase, Shift
from lark.parsers.lalr_parser_state import ParseConf, ParserState

from posgmc.syntax.transformer import AstBuilder, RuleAction, rule_actions

__all__ = ["grammar_text", "lark_parser", "parse", "terminals"]

_GRAMMAR_FILE = "prism.lark"
_START_SYMBOLS = (
    "model_file",
    "properties_file",
    "single_property",
    "single_expression",
    "single_model_expression",
)


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
def terminals() -> dict[str, TerminalDef]:
    """lark's terminal definitions by name (for error messages)."""
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
    """lark's LALR(1) automaton for :func:`parse`, re-encoded so that one step is one lookup.

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


def _tokens(text: str, state: ParserState[int]) -> Iterator[Token]:
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
        kind = match.lastgroup
        if kind is None:  # pragma: no cover - every alternative is a named group
            break  # (lark's lexer takes over from here)
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
        lexer_state = lexer.state
        if lexer_state is None:  # pragma: no cover - LexerThread.from_text always gives one
            raise RuntimeError("lark's lexer thread has no text")
        counter = lexer_state.line_ctr
        counter.char_pos, counter.line, counter.line_start_pos = pos, line, line_start
        counter.column = pos - line_start + 1
        lexer_state.last_token = token
        for token in lexer.lex(state):
            yield token
    yield Token.new_borrow_pos("$END", "", token) if token else Token("$END", "", 0, 1, 1)


def parse(text: str, start: str, builder: AstBuilder) -> Any:
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
