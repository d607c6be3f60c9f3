"""The lines after ``@model`` in bulk: classified, and the state and action lines parsed.

The lines are classified (state, action, transition, comment) and the state and action lines in
the plain layout Storm and PAYNT write are parsed with vectorized numpy string operations; any
other line (extra blanks, quoted labels) and every error go through the per-line parsers of
:mod:`posgmc.io.drn.lines`, which define the syntax and the error positions. The state
valuations Storm writes as ``//[...]`` comments below the state lines are read here too.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from posgmc.io._text import STR
from posgmc.io.drn.header import Header
from posgmc.io.drn.lines import parse_action_line, parse_state_line
from posgmc.io.drn.source import DrnText
from posgmc.syntax.ast import ModelType

__all__ = [
    "Body",
    "States",
    "Actions",
    "classify",
    "check_state_count",
    "parse_states",
    "parse_actions",
    "valuations",
    "partition",
]

_IDENTIFIER_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.']*")


@dataclass
class States:
    """The state lines, parsed: one entry per state."""

    lines: np.ndarray  # int64[S]: file line numbers
    observation: np.ndarray | None  # int64[S] (pomdp, posmg)
    player: np.ndarray | None  # int64[S] (smg, posmg)
    has_rewards: np.ndarray  # bool[S]: the line has a reward list
    rewards: np.ndarray  # StringDType[S]: the reward list without brackets
    labels: dict[str, np.ndarray]  # name -> bool[S]


@dataclass
class Actions:
    """The action lines, parsed: one entry per action line."""

    lines: np.ndarray  # int64[A]: file line numbers
    names: np.ndarray  # StringDType[A]
    has_rewards: np.ndarray  # bool[A]
    rewards: np.ndarray  # StringDType[A]: the reward list without brackets


@dataclass(frozen=True)
class Body:
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
        out: np.ndarray = (np.cumsum(self.is_state) - 1)[idx]
        return out


def classify(drn: DrnText, header: Header) -> Body:
    """Sort the lines after @model into state, action and transition lines (in bulk)."""
    first = header.model_line
    stripped = np.strings.strip(np.array(drn.lines[first:], dtype=STR))
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
    body = Body(first, stripped, is_state, is_action, content & ~is_state & ~is_action)
    content_idx = np.flatnonzero(content)
    if content_idx.size == 0:
        raise drn.whole_line_error(
            "the model has no states", first, hint="add 'state 0 init' after @model"
        )
    if not is_state[content_idx[0]]:
        raise drn.whole_line_error(
            "expected a line 'state 0 ...' first after @model", body.line(content_idx[0])
        )
    return body


def check_state_count(drn: DrnText, header: Header, body: Body, state_idx: np.ndarray) -> None:
    """Check the number of state lines against ``@nr_states``."""
    declared = header.nr_states
    assert declared is not None  # read_header guarantees it
    if state_idx.size > declared:
        raise drn.whole_line_error(
            f"more states than @nr_states declares ({declared})",
            body.line(state_idx[declared]),
            hint=f"correct @nr_states on line {header.nr_states_line}",
        )
    if state_idx.size < declared:
        raise drn.whole_line_error(
            f"@nr_states declares {declared} states, but the model has {state_idx.size}",
            header.nr_states_line,
        )


def parse_states(drn: DrnText, body: Body, state_idx: np.ndarray, model_type: ModelType) -> States:
    """Parse all state lines in bulk.

    Lines in the plain layout Storm and PAYNT write (single blanks, unquoted labels) are parsed
    with vectorized string operations; every other line (and every error) goes through
    :func:`~posgmc.io.drn.lines.parse_state_line`, which is the definition of the syntax.
    """
    num_states = int(state_idx.size)
    text = body.stripped[state_idx]
    ident, _, tail = partition(np.strings.slice(text, 6, None), " ")
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
    inner, close, after = partition(np.strings.slice(tail, 1, None), "]")
    glued = (np.strings.str_len(after) > 0) & ~np.strings.startswith(after, " ")
    ok &= ~has_rewards | ((close == "]") & ~glued)
    rewards = np.where(has_rewards, inner, _EMPTY)
    tail = np.where(has_rewards, np.strings.slice(after, 1, None), tail)
    ok &= np.strings.find(tail, '"') < 0  # quoted labels take the slow path
    extra_labels: dict[int, list[str]] = {}
    for s in np.flatnonzero(~ok).tolist():
        parsed = parse_state_line(drn, body.line(state_idx[s]), s, model_type)
        if observation is not None:
            observation[s] = parsed.observation
        if player is not None:
            player[s] = parsed.player
        has_rewards[s] = parsed.rewards is not None
        rewards[s] = ",".join(t for t, _ in parsed.rewards or ())
        tail[s] = ""
        extra_labels[s] = parsed.labels
    return States(
        lines=body.lines(state_idx),
        observation=observation,
        player=player,
        has_rewards=has_rewards,
        rewards=rewards,
        labels=_labels(tail, extra_labels),
    )


def parse_actions(drn: DrnText, body: Body, action_idx: np.ndarray) -> Actions:
    """Parse all action lines in bulk (plain layout vectorized, the rest by parse_action_line)."""
    text = body.stripped[action_idx]
    name, _, tail = partition(np.strings.slice(text, 7, None), " ")
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
        parsed = parse_action_line(drn, body.line(action_idx[a]))
        name[a] = parsed.name
        has_rewards[a] = parsed.rewards is not None
        rewards[a] = ",".join(t for t, _ in parsed.rewards or ())
    return Actions(body.lines(action_idx), name, has_rewards, rewards)


_EMPTY = np.array("", dtype=STR)


def partition(texts: np.ndarray, sep: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """np.strings.partition for StringDType arrays (the separator must be of the same dtype)."""
    head, found, tail = np.strings.partition(texts, np.array(sep, dtype=STR))
    return head, found, tail


def _int_group(
    tail: np.ndarray, open_: str, close: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The leading ``{n}`` (or ``<n>``) of each text: (values, the rest, well-formed?)."""
    starts = np.strings.startswith(tail, open_)
    inner, found, after = partition(np.strings.slice(tail, 1, None), close)
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


def valuations(body: Body, state_idx: np.ndarray) -> tuple[tuple[str, ...], np.ndarray | None]:
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
        head, _, rest = partition(rest, "&")
        item = np.strings.strip(head)
        name, equals, value = partition(item, "=")
        name = np.strings.strip(name)
        value = np.strings.strip(value)
        if np.all(equals == "="):
            is_true, is_false = value == "true", value == "false"
            numbers = np.where(is_true | is_false, np.array("0", dtype=STR), value)
            digits = np.strings.lstrip(numbers, "-")
            if not np.all(np.strings.isdecimal(digits)) or np.any(np.strings.str_len(digits) > 18):
                return (), None  # not Storm's valuation comment (or beyond 64-bit integers)
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
