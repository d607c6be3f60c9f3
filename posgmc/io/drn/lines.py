"""The per-line parsers of state and action lines: the definition of their syntax and of every
error position in them.

State lines are ``state <id> [{<observation>}] [<<player>>] [[<rewards>]] [<labels>...]`` in this
order. ``{z}`` is required in POMDP/POSMG files and refused elsewhere; ``<p>`` (a 0-based player
index, as PAYNT writes it) is required in SMG/POSMG files and refused elsewhere. Labels are
whitespace-separated, double-quoted when they contain spaces. Action lines are
``action <name> [[<rewards>]]``; ``__NOLABEL__`` is the unlabelled action. Reward brackets hold
comma-separated values, one per reward model; an empty bracket ``[]`` (written by the PRISM fork
behind PAYNT's files) means all zero.

The bulk parsers (:mod:`posgmc.io.drn.body`, :mod:`posgmc.io.drn.rewards`) parse the plain layout
Storm and PAYNT write themselves and hand any other line (extra blanks, quoted labels), and every
line with an error, to these parsers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from posgmc.io.drn.source import DrnText
from posgmc.syntax.ast import ModelType

__all__ = ["NOLABEL", "StateLine", "ActionLine", "parse_state_line", "parse_action_line"]

_ORDER_HINT = "a state line reads: state <id> {<observation>} <<player>> [<rewards>] <labels>"
NOLABEL = "__NOLABEL__"

_TOKEN_RE = re.compile(r"[ \t]+(\S+)")
_WS_RE = re.compile(r"[ \t]*")


def _skip_blanks(raw: str, pos: int) -> int:
    """The first position at or after ``pos`` that is not a blank or a tab."""
    m = _WS_RE.match(raw, pos)
    return pos if m is None else m.end()  # (the pattern matches everywhere)
_UNQUOTED_LABEL_RE = re.compile(r'[^\s"]+')
_INT_RE = re.compile(r"\s*(\d+)\s*")


@dataclass
class StateLine:
    """A state line, as :func:`parse_state_line` reads it."""

    observation: int | None
    player: int | None
    rewards: list[tuple[str, int]] | None  # (text, 1-based column) per value; None = no bracket
    rewards_column: int
    labels: list[str]


@dataclass
class ActionLine:
    """An action line, as :func:`parse_action_line` reads it."""

    name: str
    rewards: list[tuple[str, int]] | None
    rewards_column: int


def _group(
    drn: DrnText, raw: str, pos: int, ln: int, close: str, what: str
) -> tuple[str, int, int]:
    """The text inside the group opening at ``raw[pos]``: (inner, its start, position after)."""
    end = raw.find(close, pos + 1)
    if end < 0:
        raise drn.error(f"missing '{close}' to close the {what}", ln, pos + 1, len(raw) + 1)
    after = end + 1
    if after < len(raw) and raw[after] not in " \t":
        raise drn.error(f"expected a space after the {what}", ln, after + 1, after + 2)
    return raw[pos + 1 : end], pos + 1, after


def _int_group(drn: DrnText, raw: str, pos: int, ln: int, close: str, what: str) -> tuple[int, int]:
    inner, start, after = _group(drn, raw, pos, ln, close, what)
    m = _INT_RE.fullmatch(inner)
    if m is None:
        raise drn.error(
            f"the {what} must be a non-negative integer, found \"{inner.strip()}\"",
            ln,
            start + 1,
            start + len(inner) + 1,
        )
    digits = m.group(1).lstrip("0") or "0"
    value = int(digits) if len(digits) <= 18 else 2**63
    if value >= 2**31:
        end = start + len(inner) + 1
        shown = m.group(1) if len(m.group(1)) <= 30 else m.group(1)[:20] + "..."
        raise drn.error(f"the {what} {shown} is too large", ln, start + 1, end)
    return value, after


def _rewards(drn: DrnText, raw: str, pos: int, ln: int) -> tuple[list[tuple[str, int]], int]:
    inner, start, after = _group(drn, raw, pos, ln, "]", "reward list")
    if not inner.strip():
        return [], after
    values: list[tuple[str, int]] = []
    offset = start
    for part in inner.split(","):
        stripped = part.strip()
        column = offset + (len(part) - len(part.lstrip())) + 1
        if not stripped:
            raise drn.error("empty reward value", ln, offset + 1, offset + len(part) + 2)
        values.append((stripped, column))
        offset += len(part) + 1
    return values, after


def parse_state_line(
    drn: DrnText, ln: int, expected: int, model_type: ModelType
) -> StateLine:
    """Parse line ``ln``, the line of state ``expected``; raise ModelFormatError where wrong."""
    raw = drn.raw(ln)
    pos = len(raw) - len(raw.lstrip()) + len("state")
    m = _TOKEN_RE.match(raw, pos)
    if m is None:
        raise drn.error("expected a state number after 'state'", ln, pos + 1, pos + 2)
    token = m.group(1)
    if not token.isdecimal():
        raise drn.error(
            f'the state number must be a non-negative integer, found "{token}"',
            ln,
            m.start(1) + 1,
            m.end(1) + 1,
        )
    if len(token) > 18 or int(token) != expected:
        raise drn.error(
            f"expected state {expected}, found state "
            f"{token if len(token) <= 30 else token[:20] + '...'}",
            ln,
            m.start(1) + 1,
            m.end(1) + 1,
            hint="state numbers must be 0, 1, 2, ... in order and without gaps",
        )
    pos = _skip_blanks(raw, m.end(1))
    n = len(raw)
    observation: int | None = None
    player: int | None = None
    if model_type.is_partially_observable:
        if pos >= n or raw[pos] != "{":
            raise drn.error(
                f"expected the observation '{{z}}' of state {expected}",
                ln,
                pos + 1,
                pos + 2,
                hint=_ORDER_HINT,
            )
        observation, pos = _int_group(drn, raw, pos, ln, "}", "observation")
        pos = _skip_blanks(raw, pos)
    elif pos < n and raw[pos] == "{":
        raise drn.error(
            "observations '{z}' are only allowed in POMDP and POSMG files",
            ln,
            pos + 1,
            pos + 2,
            hint="change @type or remove the observation",
        )
    if model_type.is_game:
        if pos >= n or raw[pos] != "<":
            raise drn.error(
                f"expected the player '<p>' who owns state {expected}",
                ln,
                pos + 1,
                pos + 2,
                hint=_ORDER_HINT,
            )
        player, pos = _int_group(drn, raw, pos, ln, ">", "player")
        pos = _skip_blanks(raw, pos)
    elif pos < n and raw[pos] == "<":
        raise drn.error(
            "players '<p>' are only allowed in SMG and POSMG files",
            ln,
            pos + 1,
            pos + 2,
            hint='change @type, or quote a label that starts with "<"',
        )
    rewards: list[tuple[str, int]] | None = None
    rewards_column = pos + 1
    if pos < n and raw[pos] == "[":
        rewards, pos = _rewards(drn, raw, pos, ln)
    labels: list[str] = []
    while True:
        pos = _skip_blanks(raw, pos)
        if pos >= n:
            break
        if raw[pos] == '"':
            end = raw.find('"', pos + 1)
            if end < 0:
                raise drn.error("missing '\"' to close the label", ln, pos + 1, n + 1)
            if end == pos + 1:
                raise drn.error("empty label", ln, pos + 1, pos + 3)
            labels.append(raw[pos + 1 : end])
            pos = end + 1
            if pos < n and raw[pos] not in ' \t"':
                raise drn.error(
                    "expected a space after the quoted label", ln, pos + 1, pos + 2
                )
        else:
            lm = _UNQUOTED_LABEL_RE.match(raw, pos)
            assert lm is not None  # raw[pos] is neither blank nor a quote
            pos = lm.end()
            if pos < n and raw[pos] == '"':
                raise drn.error(
                    "a label with quotes must be quoted as a whole",
                    ln,
                    lm.start() + 1,
                    pos + 2,
                    hint='write "my label" for labels with spaces; quotes cannot be in labels',
                )
            labels.append(lm.group(0))
    return StateLine(observation, player, rewards, rewards_column, labels)


def parse_action_line(drn: DrnText, ln: int) -> ActionLine:
    """Parse the action line ``ln``; raise ModelFormatError where it is wrong."""
    raw = drn.raw(ln)
    pos = len(raw) - len(raw.lstrip()) + len("action")
    m = _TOKEN_RE.match(raw, pos)
    if m is None or m.group(1).startswith("["):
        col = m.start(1) if m is not None else pos
        raise drn.error(
            "expected an action name (or __NOLABEL__) after 'action'", ln, col + 1, col + 2
        )
    pos = _skip_blanks(raw, m.end(1))
    rewards: list[tuple[str, int]] | None = None
    rewards_column = pos + 1
    if pos < len(raw):
        if raw[pos] != "[":
            raise drn.error(
                "unexpected text after the action name",
                ln,
                pos + 1,
                len(raw) + 1,
                hint="action names cannot contain spaces; rewards are written [r1, r2]",
            )
        rewards, pos = _rewards(drn, raw, pos, ln)
        pos = _skip_blanks(raw, pos)
        if pos < len(raw):
            raise drn.error(
                "unexpected text after the action's rewards", ln, pos + 1, len(raw) + 1
            )
    return ActionLine(m.group(1), rewards, rewards_column)
