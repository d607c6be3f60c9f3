"""The DRN header: every line before ``@model``, read into a :class:`Header`.

The header keywords, as Storm's ``DirectEncodingParser`` reads them: ``@type`` (DTMC | MDP |
POMDP | SMG | POSMG), ``@value_type`` (optional: double | rational), ``@parameters`` (the next
line: parameter names; must be empty here), ``@placeholders`` (optional: lines ``$name : value``
until the next ``@`` line), ``@reward_models`` (the next line: names split at single
spaces/tabs), ``@nr_states`` and ``@nr_choices`` (the next line: a number), then ``@model``.
Comment lines are skipped, except a ``//@players: p1 p2`` comment (written by
:func:`~posgmc.io.drn.writer.write_drn`), which names the players.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from posgmc.io._text import parse_number
from posgmc.io.drn.source import DrnText
from posgmc.syntax.ast import ModelType

__all__ = ["Header", "PLAYERS_PREFIX", "read_header"]

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
PLAYERS_PREFIX = "//@players:"


@dataclass
class Header:
    """What the header declares, and on which line (for error positions)."""

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


def _value_line(drn: DrnText, index: int) -> tuple[str, int] | None:
    """The line after the keyword on line ``index`` (0-based), unless it is a keyword too."""
    if index + 1 >= len(drn.lines):
        return None
    raw = drn.lines[index + 1].rstrip("\r")
    if raw.lstrip().startswith("@"):
        return None
    return raw, index + 2


def _header_int(drn: DrnText, index: int, keyword: str) -> tuple[int, int]:
    value = _value_line(drn, index)
    if value is None or not value[0].strip().isdecimal() or len(value[0].strip()) > 18:
        line = index + 2 if value is not None else index + 1
        raise drn.whole_line_error(
            f"expected a non-negative integer on the line after {keyword}", line
        )
    return int(value[0].strip()), value[1]


def read_header(drn: DrnText) -> Header:
    """Read the lines up to ``@model``; raise ModelFormatError/UnsupportedError where wrong."""
    header = Header()
    seen: dict[str, int] = {}
    i = 0
    n = len(drn.lines)
    while i < n:
        raw = drn.lines[i].rstrip()
        s = raw.strip()
        ln = i + 1
        if not s:
            i += 1
            continue
        if s.startswith("//"):
            if s.startswith(PLAYERS_PREFIX):
                names = tuple(s[len(PLAYERS_PREFIX) :].split())
                header.player_names, header.players_line = names, ln
            i += 1
            continue
        keyword = s.split(":", 1)[0].split()[0] if s.startswith("@") else s
        if keyword in seen and keyword != "@model":
            raise drn.whole_line_error(
                f"{keyword} is declared twice (first on line {seen[keyword]})", ln
            )
        seen[keyword] = ln
        if keyword == "@type":
            name = s.split(":", 1)[1].strip() if ":" in s else ""
            if name in _UNSUPPORTED_TYPES:
                start = raw.index(name) if name else 0
                raise drn.error(
                    f"{_UNSUPPORTED_TYPES[name]} ({name}) are not supported",
                    ln,
                    start + 1,
                    start + len(name) + 1,
                    hint="posgmc reads DTMC, MDP, POMDP, SMG and POSMG files",
                    unsupported=True,
                )
            if name not in _TYPES:
                raise drn.whole_line_error(
                    f'unknown model type "{name}"',
                    ln,
                    hint="write one of: @type: DTMC, MDP, POMDP, SMG, POSMG",
                )
            header.model_type, header.type_line = _TYPES[name], ln
        elif keyword == "@value_type":
            name = s.split(":", 1)[1].strip() if ":" in s else ""
            if name in ("double-interval", "rational-interval", "parametric"):
                raise drn.error(
                    f"models with {name} values are not supported",
                    ln,
                    1,
                    len(raw) + 1,
                    hint="export the model with plain (double or rational) values",
                    unsupported=True,
                )
            if name not in ("double", "rational"):
                raise drn.whole_line_error(
                    f'unknown value type "{name}"', ln, hint="write @value_type: double"
                )
        elif keyword == "@parameters":
            value = _value_line(drn, i)
            if value is not None:
                i += 1
                if value[0].split():
                    raise drn.error(
                        "parametric models are not supported",
                        value[1],
                        1,
                        len(value[0].rstrip()) + 1,
                        hint="instantiate the parameters (e.g. with Storm) and export again",
                        unsupported=True,
                    )
        elif keyword == "@placeholders":
            i = _read_placeholders(drn, i, header)
        elif keyword == "@reward_models":
            value = _value_line(drn, i)
            if value is not None:
                i += 1
                # Storm splits at every single space or tab: "a b " gives ["a", "b", ""].
                header.reward_names = re.split(r"[ \t]", value[0])
        elif keyword == "@nr_states":
            header.nr_states, header.nr_states_line = _header_int(drn, i, "@nr_states")
            i += 1
        elif keyword == "@nr_choices":
            header.nr_choices, header.nr_choices_line = _header_int(drn, i, "@nr_choices")
            i += 1
        elif keyword == "@model":
            header.model_line = ln
            if header.model_type is None:
                raise drn.whole_line_error(
                    "the model type must be declared before @model",
                    ln,
                    hint="add a line '@type: MDP' (or DTMC, POMDP, SMG, POSMG) to the header",
                )
            if header.nr_states is None:
                raise drn.whole_line_error(
                    "the number of states must be declared before @model",
                    ln,
                    hint="add the lines '@nr_states' and the number of states to the header",
                )
            return header
        else:
            raise drn.whole_line_error(
                "unexpected line in the DRN header", ln, hint=_HEADER_HINT
            )
        i += 1
    last = max(1, len(drn.lines) - (1 if drn.lines and not drn.lines[-1].strip() else 0))
    raise drn.error(
        "the file ends before @model",
        last,
        hint="a DRN file has a header (@type, @nr_states, ...), then @model and the states",
    )


def _read_placeholders(drn: DrnText, index: int, header: Header) -> int:
    """Read ``$name : value`` lines after line ``index``; return the index of the last one."""
    i = index
    while i + 1 < len(drn.lines):
        raw = drn.lines[i + 1].rstrip()
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
            raise drn.whole_line_error(
                "expected a placeholder definition '$name : value'", ln
            )
        if name[1:] in header.placeholders:
            raise drn.whole_line_error(f"placeholder {name} is defined twice", ln)
        number = parse_number(value, header.placeholders)
        if number is None or not np.isfinite(number):
            col = raw.index(":") + 2
            raise drn.error(
                f'the value of placeholder {name} is not a number: "{value.strip()}"',
                ln,
                col,
                len(raw) + 1,
            )
        header.placeholders[name[1:]] = number
    return i
