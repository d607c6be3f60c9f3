"""Storm's explicit DRN format: read a file into an :class:`ExplicitModel`, write one back.

The format, as Storm 2.0 reads it (``storm-parsers/parser/DirectEncodingParser.cpp``) and writes it
(``storm/io/DirectEncodingExporter.cpp``), extended with PAYNT's partially observable games::

    // comment lines (anywhere)
    @type: POSMG                    DTMC | MDP | POMDP | SMG | POSMG
    @value_type: double             optional: double | rational
    @parameters
                                    (the next line: parameter names; must be empty here)
    @placeholders                   optional: lines "$name : value" until the next "@" line
    @reward_models
    steps cost                      (the next line: names split at single spaces/tabs)
    @nr_states
    3
    @nr_choices
    4
    @model
    state 0 {2} <1> [1, 0] init "two words"
    //[x=0	& y=1]                  optional state valuation (Storm writes one when it has them)
    	action a [0, 2.5]
    		1 : 0.5
    		2 : 1/2
    ...

State lines are ``state <id> [{<observation>}] [<<player>>] [[<rewards>]] [<labels>...]`` in this
order. ``{z}`` is required in POMDP/POSMG files and refused elsewhere; ``<p>`` (a 0-based player
index, as PAYNT writes it) is required in SMG/POSMG files and refused elsewhere. Labels are
whitespace-separated, double-quoted when they contain spaces; ``init`` marks the initial states
and ``deadlock`` the states whose self-loop was added by the exporter. Action lines are
``action <name> [[<rewards>]]``; ``__NOLABEL__`` is the unlabelled action, and a file whose
action tokens are all the choice's local index (Storm's output without choice labels) is read as
unlabelled. Transition lines are ``<target> : <probability>`` with decimal, fractional ``p/q``
or placeholder ``$name`` values. Reward brackets hold one value per reward model; an empty
bracket ``[]`` (written by the PRISM fork behind PAYNT's files) means all zero. As in Storm, the
number of reward models is the longest bracket; reward model i is named by the i-th name of
``@reward_models`` (an empty name is an unnamed reward model; a missing one is ``rew<i>``).

Semantics of the model read:

* ``@type: POSMG`` becomes :attr:`ModelType.POSG`. PAYNT's semantics: the player of the property's
  coalition observes through the ``{z}`` ids, the others see everything. Since the file gives one
  observation per state, every player gets an :class:`Observation` with these ids; the property
  decides which player's observation is used.
* ``player_names`` are ``("0", "1", ...)`` (as many as the largest player index + 1) unless the
  header has a ``//@players: p1 p2`` comment (written by :func:`write_drn`) naming them.
* Transitions to the same target within one choice are summed, as Storm does; zero
  probabilities are dropped. The transition count is the number of distinct (choice, target)
  pairs, which is Storm's ``nr_transitions``.
* State valuations are kept only when every state has a well-formed ``//[...]`` comment with the
  same variables (Storm's exporter writes true Booleans as an empty item, which makes them
  unreadable; such files are read without valuations).

Implementation: the lines are classified, and transition, action and state lines in the plain
layout Storm and PAYNT write are parsed, with vectorized numpy string operations; any other line
(extra blanks, quoted labels) and every error go through the per-line parsers
(``parse_state_line``, ``parse_action_line``), which define the syntax and the error positions.

:func:`write_drn` writes files Storm reads back (DTMC, MDP, POMDP; Storm 2.0 has no reader for
games), plus SMG/POSMG in PAYNT's layout. Reward lists are written ``[1,2.5]`` without blanks:
Storm 2.0 parses a value with a leading blank (as in its own ``[1, 2.5]``) through an inexact path
that can lose the last bit (``0.1`` becomes ``0.09999999999999999``); without blanks Storm reads
every written number exactly, as posgmc does. What DRN cannot carry: labels that hold in no state,
observation names and values (only the ids), transition rewards separate from action rewards,
and a POSG whose players have different observation functions (one must be chosen).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np
import scipy.sparse as sp

from posgmc.errors import ModelFormatError, PosgmcError, SourceSpan, SourceText, UnsupportedError
from posgmc.io._text import STR, format_values, join_columns, parse_number, parse_values, write_to
from posgmc.model.explicit import (
    ExplicitModel,
    ModelInvariantError,
    Observation,
    RewardModel,
    make_model,
)
from posgmc.syntax.ast import ModelType

__all__ = ["read_drn", "parse_drn", "write_drn", "drn_text"]

_TYPES: Mapping[str, ModelType] = {
    "DTMC": ModelType.DTMC,
    "MDP": ModelType.MDP,
    "POMDP": ModelType.POMDP,
    "SMG": ModelType.SMG,
    "POSMG": ModelType.POSG,
}
_UNSUPPORTED_TYPES: Mapping[str, str] = {
    "CTMC": "continuous-time Markov chains",
    "MA": "Markov automata",
    "Markov Automaton": "Markov automata",
    "S2PG": "stochastic two-player games in Storm's S2PG encoding",
}
_HEADER_HINT = (
    "header lines are @type, @value_type, @parameters, @placeholders, @reward_models, "
    "@nr_states, @nr_choices and @model"
)
_ORDER_HINT = "a state line reads: state <id> {<observation>} <<player>> [<rewards>] <labels>"
_NOLABEL = "__NOLABEL__"
_PLAYERS_PREFIX = "//@players:"

_TOKEN_RE = re.compile(r"[ \t]+(\S+)")
_WS_RE = re.compile(r"[ \t]*")
_UNQUOTED_LABEL_RE = re.compile(r'[^\s"]+')
_INT_RE = re.compile(r"\s*(\d+)\s*")
_IDENTIFIER_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.']*")


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------


def read_drn(source: str | os.PathLike[str], *, file: str | None = None) -> ExplicitModel:
    """Read a DRN model from a file (or from DRN text).

    Args:
        source: a path; a ``str`` containing a newline is taken as the DRN text itself.
        file: the name used in error positions (default: the path).

    Returns:
        The validated model (see the module docstring for how DRN maps onto it).

    Raises:
        ModelFormatError: the text is not valid DRN (with line and column).
        UnsupportedError: valid DRN this build does not handle (parameters, CTMCs, ...).
        OSError: the file cannot be read.
    """
    if isinstance(source, str) and "\n" in source:
        return parse_drn(source, file=file)
    path = Path(source)
    text = path.read_text(encoding="utf-8")
    return parse_drn(text, file=file if file is not None else str(path))


def parse_drn(text: str, *, file: str | None = None) -> ExplicitModel:
    """Parse DRN text into a model.

    Args:
        text: the whole DRN file.
        file: the file name for error positions.

    Returns:
        The validated model.

    Raises:
        ModelFormatError: the text is not valid DRN (with line and column).
        UnsupportedError: valid DRN this build does not handle.
    """
    return _DrnReader(text, file).read()


@dataclass
class _Header:
    model_type: ModelType | None = None
    type_line: int = 0
    nr_states: int | None = None
    nr_states_line: int = 0
    nr_choices: int | None = None
    nr_choices_line: int = 0
    reward_names: list[str] = field(default_factory=list)
    placeholders: dict[str, float] = field(default_factory=dict)
    player_names: tuple[str, ...] | None = None
    players_line: int = 0
    model_line: int = 0


@dataclass
class _StateLine:
    observation: int | None
    player: int | None
    rewards: list[tuple[str, int]] | None  # (text, 1-based column) per value; None = no bracket
    rewards_column: int
    labels: list[str]


@dataclass
class _ActionLine:
    name: str
    rewards: list[tuple[str, int]] | None
    rewards_column: int


@dataclass
class _States:
    """The state lines, parsed: one entry per state."""

    lines: np.ndarray  # int64[S]: file line numbers
    observation: np.ndarray | None  # int64[S] (pomdp, posmg)
    player: np.ndarray | None  # int64[S] (smg, posmg)
    has_rewards: np.ndarray  # bool[S]: the line has a reward list
    rewards: np.ndarray  # StringDType[S]: the reward list without brackets
    labels: dict[str, np.ndarray]  # name -> bool[S]


@dataclass
class _Actions:
    """The action lines, parsed: one entry per action line."""

    lines: np.ndarray  # int64[A]: file line numbers
    names: np.ndarray  # StringDType[A]
    has_rewards: np.ndarray  # bool[A]
    rewards: np.ndarray  # StringDType[A]: the reward list without brackets


@dataclass(frozen=True)
class _Body:
    """The lines after ``@model``, stripped and classified; body line j is file line first+j+1."""

    first: int
    stripped: np.ndarray  # StringDType[lines]
    is_state: np.ndarray  # bool[lines]
    is_action: np.ndarray  # bool[lines]
    is_trans: np.ndarray  # bool[lines]: every other non-blank, non-comment line

    def line(self, j: int | np.integer) -> int:
        return self.first + int(j) + 1

    def lines(self, idx: np.ndarray) -> np.ndarray:
        return self.first + 1 + idx.astype(np.int64)

    def state_of(self, idx: np.ndarray) -> np.ndarray:
        """The state (number of state lines above, minus one) of each body line in ``idx``."""
        return (np.cumsum(self.is_state) - 1)[idx]


@dataclass(frozen=True)
class _Choices:
    """The choice structure: row groups, and which choice each transition and action line is."""

    row_groups: np.ndarray  # int64[S + 1]
    choice_of_trans: np.ndarray  # int64[T]: choice of each transition line
    trans_idx: np.ndarray  # int64[T]: body index of each transition line
    names: np.ndarray  # StringDType[C]: action token of each choice ("" if none)
    choice_lines: np.ndarray  # int64[C]: file line of each choice's action (or state) line
    action_choice: np.ndarray  # int64[A]: choice of each action line


class _DrnReader:
    """One parse of one DRN text; keeps the text for error positions."""

    def __init__(self, text: str, file: str | None) -> None:
        self.text = text
        self.file = file
        self.source = SourceText(text, file)
        self.lines = text.split("\n")

    # -- errors ----------------------------------------------------------------------------------

    def error(
        self,
        message: str,
        line: int,
        column: int = 1,
        end_column: int | None = None,
        *,
        hint: str | None = None,
        unsupported: bool = False,
    ) -> PosgmcError:
        span = SourceSpan(line, column, line, end_column, self.file)
        if unsupported:
            return UnsupportedError(message, span, hint=hint, source=self.source)
        return ModelFormatError(message, span, hint=hint, source=self.source)

    def raw(self, line: int) -> str:
        """Line ``line`` (1-based) without its line ending and trailing blanks."""
        return self.lines[line - 1].rstrip()

    def whole_line_error(self, message: str, line: int, *, hint: str | None = None) -> PosgmcError:
        raw = self.raw(line)
        start = len(raw) - len(raw.lstrip())
        return self.error(message, line, start + 1, max(len(raw), start + 1) + 1, hint=hint)

    # -- header ----------------------------------------------------------------------------------

    def _value_line(self, index: int) -> tuple[str, int] | None:
        """The line after the keyword on line ``index`` (0-based), unless it is a keyword too."""
        if index + 1 >= len(self.lines):
            return None
        raw = self.lines[index + 1].rstrip("\r")
        if raw.lstrip().startswith("@"):
            return None
        return raw, index + 2

    def _header_int(self, index: int, keyword: str) -> tuple[int, int]:
        value = self._value_line(index)
        if value is None or not value[0].strip().isdecimal():
            line = index + 2 if value is not None else index + 1
            raise self.whole_line_error(
                f"expected a non-negative integer on the line after {keyword}", line
            )
        return int(value[0].strip()), value[1]

    def read_header(self) -> _Header:
        header = _Header()
        seen: dict[str, int] = {}
        i = 0
        n = len(self.lines)
        while i < n:
            raw = self.lines[i].rstrip()
            s = raw.strip()
            ln = i + 1
            if not s:
                i += 1
                continue
            if s.startswith("//"):
                if s.startswith(_PLAYERS_PREFIX):
                    names = tuple(s[len(_PLAYERS_PREFIX) :].split())
                    header.player_names, header.players_line = names, ln
                i += 1
                continue
            keyword = s.split(":", 1)[0].split()[0] if s.startswith("@") else s
            if keyword in seen and keyword != "@model":
                raise self.whole_line_error(
                    f"{keyword} is declared twice (first on line {seen[keyword]})", ln
                )
            seen[keyword] = ln
            if keyword == "@type":
                name = s.split(":", 1)[1].strip() if ":" in s else ""
                if name in _UNSUPPORTED_TYPES:
                    start = raw.index(name) if name else 0
                    raise self.error(
                        f"{_UNSUPPORTED_TYPES[name]} ({name}) are not supported",
                        ln,
                        start + 1,
                        start + len(name) + 1,
                        hint="posgmc reads DTMC, MDP, POMDP, SMG and POSMG files",
                        unsupported=True,
                    )
                if name not in _TYPES:
                    raise self.whole_line_error(
                        f'unknown model type "{name}"',
                        ln,
                        hint="write one of: @type: DTMC, MDP, POMDP, SMG, POSMG",
                    )
                header.model_type, header.type_line = _TYPES[name], ln
            elif keyword == "@value_type":
                name = s.split(":", 1)[1].strip() if ":" in s else ""
                if name in ("double-interval", "rational-interval", "parametric"):
                    raise self.error(
                        f"models with {name} values are not supported",
                        ln,
                        1,
                        len(raw) + 1,
                        hint="export the model with plain (double or rational) values",
                        unsupported=True,
                    )
                if name not in ("double", "rational"):
                    raise self.whole_line_error(
                        f'unknown value type "{name}"', ln, hint="write @value_type: double"
                    )
            elif keyword == "@parameters":
                value = self._value_line(i)
                if value is not None:
                    i += 1
                    if value[0].split():
                        raise self.error(
                            "parametric models are not supported",
                            value[1],
                            1,
                            len(value[0].rstrip()) + 1,
                            hint="instantiate the parameters (e.g. with Storm) and export again",
                            unsupported=True,
                        )
            elif keyword == "@placeholders":
                i = self._read_placeholders(i, header)
            elif keyword == "@reward_models":
                value = self._value_line(i)
                if value is not None:
                    i += 1
                    # Storm splits at every single space or tab: "a b " gives ["a", "b", ""].
                    header.reward_names = re.split(r"[ \t]", value[0])
            elif keyword == "@nr_states":
                header.nr_states, header.nr_states_line = self._header_int(i, "@nr_states")
                i += 1
            elif keyword == "@nr_choices":
                header.nr_choices, header.nr_choices_line = self._header_int(i, "@nr_choices")
                i += 1
            elif keyword == "@model":
                header.model_line = ln
                if header.model_type is None:
                    raise self.whole_line_error(
                        "the model type must be declared before @model",
                        ln,
                        hint="add a line '@type: MDP' (or DTMC, POMDP, SMG, POSMG) to the header",
                    )
                if header.nr_states is None:
                    raise self.whole_line_error(
                        "the number of states must be declared before @model",
                        ln,
                        hint="add the lines '@nr_states' and the number of states to the header",
                    )
                return header
            else:
                raise self.whole_line_error(
                    "unexpected line in the DRN header", ln, hint=_HEADER_HINT
                )
            i += 1
        last = max(1, len(self.lines) - (1 if self.lines and not self.lines[-1].strip() else 0))
        raise self.error(
            "the file ends before @model",
            last,
            hint="a DRN file has a header (@type, @nr_states, ...), then @model and the states",
        )

    def _read_placeholders(self, index: int, header: _Header) -> int:
        """Read ``$name : value`` lines after line ``index``; return the index of the last one."""
        i = index
        while i + 1 < len(self.lines):
            raw = self.lines[i + 1].rstrip()
            s = raw.strip()
            if s.startswith("@"):
                break
            i += 1
            if not s or s.startswith("//"):
                continue
            ln = i + 1
            name, sep, value = s.partition(":")
            name = name.strip()
            if not sep or not name.startswith("$") or len(name) < 2:
                raise self.whole_line_error(
                    "expected a placeholder definition '$name : value'", ln
                )
            if name[1:] in header.placeholders:
                raise self.whole_line_error(f"placeholder {name} is defined twice", ln)
            number = parse_number(value, header.placeholders)
            if number is None or not np.isfinite(number):
                col = raw.index(":") + 2
                raise self.error(
                    f'the value of placeholder {name} is not a number: "{value.strip()}"',
                    ln,
                    col,
                    len(raw) + 1,
                )
            header.placeholders[name[1:]] = number
        return i

    # -- lines of the model ----------------------------------------------------------------------

    def _group(self, raw: str, pos: int, ln: int, close: str, what: str) -> tuple[str, int, int]:
        """The text inside the group opening at ``raw[pos]``: (inner, its start, position after)."""
        end = raw.find(close, pos + 1)
        if end < 0:
            raise self.error(f"missing '{close}' to close the {what}", ln, pos + 1, len(raw) + 1)
        after = end + 1
        if after < len(raw) and raw[after] not in " \t":
            raise self.error(f"expected a space after the {what}", ln, after + 1, after + 2)
        return raw[pos + 1 : end], pos + 1, after

    def _int_group(self, raw: str, pos: int, ln: int, close: str, what: str) -> tuple[int, int]:
        inner, start, after = self._group(raw, pos, ln, close, what)
        m = _INT_RE.fullmatch(inner)
        if m is None:
            raise self.error(
                f"the {what} must be a non-negative integer, found \"{inner.strip()}\"",
                ln,
                start + 1,
                start + len(inner) + 1,
            )
        value = int(m.group(1))
        if value >= 2**31:
            end = start + len(inner) + 1
            raise self.error(f"the {what} {value} is too large", ln, start + 1, end)
        return value, after

    def _rewards(self, raw: str, pos: int, ln: int) -> tuple[list[tuple[str, int]], int]:
        inner, start, after = self._group(raw, pos, ln, "]", "reward list")
        if not inner.strip():
            return [], after
        values: list[tuple[str, int]] = []
        offset = start
        for part in inner.split(","):
            stripped = part.strip()
            column = offset + (len(part) - len(part.lstrip())) + 1
            if not stripped:
                raise self.error("empty reward value", ln, offset + 1, offset + len(part) + 2)
            values.append((stripped, column))
            offset += len(part) + 1
        return values, after

    def parse_state_line(
        self, ln: int, expected: int, model_type: ModelType
    ) -> _StateLine:
        raw = self.raw(ln)
        pos = len(raw) - len(raw.lstrip()) + len("state")
        m = _TOKEN_RE.match(raw, pos)
        if m is None:
            raise self.error("expected a state number after 'state'", ln, pos + 1, pos + 2)
        token = m.group(1)
        if not token.isdecimal():
            raise self.error(
                f'the state number must be a non-negative integer, found "{token}"',
                ln,
                m.start(1) + 1,
                m.end(1) + 1,
            )
        if int(token) != expected:
            raise self.error(
                f"expected state {expected}, found state {int(token)}",
                ln,
                m.start(1) + 1,
                m.end(1) + 1,
                hint="state numbers must be 0, 1, 2, ... in order and without gaps",
            )
        pos = _WS_RE.match(raw, m.end(1)).end()  # type: ignore[union-attr]
        n = len(raw)
        observation: int | None = None
        player: int | None = None
        if model_type.is_partially_observable:
            if pos >= n or raw[pos] != "{":
                raise self.error(
                    f"expected the observation '{{z}}' of state {expected}",
                    ln,
                    pos + 1,
                    pos + 2,
                    hint=_ORDER_HINT,
                )
            observation, pos = self._int_group(raw, pos, ln, "}", "observation")
            pos = _WS_RE.match(raw, pos).end()  # type: ignore[union-attr]
        elif pos < n and raw[pos] == "{":
            raise self.error(
                "observations '{z}' are only allowed in POMDP and POSMG files",
                ln,
                pos + 1,
                pos + 2,
                hint="change @type or remove the observation",
            )
        if model_type.is_game:
            if pos >= n or raw[pos] != "<":
                raise self.error(
                    f"expected the player '<p>' who owns state {expected}",
                    ln,
                    pos + 1,
                    pos + 2,
                    hint=_ORDER_HINT,
                )
            player, pos = self._int_group(raw, pos, ln, ">", "player")
            pos = _WS_RE.match(raw, pos).end()  # type: ignore[union-attr]
        elif pos < n and raw[pos] == "<":
            raise self.error(
                "players '<p>' are only allowed in SMG and POSMG files",
                ln,
                pos + 1,
                pos + 2,
                hint='change @type, or quote a label that starts with "<"',
            )
        rewards: list[tuple[str, int]] | None = None
        rewards_column = pos + 1
        if pos < n and raw[pos] == "[":
            rewards, pos = self._rewards(raw, pos, ln)
        labels: list[str] = []
        while True:
            pos = _WS_RE.match(raw, pos).end()  # type: ignore[union-attr]
            if pos >= n:
                break
            if raw[pos] == '"':
                end = raw.find('"', pos + 1)
                if end < 0:
                    raise self.error("missing '\"' to close the label", ln, pos + 1, n + 1)
                if end == pos + 1:
                    raise self.error("empty label", ln, pos + 1, pos + 3)
                labels.append(raw[pos + 1 : end])
                pos = end + 1
                if pos < n and raw[pos] not in ' \t"':
                    raise self.error(
                        "expected a space after the quoted label", ln, pos + 1, pos + 2
                    )
            else:
                lm = _UNQUOTED_LABEL_RE.match(raw, pos)
                assert lm is not None  # raw[pos] is neither blank nor a quote
                pos = lm.end()
                if pos < n and raw[pos] == '"':
                    raise self.error(
                        "a label with quotes must be quoted as a whole",
                        ln,
                        lm.start() + 1,
                        pos + 2,
                        hint='write "my label" for labels with spaces; quotes cannot be in labels',
                    )
                labels.append(lm.group(0))
        return _StateLine(observation, player, rewards, rewards_column, labels)

    def parse_action_line(self, ln: int) -> _ActionLine:
        raw = self.raw(ln)
        pos = len(raw) - len(raw.lstrip()) + len("action")
        m = _TOKEN_RE.match(raw, pos)
        if m is None or m.group(1).startswith("["):
            col = m.start(1) if m is not None else pos
            raise self.error(
                "expected an action name (or __NOLABEL__) after 'action'", ln, col + 1, col + 2
            )
        pos = _WS_RE.match(raw, m.end(1)).end()  # type: ignore[union-attr]
        rewards: list[tuple[str, int]] | None = None
        rewards_column = pos + 1
        if pos < len(raw):
            if raw[pos] != "[":
                raise self.error(
                    "unexpected text after the action name",
                    ln,
                    pos + 1,
                    len(raw) + 1,
                    hint="action names cannot contain spaces; rewards are written [r1, r2]",
                )
            rewards, pos = self._rewards(raw, pos, ln)
            pos = _WS_RE.match(raw, pos).end()  # type: ignore[union-attr]
            if pos < len(raw):
                raise self.error(
                    "unexpected text after the action's rewards", ln, pos + 1, len(raw) + 1
                )
        return _ActionLine(m.group(1), rewards, rewards_column)

    # -- the whole file --------------------------------------------------------------------------

    def read(self) -> ExplicitModel:
        header = self.read_header()
        model_type = header.model_type
        assert model_type is not None  # read_header guarantees it
        body = self._classify(header)
        state_idx = np.flatnonzero(body.is_state)
        self._check_state_count(header, body, state_idx)
        states = self._parse_states(body, state_idx, model_type)
        action_idx = np.flatnonzero(body.is_action)
        actions = self._parse_actions(body, action_idx)
        if model_type is ModelType.DTMC:
            choices = self._dtmc_choices(header, body, state_idx, action_idx, actions)
        else:
            choices = self._nondeterministic_choices(header, body, state_idx, action_idx, actions)
        transitions = self._transitions(header, body, choices, num_states=int(state_idx.size))
        choice_actions, action_names = _action_ids(choices.names, choices.row_groups)
        labels = states.labels
        if "init" not in labels:
            raise self.whole_line_error(
                "no state is labelled init",
                body.line(state_idx[0]),
                hint="add the label init to the initial state, e.g. 'state 0 init'",
            )
        reward_models = self._reward_models(header, model_type, states, actions, choices)
        players, player_names = self._players(states, model_type, header)
        variable_names, state_values = _valuations(body, state_idx)
        try:
            return make_model(
                model_type,
                choices.row_groups,
                transitions,
                initial_states=np.flatnonzero(labels["init"]),
                choice_actions=choice_actions,
                action_names=action_names,
                state_players=players,
                player_names=player_names,
                observations=_observations(states, model_type, player_names),
                labels=labels,
                reward_models=reward_models,
                variable_names=variable_names,
                state_values=state_values,
                deadlocks=np.flatnonzero(labels["deadlock"]) if "deadlock" in labels else None,
            )
        except ModelInvariantError as e:  # pragma: no cover - every invariant is checked above
            raise self.whole_line_error(f"invalid model: {e.message}", header.model_line) from None

    def _classify(self, header: _Header) -> _Body:
        """Sort the lines after @model into state, action and transition lines (in bulk)."""
        first = header.model_line
        stripped = np.strings.strip(np.array(self.lines[first:], dtype=STR))
        content = (np.strings.str_len(stripped) > 0) & ~np.strings.startswith(stripped, "//")
        is_state = content & (
            np.strings.startswith(stripped, "state ")
            | np.strings.startswith(stripped, "state\t")
            | (stripped == "state")
        )
        is_action = content & (
            np.strings.startswith(stripped, "action ")
            | np.strings.startswith(stripped, "action\t")
            | (stripped == "action")
        )
        body = _Body(first, stripped, is_state, is_action, content & ~is_state & ~is_action)
        content_idx = np.flatnonzero(content)
        if content_idx.size == 0:
            raise self.whole_line_error(
                "the model has no states", first, hint="add 'state 0 init' after @model"
            )
        if not is_state[content_idx[0]]:
            raise self.whole_line_error(
                "expected a line 'state 0 ...' first after @model", body.line(content_idx[0])
            )
        return body

    def _check_state_count(self, header: _Header, body: _Body, state_idx: np.ndarray) -> None:
        declared = header.nr_states
        assert declared is not None  # read_header guarantees it
        if state_idx.size > declared:
            raise self.whole_line_error(
                f"more states than @nr_states declares ({declared})",
                body.line(state_idx[declared]),
                hint=f"correct @nr_states on line {header.nr_states_line}",
            )
        if state_idx.size < declared:
            raise self.whole_line_error(
                f"@nr_states declares {declared} states, but the model has {state_idx.size}",
                header.nr_states_line,
            )

    def _parse_states(self, body: _Body, state_idx: np.ndarray, model_type: ModelType) -> _States:
        """Parse all state lines in bulk.

        Lines in the plain layout Storm and PAYNT write (single blanks, unquoted labels) are parsed
        with vectorized string operations; every other line (and every error) goes through
        :meth:`parse_state_line`, which is the definition of the syntax.
        """
        num_states = int(state_idx.size)
        text = body.stripped[state_idx]
        ident, _, tail = _partition(np.strings.slice(text, 6, None), " ")
        ok = np.strings.startswith(text, "state ") & (ident == np.arange(num_states).astype(STR))
        observation = player = None
        if model_type.is_partially_observable:
            observation, tail, good = _int_group(tail, "{", "}")
            ok &= good
        if model_type.is_game:
            player, tail, good = _int_group(tail, "<", ">")
            ok &= good
        # A "{" or "<" left over is an observation or player where none belongs: the slow path says so.
        ok &= ~(np.strings.startswith(tail, "{") | np.strings.startswith(tail, "<"))
        has_rewards = np.strings.startswith(tail, "[")
        inner, close, after = _partition(np.strings.slice(tail, 1, None), "]")
        glued = (np.strings.str_len(after) > 0) & ~np.strings.startswith(after, " ")
        ok &= ~has_rewards | ((close == "]") & ~glued)
        rewards = np.where(has_rewards, inner, _EMPTY)
        tail = np.where(has_rewards, np.strings.slice(after, 1, None), tail)
        ok &= np.strings.find(tail, '"') < 0  # quoted labels take the slow path
        extra_labels: dict[int, list[str]] = {}
        for s in np.flatnonzero(~ok).tolist():
            parsed = self.parse_state_line(body.line(state_idx[s]), s, model_type)
            if observation is not None:
                observation[s] = parsed.observation
            if player is not None:
                player[s] = parsed.player
            has_rewards[s] = parsed.rewards is not None
            rewards[s] = ",".join(t for t, _ in parsed.rewards or ())
            tail[s] = ""
            extra_labels[s] = parsed.labels
        return _States(
            lines=body.lines(state_idx),
            observation=observation,
            player=player,
            has_rewards=has_rewards,
            rewards=rewards,
            labels=_labels(tail, extra_labels),
        )

    def _parse_actions(self, body: _Body, action_idx: np.ndarray) -> _Actions:
        """Parse all action lines in bulk (plain layout vectorized, the rest by parse_action_line)."""
        text = body.stripped[action_idx]
        name, _, tail = _partition(np.strings.slice(text, 7, None), " ")
        ok = (
            np.strings.startswith(text, "action ")
            & (np.strings.str_len(name) > 0)
            & ~np.strings.startswith(name, "[")
            & (np.strings.find(name, "\t") < 0)
        )
        has_rewards = np.strings.startswith(tail, "[")
        ok &= (np.strings.str_len(tail) == 0) | (
            has_rewards & np.strings.endswith(tail, "]") & (np.strings.count(tail, "]") == 1)
        )
        rewards = np.where(has_rewards, np.strings.slice(tail, 1, -1), _EMPTY)
        for a in np.flatnonzero(~ok).tolist():
            parsed = self.parse_action_line(body.line(action_idx[a]))
            name[a] = parsed.name
            has_rewards[a] = parsed.rewards is not None
            rewards[a] = ",".join(t for t, _ in parsed.rewards or ())
        return _Actions(body.lines(action_idx), name, has_rewards, rewards)

    def _dtmc_choices(
        self,
        header: _Header,
        body: _Body,
        state_idx: np.ndarray,
        action_idx: np.ndarray,
        actions: _Actions,
    ) -> _Choices:
        """One choice per state; its action line is optional."""
        num_states = int(state_idx.size)
        action_states = body.state_of(action_idx)
        extra = np.flatnonzero(np.diff(action_states) == 0)
        if extra.size:
            raise self.whole_line_error(
                "a state of a DTMC has exactly one action",
                body.line(action_idx[extra[0] + 1]),
                hint="use @type: MDP for states with several actions",
            )
        if header.nr_choices is not None and header.nr_choices not in (0, num_states):
            raise self.whole_line_error(
                f"@nr_choices of a DTMC must equal @nr_states ({num_states})",
                header.nr_choices_line,
            )
        names = np.full(num_states, "", dtype=STR)
        names[action_states] = actions.names
        choice_lines = body.lines(state_idx)
        choice_lines[action_states] = body.lines(action_idx)
        trans_idx = np.flatnonzero(body.is_trans)
        return _Choices(
            row_groups=np.arange(num_states + 1, dtype=np.int64),
            choice_of_trans=body.state_of(trans_idx),
            trans_idx=trans_idx,
            names=names,
            choice_lines=choice_lines,
            action_choice=action_states,
        )

    def _nondeterministic_choices(
        self,
        header: _Header,
        body: _Body,
        state_idx: np.ndarray,
        action_idx: np.ndarray,
        actions: _Actions,
    ) -> _Choices:
        """One choice per action line; each transition belongs to the action line above it."""
        num_states = int(state_idx.size)
        trans_idx = np.flatnonzero(body.is_trans)
        positions = np.arange(body.is_state.shape[0])
        last_action = np.maximum.accumulate(np.where(body.is_action, positions, -1))
        last_state = np.maximum.accumulate(np.where(body.is_state, positions, -1))
        orphan = trans_idx[last_action[trans_idx] < last_state[trans_idx]]
        if orphan.size:
            raise self.whole_line_error(
                "a transition must follow an 'action' line",
                body.line(orphan[0]),
                hint="start each choice with 'action <name>' (or 'action __NOLABEL__')",
            )
        actions_per_state = np.bincount(body.state_of(action_idx), minlength=num_states)
        empty = np.flatnonzero(actions_per_state == 0)
        if empty.size:
            s = int(empty[0])
            raise self.whole_line_error(
                f"state {s} has no actions",
                body.line(state_idx[s]),
                hint=f"give it a self-loop, as Storm does for deadlocks: "
                f"'action __NOLABEL__' and '{s} : 1'",
            )
        num_choices = int(action_idx.size)
        declared = header.nr_choices
        if declared and num_choices > declared:
            raise self.whole_line_error(
                f"more choices than @nr_choices declares ({declared})",
                body.line(action_idx[declared]),
                hint=f"correct @nr_choices on line {header.nr_choices_line}",
            )
        if declared and num_choices < declared:
            raise self.whole_line_error(
                f"@nr_choices declares {declared} choices, but the model has {num_choices}",
                header.nr_choices_line,
            )
        return _Choices(
            row_groups=np.concatenate(([0], np.cumsum(actions_per_state))).astype(np.int64),
            choice_of_trans=(np.cumsum(body.is_action) - 1)[trans_idx],
            trans_idx=trans_idx,
            names=actions.names,
            choice_lines=body.lines(action_idx),
            action_choice=np.arange(num_choices, dtype=np.int64),
        )

    def _transitions(
        self, header: _Header, body: _Body, choices: _Choices, *, num_states: int
    ) -> sp.csr_matrix:
        """Parse all transition lines at once; check targets, values and per-choice sums."""
        trans_idx = choices.trans_idx
        num_choices = int(choices.row_groups[-1])
        lhs, sep, rhs = np.strings.partition(body.stripped[trans_idx], np.array(":", dtype=STR))
        missing = np.flatnonzero(sep != ":")
        if missing.size:
            raise self.whole_line_error(
                "expected a transition '<target> : <probability>'",
                body.line(trans_idx[missing[0]]),
                hint="lines inside a state are 'action <name>' or '<target> : <probability>'",
            )
        lhs = np.strings.strip(lhs)
        rhs = np.strings.strip(rhs)

        def target_error(k: int, message: str) -> PosgmcError:
            ln = body.line(trans_idx[k])
            raw = self.raw(ln)
            start = len(raw) - len(raw.lstrip())
            end = len(raw[: raw.index(":")].rstrip())
            return self.error(message, ln, start + 1, end + 1)

        def value_error(k: int, problem: str) -> PosgmcError:
            ln = body.line(trans_idx[k])
            raw = self.raw(ln)
            after = raw.index(":") + 1
            start = after + len(raw[after:]) - len(raw[after:].lstrip())
            return self.error(f'the probability "{rhs[k]}" {problem}', ln, start + 1, len(raw) + 1)

        bad = np.flatnonzero(~np.strings.isdecimal(lhs))
        if bad.size:
            k = int(bad[0])
            raise target_error(k, f'the target state must be a state number, found "{lhs[k]}"')
        targets = lhs.astype(np.int64)
        out = np.flatnonzero(targets >= num_states)
        if out.size:
            k = int(out[0])
            raise target_error(
                k,
                f"target state {targets[k]} does not exist "
                f"(the model has states 0 to {num_states - 1})",
            )
        values = parse_values(rhs, placeholders=header.placeholders, on_error=value_error)
        negative = np.flatnonzero(values < 0)
        if negative.size:
            raise value_error(int(negative[0]), "is negative")
        above = np.flatnonzero(values > 1.0 + 1e-9)
        if above.size:
            raise value_error(int(above[0]), "is greater than 1")
        choice_of_trans = choices.choice_of_trans
        empty = np.flatnonzero(np.bincount(choice_of_trans, minlength=num_choices) == 0)
        if empty.size:
            raise self.whole_line_error(
                "this choice has no transitions",
                int(choices.choice_lines[empty[0]]),
                hint="add transition lines '<target> : <probability>' below it",
            )
        sums = np.bincount(choice_of_trans, weights=values, minlength=num_choices)
        wrong = np.flatnonzero(np.abs(sums - 1.0) > 1e-9)
        if wrong.size:
            c = int(wrong[0])
            raise self.whole_line_error(
                f"the probabilities of this choice sum to {float(sums[c])!r}, not 1",
                int(choices.choice_lines[c]),
                hint="the transition probabilities of every choice must sum to 1 (within 1e-9)",
            )
        keep = values > 0  # Storm keeps explicit zeros; they carry nothing, so they are dropped.
        # Repeated targets are summed (as Storm does) by make_model.
        return sp.csr_matrix(
            (values[keep], (choice_of_trans[keep], targets[keep])),
            shape=(num_choices, num_states),
        )

    def _reward_models(
        self,
        header: _Header,
        model_type: ModelType,
        states: _States,
        actions: _Actions,
        choices: _Choices,
    ) -> tuple[RewardModel, ...]:
        """Reward models from the lists on state lines (state rewards) and action lines."""
        num_states = states.lines.shape[0]
        num_choices = int(choices.row_groups[-1])
        # One row per reward list, in file order.
        with_state, with_action = states.has_rewards, actions.has_rewards
        on_state = np.repeat([True, False], [int(with_state.sum()), int(with_action.sum())])
        owner = np.concatenate((np.flatnonzero(with_state), choices.action_choice[with_action]))
        lines = np.concatenate((states.lines[with_state], actions.lines[with_action]))
        inner = np.concatenate((states.rewards[with_state], actions.rewards[with_action]))
        order = np.argsort(lines, kind="stable")
        on_state, owner, lines, inner = on_state[order], owner[order], lines[order], inner[order]
        blank = np.strings.str_len(np.strings.strip(inner)) == 0
        count = np.where(blank, 0, np.strings.count(inner, ",") + 1)
        num_rewards = int(count.max()) if count.size else 0
        if num_rewards == 0:
            return ()

        def line_parse(k: int) -> tuple[list[tuple[str, int]], int]:
            """List k parsed by the per-line parser: its (text, column) values and its column."""
            line = int(lines[k])
            if on_state[k]:
                st = self.parse_state_line(line, int(owner[k]), model_type)
                return st.rewards or [], st.rewards_column
            action = self.parse_action_line(line)
            return action.rewards or [], action.rewards_column

        columns = []
        rest = inner
        for _ in range(num_rewards):
            head, _sep, rest = _partition(rest, ",")
            columns.append(np.strings.strip(head))
        texts = np.stack(columns, axis=1)  # [lists, num_rewards]
        present = np.arange(num_rewards)[None, :] < count[:, None]
        empty = np.flatnonzero((present & (np.strings.str_len(texts) == 0)).any(axis=1))
        if empty.size:
            line_parse(int(empty[0]))  # raises "empty reward value" with its position
        wrong = np.flatnonzero((count != 0) & (count != num_rewards))
        if wrong.size:
            k = int(wrong[0])
            raise self.error(
                f"expected {num_rewards} reward values (one per reward model), "
                f"found {int(count[k])}",
                int(lines[k]),
                line_parse(k)[1],
                hint="every reward list has one value per reward model, or is empty ([])",
            )
        full = np.flatnonzero(count == num_rewards)

        def reward_error(k: int, problem: str) -> PosgmcError:
            row, r = int(full[k // num_rewards]), k % num_rewards
            text, column = line_parse(row)[0][r]
            return self.error(
                f'the reward "{text}" {problem}', int(lines[row]), column, column + len(text)
            )

        values = parse_values(
            texts[full].ravel(), placeholders=header.placeholders, on_error=reward_error
        ).reshape(full.size, num_rewards)
        state_rewards = np.zeros((num_rewards, num_states))
        choice_rewards = np.zeros((num_rewards, num_choices))
        full_on_state = on_state[full]
        state_rewards[:, owner[full][full_on_state]] = values[full_on_state].T
        choice_rewards[:, owner[full][~full_on_state]] = values[~full_on_state].T
        result = []
        for r in range(num_rewards):
            # Storm: the i-th name of @reward_models, or "rew<i>" when there are too few names.
            name = header.reward_names[r] if r < len(header.reward_names) else f"rew{r}"
            result.append(
                RewardModel(
                    name or None,
                    state_rewards[r] if np.any(state_rewards[r]) else None,
                    choice_rewards[r] if np.any(choice_rewards[r]) else None,
                )
            )
        return tuple(result)

    def _players(
        self, states: _States, model_type: ModelType, header: _Header
    ) -> tuple[np.ndarray, tuple[str, ...]]:
        num_states = states.lines.shape[0]
        if not model_type.is_game or states.player is None:
            return np.zeros(num_states, dtype=np.int32), ()
        players = states.player
        num_players = int(players.max()) + 1
        if header.player_names is None:
            return players.astype(np.int32), tuple(str(p) for p in range(num_players))
        names = header.player_names
        if len(names) < num_players or len(set(names)) != len(names):
            raise self.whole_line_error(
                f"the {_PLAYERS_PREFIX} comment must name {num_players} distinct players "
                f"(players 0 to {num_players - 1} own states)",
                header.players_line,
            )
        return players.astype(np.int32), names


_EMPTY = np.array("", dtype=STR)


def _partition(texts: np.ndarray, sep: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """np.strings.partition for StringDType arrays (the separator must be of the same dtype)."""
    head, found, tail = np.strings.partition(texts, np.array(sep, dtype=STR))
    return head, found, tail


def _int_group(
    tail: np.ndarray, open_: str, close: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The leading ``{n}`` (or ``<n>``) of each text: (values, the rest, well-formed?)."""
    starts = np.strings.startswith(tail, open_)
    inner, found, after = _partition(np.strings.slice(tail, 1, None), close)
    good = (
        starts
        & (found == close)
        & np.strings.isdecimal(inner)
        & (np.strings.str_len(inner) <= 9)  # below 2^31; longer ids take the slow path
        & ((np.strings.str_len(after) == 0) | np.strings.startswith(after, " "))
    )
    values = np.where(good, inner, np.array("0", dtype=STR)).astype(np.int64)
    return values, np.strings.slice(after, 1, None), good


def _labels(tails: np.ndarray, extra: Mapping[int, list[str]]) -> dict[str, np.ndarray]:
    """Label sets from the label part of each state line (split once per distinct text)."""
    num_states = tails.shape[0]
    distinct, inverse = np.unique(tails, return_inverse=True)
    holders: dict[str, list[int]] = {}
    for u, text in enumerate(distinct.tolist()):
        for name in text.split():
            holders.setdefault(name, []).append(u)
    labels = {
        name: np.isin(inverse.ravel(), np.array(us)) for name, us in holders.items()
    }
    for s, names in extra.items():
        for name in names:
            labels.setdefault(name, np.zeros(num_states, dtype=bool))[s] = True
    return labels


def _action_ids(tokens: np.ndarray, row_groups: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Choice action ids and action names ("" first, then in order of first appearance)."""
    tokens = tokens.copy()
    if tokens.size == 0:
        return np.zeros(0, dtype=np.int32), ("",)
    local = np.arange(tokens.size) - np.repeat(row_groups[:-1], np.diff(row_groups))
    if np.all((tokens == local.astype(STR)) | (tokens == "")):
        # Storm without choice labels writes each choice's index within its state (PRISM too, for
        # DTMCs); states of a DTMC without an action line have the empty token.
        return np.zeros(tokens.size, dtype=np.int32), ("",)
    tokens[tokens == _NOLABEL] = ""
    uniq, first, inverse = np.unique(tokens, return_index=True, return_inverse=True)
    ordered = [str(u) for u in uniq[np.argsort(first, kind="stable")]]
    action_names = ("",) + tuple(n for n in ordered if n)
    position = {n: i for i, n in enumerate(action_names)}
    lookup = np.array([position[str(u)] for u in uniq], dtype=np.int32)
    return lookup[inverse.ravel()], action_names


def _observations(
    states: _States, model_type: ModelType, player_names: tuple[str, ...]
) -> tuple[Observation, ...]:
    if not model_type.is_partially_observable or states.observation is None:
        return ()
    ids = states.observation.astype(np.int32)  # the parsers keep ids below 2^31
    values = np.zeros((int(ids.max()) + 1, 0), dtype=np.int64)
    players = range(len(player_names)) if model_type.is_game else range(1)
    return tuple(Observation(p, ids, (), values) for p in players)


def _valuations(body: _Body, state_idx: np.ndarray) -> tuple[tuple[str, ...], np.ndarray | None]:
    """Variable names and values from ``//[x=1\t& b\t& !c]`` comments right below every state line.

    Any state without a well-formed valuation, or with other variables, drops them all: they are
    comments, and Storm writes some it cannot read back (true Booleans as empty items).
    """
    after = state_idx + 1
    if after[-1] >= body.stripped.shape[0]:
        return (), None
    comments = body.stripped[after]
    if not np.all(np.strings.startswith(comments, "//[") & np.strings.endswith(comments, "]")):
        return (), None
    rest = np.strings.slice(comments, 3, -1)
    items = np.strings.count(rest, "&") + 1
    if np.any(items != items[0]):
        return (), None
    names: list[str] = []
    columns: list[np.ndarray] = []
    for _ in range(int(items[0])):
        head, _, rest = _partition(rest, "&")
        item = np.strings.strip(head)
        name, equals, value = _partition(item, "=")
        name = np.strings.strip(name)
        value = np.strings.strip(value)
        if np.all(equals == "="):
            is_true, is_false = value == "true", value == "false"
            numbers = np.where(is_true | is_false, np.array("0", dtype=STR), value)
            if not np.all(np.strings.isdecimal(np.strings.lstrip(numbers, "-"))):
                return (), None
            column = np.where(is_true, 1, numbers.astype(np.int64))
        elif np.all(equals == ""):
            negated = np.strings.startswith(item, "!")
            name = np.where(negated, np.strings.slice(item, 1, None), item)
            column = np.where(negated, 0, 1).astype(np.int64)
        else:
            return (), None
        first = str(name[0])
        if not _IDENTIFIER_RE.fullmatch(first) or np.any(name != first):
            return (), None
        names.append(first)
        columns.append(column)
    return tuple(names), np.stack(columns, axis=1).astype(np.int64)


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------

_WRITE_TYPES: Mapping[ModelType, str] = {
    ModelType.DTMC: "DTMC",
    ModelType.MDP: "MDP",
    ModelType.POMDP: "POMDP",
    ModelType.SMG: "SMG",
    ModelType.POSG: "POSMG",
}


def write_drn(
    model: ExplicitModel,
    target: str | os.PathLike[str] | IO[str],
    *,
    header_comment: str | None = None,
    valuations: bool = False,
    observer: int | str | None = None,
) -> None:
    """Write ``model`` in DRN (atomically when ``target`` is a path).

    Args:
        model: the model.
        target: a path or an open text stream.
        header_comment: text written as ``//`` comment lines at the top.
        valuations: write each state's variable values as Storm does (a ``//[x=1\\t& y=0]`` line).
        observer: for a POSG whose players observe differently, the player (index or name) whose
            observation ids are written; PAYNT uses only the optimizing player's.

    Raises:
        UnsupportedError: the model holds something DRN cannot carry (see :func:`drn_text`).
        OSError: the file cannot be written (nothing is left behind).
    """
    text = drn_text(model, header_comment=header_comment, valuations=valuations, observer=observer)
    write_to(target, text)


def drn_text(
    model: ExplicitModel,
    *,
    header_comment: str | None = None,
    valuations: bool = False,
    observer: int | str | None = None,
) -> str:
    """The DRN text of ``model`` (see :func:`write_drn` for the arguments).

    Raises:
        UnsupportedError: non-finite numbers, names DRN cannot quote (labels with '"', action or
            reward names with spaces), or a POSG with several different observation functions and
            no ``observer``.
    """
    num_states, num_choices = model.num_states, model.num_choices
    rg = model.row_groups
    T = model.transitions
    observation_ids = _written_observations(model, observer)
    game = model.model_type.is_game
    type_name = _WRITE_TYPES[model.model_type]
    if model.model_type is ModelType.POSG and observation_ids is None:
        type_name = "SMG"
    reward_names = [rm.name or "" for rm in model.reward_models]
    for name in reward_names:
        if re.search(r"\s", name):
            raise UnsupportedError(
                f'the reward model name "{name}" contains a space, which DRN cannot carry',
                hint="rename the reward structure",
            )

    head = ["// Exported by posgmc", f"// Original model type: {model.model_type.value}"]
    if header_comment:
        head.extend("// " + line for line in header_comment.splitlines())
    if game:
        for name in model.player_names:
            if not name or re.search(r"\s", name):
                raise UnsupportedError(f'the player name "{name}" cannot be written in DRN')
        head.append(_PLAYERS_PREFIX + " " + " ".join(model.player_names))
    head += [
        f"@type: {type_name}",
        "@parameters",
        "",
        "@reward_models",
        # Storm writes every name followed by one space.
        "".join(name + " " for name in reward_names),
        "@nr_states",
        str(num_states),
        "@nr_choices",
        str(num_choices),
        "@model",
    ]

    # -- state lines -----------------------------------------------------------------------------
    state_line = np.strings.add("state ", np.arange(num_states).astype(STR))
    if observation_ids is not None:
        state_line = np.strings.add(
            np.strings.add(np.strings.add(state_line, " {"), observation_ids.astype(STR)), "}"
        )
    if game:
        state_line = np.strings.add(
            np.strings.add(np.strings.add(state_line, " <"), model.state_players.astype(STR)), ">"
        )
    if model.reward_models:
        columns = [
            format_values(rm.state if rm.state is not None else np.zeros(num_states), what="reward")
            for rm in model.reward_models
        ]
        state_line = np.strings.add(
            np.strings.add(np.strings.add(state_line, " ["), join_columns(columns, ",")), "]"
        )
    for name in _label_order(model.labels):
        token = np.full(num_states, "", dtype=STR)
        token[np.asarray(model.labels[name], dtype=bool)] = " " + _quote_label(name)
        state_line = np.strings.add(state_line, token)

    # -- action lines ----------------------------------------------------------------------------
    tokens = []
    for name in model.action_names:
        if re.search(r"\s", name):
            raise UnsupportedError(
                f'the action name "{name}" contains a space, which DRN cannot carry',
                hint="rename the action",
            )
        tokens.append(name or _NOLABEL)
    action_line = np.strings.add("\taction ", np.array(tokens, dtype=STR)[model.choice_actions])
    if model.reward_models:
        columns = [
            format_values(
                rm.choice if rm.choice is not None else np.zeros(num_choices), what="reward"
            )
            for rm in model.reward_models
        ]
        action_line = np.strings.add(
            np.strings.add(np.strings.add(action_line, " ["), join_columns(columns, ",")), "]"
        )

    # -- transition lines ------------------------------------------------------------------------
    trans_line = np.strings.add(
        np.strings.add("\t\t", T.indices.astype(STR)),
        np.strings.add(" : ", format_values(T.data, what="probability")),
    )

    # -- interleave: state s, [valuation], then each choice's action line and its transitions ----
    write_values = valuations and len(model.variable_names) > 0
    per_state = 2 if write_values else 1
    indptr = T.indptr.astype(np.int64)
    states = np.arange(num_states, dtype=np.int64)
    state_pos = states * per_state + rg[:-1] + indptr[rg[:-1]]
    choices = np.arange(num_choices, dtype=np.int64)
    action_pos = (model.choice_states + 1) * per_state + choices + indptr[:-1]
    trans_choice = np.repeat(choices, np.diff(indptr))
    trans_pos = action_pos[trans_choice] + 1 + (np.arange(T.nnz) - indptr[trans_choice])
    lines = np.empty(num_states * per_state + num_choices + T.nnz, dtype=STR)
    lines[state_pos] = state_line
    lines[action_pos] = action_line
    lines[trans_pos] = trans_line
    if write_values:
        values = model.state_values
        columns = [
            np.strings.add(name + "=", values[:, v].astype(STR))
            for v, name in enumerate(model.variable_names)
        ]
        lines[state_pos + 1] = np.strings.add(
            np.strings.add("//[", join_columns(columns, "\t& ")), "]"
        )
    return "\n".join(head + lines.tolist()) + "\n"


def _written_observations(model: ExplicitModel, observer: int | str | None) -> np.ndarray | None:
    """The one observation id per state that the DRN file carries (None: no observations)."""
    if not model.model_type.is_partially_observable or not model.observations:
        if model.model_type is ModelType.POMDP:
            raise UnsupportedError("a POMDP without an observation function cannot be written")
        return None
    if observer is not None:
        index = observer
        if isinstance(observer, str):
            if observer not in model.player_names:
                raise UnsupportedError(f'observer "{observer}" is not a player of the model')
            index = model.player_names.index(observer)
        obs = model.observation_of(int(index))
        if obs is None:
            raise UnsupportedError(
                f"player {observer} observes the full state; it has no observation ids"
            )
        return obs.state_ids
    first = model.observations[0].state_ids
    if all(np.array_equal(o.state_ids, first) for o in model.observations[1:]):
        return first
    raise UnsupportedError(
        "the players observe the game differently, but DRN carries one observation per state",
        hint="pass observer=<player> to write the observations of the partially observing "
        "player the property optimizes for (PAYNT uses only that player's)",
    )


def _label_order(labels: Mapping[str, np.ndarray]) -> list[str]:
    """init and deadlock first (as PRISM writes them), then the model's labels in order."""
    order = [n for n in ("init", "deadlock") if n in labels]
    return order + [n for n in labels if n not in ("init", "deadlock")]


def _quote_label(name: str) -> str:
    if not name or '"' in name or "\n" in name:
        raise UnsupportedError(
            f"the label {name!r} cannot be written in DRN (labels are non-empty, without quotes)",
            hint="rename the label",
        )
    # Quote what would otherwise read as something else: spaces, or a leading group bracket.
    if re.search(r"\s", name) or name[0] in "[{<":
        return f'"{name}"'
    return name
