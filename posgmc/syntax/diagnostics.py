"""Turn lark's syntax errors into :class:`~posgmc.errors.ParseError` messages a person can act on.

lark reports an unexpected token together with the set of terminal names the parser could have
accepted. This module words that set in human terms ("expected ';' but found '['", "expected an
expression"), points the span at the offending token (or just past the last token when the text
ends early), and adds a hint for the common mistakes: a block that is never closed (a missing
``endmodule``), a call of something that is not a function, a primed variable outside an update,
an update without a prime, a time bound with ``+``/``-`` that needs parentheses.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from copy import copy
from dataclasses import dataclass

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr, TerminalDef
from lark.parsers.lalr_parser_state import ParserState

from posgmc.errors import ParseError, SourceSpan
from posgmc.syntax.ast import (
    Binary,
    Call,
    ConstantDecl,
    FormulaDecl,
    Ite,
    LabelDecl,
    MultiQuery,
    ProbQuery,
    RewardKind,
    RewardObjective,
    RewardQuery,
    Temporal,
    TimeBound,
    Unary,
    UnaryOp,
)
from posgmc.syntax.items import PropertyItem, QueryOp

_FUNCTIONS = "min, max, floor, ceil, round, pow, mod and log"

# Regular-expression terminals, in words.
_REGEX_NAMES: dict[str, str] = {
    "IDENT": "a name",
    "PIDENT": "a name",
    "IDENTPRIME": "a primed variable (x')",
    "CALLNAME": "a function name",
    "MULTI": "multi(",
    "INT": "an integer",
    "DOUBLE": "a number",
    "STRING": 'a quoted name ("...")',
}

# Terminals that may start an expression; when the parser would accept an expression, these are
# summarised as "an expression" instead of being listed one by one.
_EXPRESSION_STARTS = frozenset(
    {
        "INT", "DOUBLE", "IDENT", "PIDENT", "TRUE", "FALSE", "LPAR", "MINUS", "BANG", "MIN", "MAX",
        "CALLNAME", "FILTER", "CTL_A", "CTL_E", "STEADY", "FUNC", "STRING", "P", "PMIN", "PMAX",
        "R", "RMIN", "RMAX", "LSQB", "F", "G", "X", "MULTI",
    }
)  # fmt: skip

# Binary operators (by their text): listed only when nothing else would do.
_OPERATOR_TEXTS = frozenset(
    {
        "+",
        "-",
        "*",
        "/",
        "^",
        "&",
        "|",
        "=",
        "!=",
        "<",
        "<=",
        ">",
        ">=",
        "=>",
        "<=>",
        "?",
        "U",
        "W",
        "R",
    }
)

# Top-level keywords of a model file (a model type, or the start of a declaration).
_MODEL_TOP = frozenset(
    {
        "DTMC", "PROBABILISTIC", "MDP", "NONDETERMINISTIC", "POMDP", "SMG", "POSG", "CTMC",
        "STOCHASTIC", "CTMDP", "PTA", "POPTA", "CSG", "STPG", "TPTG", "CONST", "FORMULA", "LABEL",
        "GLOBAL", "MODULE", "REWARDS", "INIT", "OBSERVABLES", "OBSERVABLE", "PLAYER",
    }
)  # fmt: skip

# Blocks that need a closing keyword: closing terminal -> (opening terminal, what the block is).
_BLOCKS: dict[str, tuple[str, str]] = {
    "ENDMODULE": ("MODULE", "module"),
    "ENDREWARDS": ("REWARDS", "reward structure"),
    "ENDPLAYER": ("PLAYER", "player"),
    "ENDOBSERVABLES": ("OBSERVABLES", "observables list"),
    "ENDINIT": ("INIT", "init block"),
}


@dataclass(frozen=True)
class _Context:
    """What the parser was in the middle of when it failed, read off its value stack: tokens
    not yet reduced, and the values (``ast.py`` nodes and the transformer's intermediate
    records; lists for repetitions) of the complete phrases before them."""

    stack: tuple[object, ...]

    def opener(self, terminal: str) -> Token | None:
        """The innermost unclosed token of type ``terminal`` (the ``module`` of an open module)."""
        for item in reversed(self.stack):
            if isinstance(item, Token) and item.type == terminal:
                return item
        return None

    def open_temporal(self) -> Token | None:
        """The unary temporal operator (F, G, X) whose operand the parser is in, inside the
        innermost ``[``; None outside one."""
        for item in reversed(self.stack):
            if isinstance(item, Token):
                if item.type == "LSQB":
                    return None
                if item.type in ("F", "G", "X"):
                    return item
        return None

    def in_time_bound(self, token: Token) -> bool:
        """True when the error looks like a time bound that swallowed less than intended:
        ``F<=T+1 x`` fails at '+', and ``F<=T-1 x`` parses ``-1 x`` as the operand."""
        for i in range(len(self.stack) - 1, -1, -1):
            item = self.stack[i]
            if isinstance(item, Token) and item.type in ("F", "G", "X", "U", "W", "R"):
                rest = self.stack[i + 1 :]
                if rest and isinstance(rest[0], Token) and rest[0].value in _BOUND_OPS:
                    return token.type in ("PLUS", "MINUS")
                if len(rest) > 1 and isinstance(rest[0], TimeBound):
                    after = rest[1]
                    return _is_negation(after) or (
                        isinstance(after, Token) and after.type == "MINUS"
                    )
                break
        return any(_bound_then_minus(item) for item in self.stack if not isinstance(item, Token))


_BOUND_OPS = frozenset({"<=", "<", ">=", ">", "="})


def _is_negation(value: object) -> bool:
    return isinstance(value, Unary) and value.op is UnaryOp.NEG


def _bound_then_minus(value: object) -> bool:
    """True if ``value`` (or the chain of its last operands) holds a bounded temporal operator
    whose operand right after the bound is a negation."""
    node: object = value
    while node is not None:
        if isinstance(node, Temporal) and node.bound is not None:
            if _is_negation(node.operands[-1]):
                return True
        node = _last_part(node)
    return False


def _last_part(value: object) -> object:
    """The last part of a stack value as written (its last operand), or ``None`` for a leaf."""
    if isinstance(value, list):  # a repetition, e.g. the properties read so far
        return value[-1] if value else None
    if isinstance(value, Unary):
        return value.operand
    if isinstance(value, Binary):
        return value.right
    if isinstance(value, Ite):
        return value.otherwise
    if isinstance(value, (Call, Temporal)):
        operands = value.args if isinstance(value, Call) else value.operands
        return operands[-1] if operands else None
    if isinstance(value, MultiQuery):
        return value.objectives[-1] if value.objectives else None
    if isinstance(value, ProbQuery):
        return value.path
    if isinstance(value, RewardQuery):
        return value.objective
    if isinstance(value, RewardObjective):
        if value.kind in (RewardKind.CUMULATIVE, RewardKind.INSTANTANEOUS):
            return value.bound
        if value.kind is RewardKind.DISCOUNTED_TOTAL:
            return value.discount
        return value.target
    if isinstance(value, QueryOp):
        return value.threshold.value if value.threshold is not None else None
    if isinstance(value, TimeBound):
        return value.upper if value.upper is not None else value.lower
    if isinstance(value, PropertyItem):
        return value.expr
    if isinstance(value, ConstantDecl):
        return value.value
    if isinstance(value, (FormulaDecl, LabelDecl)):
        return value.expr
    return None


def _join(phrases: Sequence[str]) -> str:
    if len(phrases) <= 1:
        return "".join(phrases)
    return ", ".join(phrases[:-1]) + " or " + phrases[-1]


def _describe_terminal(name: str, terminals: dict[str, TerminalDef]) -> str:
    if name == "$END":
        return "the end of the text"
    if name in _REGEX_NAMES:
        return _REGEX_NAMES[name]
    term = terminals.get(name)
    if term is not None and isinstance(term.pattern, PatternStr):
        return f"'{term.pattern.value}'"
    return name.lower()


def _terminal_text(name: str, terminals: dict[str, TerminalDef]) -> str | None:
    term = terminals.get(name)
    if term is not None and isinstance(term.pattern, PatternStr):
        return str(term.pattern.value)
    return None


def describe_expected(expected: Iterable[str], terminals: dict[str, TerminalDef]) -> str:
    """Word a set of acceptable terminals: groups become "an expression" or "a declaration",
    and binary operators are left out when something more specific is possible."""
    names = set(expected)
    phrases: list[str] = []
    if {"MODULE", "CONST"} <= names:
        names -= _MODEL_TOP
        phrases.append("a model type or a declaration (module, const, formula, label, ...)")
    is_expression = {"INT", "LPAR"} <= names and bool({"IDENT", "PIDENT"} & names)
    operator_names = {n for n in names if _terminal_text(n, terminals) in _OPERATOR_TEXTS}
    after_operand = {"PLUS", "STAR"} <= names
    if is_expression:
        names -= _EXPRESSION_STARTS
        names -= {n for n in names if _terminal_text(n, terminals) == "<<"}
        if "CONST" in names:  # the start of a property file item
            names -= {"CONST", "FORMULA", "LABEL"}
            phrases.append("a property or a declaration (const, formula, label)")
        else:
            phrases.append("an expression")
    if after_operand:
        structural = names - operator_names
        if structural or phrases:
            names = structural
        else:
            return "an operator"
    temporal = {n for n in names if _terminal_text(n, terminals) in ("U", "W", "R")}
    if temporal and (names - temporal or phrases):
        names -= temporal
    # PRISM's old filter form `P=? [ F a {s=1} ]` is possible before every ']': rarely meant
    texts = {n: _terminal_text(n, terminals) for n in names}
    if "]" in texts.values():
        names -= {n for n, t in texts.items() if t == "{"}
    rest = sorted(names, key=lambda n: (n == "$END", _describe_terminal(n, terminals)))
    phrases.extend(_describe_terminal(n, terminals) for n in rest)
    return _join(phrases) if phrases else "something else"


def _found(token: Token) -> str:
    if token.type == "$END":
        return "the end of the text"
    value = str(token.value)
    if token.type == "STRING" or "'" in value:
        return value if value.startswith('"') else f'"{value}"'
    return f"'{value}'"


def _token_span(token: Token, file: str | None) -> SourceSpan:
    if token.type == "$END":
        # lark borrows the position of the last token; point just past it.
        line = token.end_line if isinstance(token.end_line, int) else 1
        col = token.end_column if isinstance(token.end_column, int) else 1
        return SourceSpan(line, col, line, col + 1, file)
    line = token.line if isinstance(token.line, int) else 1
    col = token.column if isinstance(token.column, int) else 1
    end_line = token.end_line if isinstance(token.end_line, int) else line
    end_col = token.end_column if isinstance(token.end_column, int) else col + 1
    return SourceSpan(line, col, end_line, end_col, file)


def _parser_state(exc: UnexpectedInput) -> ParserState[int] | None:
    ip = getattr(exc, "interactive_parser", None)
    if ip is not None and isinstance(ip.parser_state, ParserState):
        return ip.parser_state
    state = getattr(exc, "state", None)
    return state if isinstance(state, ParserState) else None


def _exact_accepts(state: ParserState[int]) -> set[str]:
    """The terminals that can really follow the parser's stack.

    An LALR state's table merges the lookaheads of every context with the same items, so its
    expected set can list tokens that are wrong here; feeding each candidate to a copy of the
    parser (without tree-building callbacks) keeps only the ones that would be accepted.
    """
    conf = copy(state.parse_conf)
    conf.callbacks = {}
    accepted: set[str] = set()
    for name in state.parse_conf.states[state.position]:
        if not name.isupper():
            continue
        trial = ParserState(conf, state.lexer, list(state.state_stack), list(state.value_stack))
        try:
            trial.feed_token(Token(name, ""), is_end=name == "$END")
        except (UnexpectedToken, AssertionError, KeyError):
            # lark asserts instead of raising on some impossible moves at the end of input
            continue
        accepted.add(name)
    return accepted


def _previous_word(text: str, offset: int) -> str | None:
    """The identifier that ends just before ``offset`` (skipping blanks), if any."""
    i = offset
    while i > 0 and text[i - 1] in " \t":
        i -= 1
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] == "_"):
        j -= 1
    if j < i and (text[j].isalpha() or text[j] == "_"):
        return text[j:i]
    return None


def unexpected_token(
    exc: UnexpectedToken, text: str, file: str | None, terminals: dict[str, TerminalDef]
) -> ParseError:
    """The :class:`ParseError` for lark's ``UnexpectedToken``."""
    token: Token = exc.token
    state = _parser_state(exc)
    expected = _exact_accepts(state) if state is not None else set(exc.expected or ())
    context = _Context(tuple(state.value_stack) if state is not None else ())
    span = _token_span(token, file)
    wanted = describe_expected(expected, terminals)
    found = _found(token)
    message = f"expected {wanted} but found {found}"
    hint: str | None = None

    if token.value == "hole" and expected & _MODEL_TOP:
        # PAYNT's sketches (sketch.templ) declare "hole int x in {1,2};" at the top level
        return ParseError(
            "'hole' declares a parameter of a PAYNT sketch: this file describes a family of "
            "models, one per value of its holes, and posgmc checks single models",
            span,
            hint="give each hole one value (hole int x in {1,2}; -> const int x = 1;) to check "
            "that member of the family; PAYNT searches the family",
        )
    closers = [c for c in _BLOCKS if c in expected]
    if closers:
        closer = closers[0]
        opener_type, what = _BLOCKS[closer]
        opener = context.opener(opener_type)
        end_word = _terminal_text(closer, terminals) or closer.lower()
        if opener is not None and (token.type == "$END" or token.type in _MODEL_TOP):
            where = f"line {opener.line}"
            if token.type == "$END":
                message = f"the text ends inside the {what} opened at {where}: expected {wanted}"
            else:
                message = (
                    f"expected {wanted} but found {found}: "
                    f"the {what} opened at {where} is not closed"
                )
            hint = f"add '{end_word}' to close the {what} that starts at {where}"
    if hint is None and token.type == "LPAR" and "LPAR" not in expected:
        name = _previous_word(text, token.start_pos) if token.start_pos is not None else None
        if name is not None:
            message = f"'{name}' is not a function: found '(' after it"
            hint = f"the functions are {_FUNCTIONS}; a call is written name(arg, ...)"
    temporal_word = token.value in ("F", "G", "X", "U", "W")
    prefix = context.open_temporal()
    if hint is None and temporal_word and prefix is not None and token.value in ("F", "G", "X"):
        p, t = prefix.value, token.value
        message = f"ambiguous temporal operator '{t}' inside the operand of '{p}'"
        hint = (
            f"the operand of {p} extends as far as it can (PRISM: F a & b is F (a & b)), so say "
            f"which is meant with parentheses: {p} (a & ({t} b)) or ({p} a) & ({t} b)"
        )
    if hint is None and temporal_word and token.type in ("IDENT", token.value):
        hint = 'temporal operators belong inside P[...] or R[...], e.g. Pmax=? [ F "goal" ]'
    if hint is None and token.type == "IDENTPRIME":
        hint = "a primed variable may only appear on the left of an update, as in (x'=x+1)"
    if hint is None and context.in_time_bound(token):
        hint = "a time bound with + or - must be in parentheses, e.g. F<=(T-1) \"goal\""
    if hint is None and "COLON" in expected and token.type in ("SEMICOLON", "PLUS", "AMPERSAND"):
        if any(isinstance(item, Token) and item.value == "->" for item in context.stack):
            hint = "an update assigns primed variables, (x'=e); a probability is followed by ':'"
    return ParseError(message, span, hint=hint)


def unexpected_characters(exc: UnexpectedCharacters, text: str, file: str | None) -> ParseError:
    """The :class:`ParseError` for lark's ``UnexpectedCharacters``."""
    line = exc.line if isinstance(exc.line, int) else 1
    col = exc.column if isinstance(exc.column, int) else 1
    char = exc.char
    span = SourceSpan(line, col, line, col + 1, file)
    hint: str | None = None
    if char == "'":
        hint = "a primed variable may only appear on the left of an update, as in (x'=x+1)"
    elif char == '"':
        hint = "a quoted name must be closed on the same line"
    shown = repr(char) if char.isprintable() else f"U+{ord(char):04X}"
    return ParseError(f"unexpected character {shown}", span, hint=hint)
