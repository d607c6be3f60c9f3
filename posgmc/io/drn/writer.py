"""Write an :class:`ExplicitModel` in DRN: :func:`write_drn` and :func:`drn_text`.

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
from collections.abc import Iterator, Mapping
from typing import IO

import numpy as np

from posgmc.errors import UnsupportedError
from posgmc.io._text import STR, format_values, join_columns
from posgmc.io.drn.header import PLAYERS_PREFIX
from posgmc.io.drn.lines import NOLABEL
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import ModelType

__all__ = ["drn_text", "iter_drn", "write_drn"]

_WRITE_TYPES: Mapping[ModelType, str] = {
    ModelType.DTMC: "DTMC",
    ModelType.MDP: "MDP",
    ModelType.POMDP: "POMDP",
    ModelType.SMG: "SMG",
    ModelType.POSG: "POSMG",
}


_CHUNK_ENTRIES = 1 << 18
"""Transitions formatted per chunk: the text in memory at once is a few tens of MB, whatever
the model's size (the file's text is never held whole)."""


def write_drn(
    model: ExplicitModel,
    target: str | os.PathLike[str] | IO[str],
    *,
    header_comment: str | None = None,
    valuations: bool = False,
    observer: int | str | None = None,
) -> None:
    """Write ``model`` in DRN (atomically when ``target`` is a path), in chunks of states.

    Args:
        model: the model.
        target: a path or an open text stream.
        header_comment: text written as ``//`` comment lines at the top.
        valuations: write each state's variable values as Storm does (a ``//[x=1\\t& y=0]`` line).
        observer: for a POSG whose players observe differently, the player (index or name) whose
            observation ids are written; PAYNT uses only the optimizing player's.

    Raises:
        UnsupportedError: the model holds something DRN cannot carry (see :func:`drn_text`),
            found before anything is written.
        OSError: the file cannot be written (nothing is left behind).
    """
    chunks = iter_drn(
        model, header_comment=header_comment, valuations=valuations, observer=observer
    )
    if not isinstance(target, (str, os.PathLike)):  # an open stream (anything with write)
        for chunk in chunks:
            target.write(chunk)
        return
    from posgmc.io.atomic import atomic_open

    with atomic_open(target) as handle:
        for chunk in chunks:
            handle.write(chunk)


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
    return "".join(
        iter_drn(model, header_comment=header_comment, valuations=valuations, observer=observer)
    )


def iter_drn(
    model: ExplicitModel,
    *,
    header_comment: str | None = None,
    valuations: bool = False,
    observer: int | str | None = None,
    chunk_entries: int = _CHUNK_ENTRIES,
) -> Iterator[str]:
    """The DRN text of ``model`` in pieces: the header, then the states in chunks of about
    ``chunk_entries`` transitions. Every check runs before the first piece is produced.

    Raises:
        UnsupportedError: as :func:`drn_text`.
    """
    num_states = model.num_states
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
        head.append(PLAYERS_PREFIX + " " + " ".join(model.player_names))
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
        str(model.num_choices),
        "@model",
    ]
    tokens = []
    for name in model.action_names:
        if re.search(r"\s", name):
            raise UnsupportedError(
                f'the action name "{name}" contains a space, which DRN cannot carry',
                hint="rename the action",
            )
        tokens.append(name or NOLABEL)
    action_tokens = np.array(tokens, dtype=STR)
    label_names = _label_order(model.labels)
    quoted = [_quote_label(name) for name in label_names]
    # non-finite numbers are refused before any text is produced
    for rm in model.reward_models:
        for values in (rm.state, rm.choice):
            if values is not None and values.size and not np.all(np.isfinite(values)):
                format_values(values[~np.isfinite(values)][:1], what="reward")
    if T.nnz and not np.all(np.isfinite(T.data)):
        format_values(T.data[~np.isfinite(T.data)][:1], what="probability")

    yield "\n".join(head) + "\n"
    # chunk boundaries: states whose transitions add up to about chunk_entries
    entries_before_state = T.indptr[rg].astype(np.int64)
    bounds = np.searchsorted(
        entries_before_state,
        np.arange(0, int(entries_before_state[-1]) + 1, max(1, chunk_entries)),
        side="right",
    )
    cuts = np.unique(np.concatenate([[0], np.clip(bounds, 1, num_states), [num_states]]))
    for s0, s1 in zip(cuts[:-1].tolist(), cuts[1:].tolist()):
        if s1 > s0:
            yield _drn_lines(
                model, s0, s1, observation_ids, action_tokens, label_names, quoted, valuations
            )


def _drn_lines(
    model: ExplicitModel,
    s0: int,
    s1: int,
    observation_ids: np.ndarray | None,
    action_tokens: np.ndarray,
    label_names: list[str],
    quoted: list[str],
    valuations: bool,
) -> str:
    """The lines of states ``s0 .. s1 - 1`` (vectorised over the chunk)."""
    rg = model.row_groups
    T = model.transitions
    c0, c1 = int(rg[s0]), int(rg[s1])
    e0, e1 = int(T.indptr[c0]), int(T.indptr[c1])
    num_states, num_choices, nnz = s1 - s0, c1 - c0, e1 - e0

    # -- state lines -----------------------------------------------------------------------------
    state_line = np.strings.add("state ", np.arange(s0, s1).astype(STR))
    if observation_ids is not None:
        state_line = np.strings.add(
            np.strings.add(np.strings.add(state_line, " {"), observation_ids[s0:s1].astype(STR)),
            "}",
        )
    if model.model_type.is_game:
        state_line = np.strings.add(
            np.strings.add(
                np.strings.add(state_line, " <"), model.state_players[s0:s1].astype(STR)
            ),
            ">",
        )
    if model.reward_models:
        columns = [
            format_values(
                rm.state[s0:s1] if rm.state is not None else np.zeros(num_states), what="reward"
            )
            for rm in model.reward_models
        ]
        state_line = np.strings.add(
            np.strings.add(np.strings.add(state_line, " ["), join_columns(columns, ",")), "]"
        )
    for name, token_text in zip(label_names, quoted):
        token = np.full(num_states, "", dtype=STR)
        token[np.asarray(model.labels[name], dtype=bool)[s0:s1]] = " " + token_text
        state_line = np.strings.add(state_line, token)  # type: ignore[arg-type]  # numpy stubs: str_ only, not StringDType

    # -- action lines ----------------------------------------------------------------------------
    action_line = np.strings.add("\taction ", action_tokens[model.choice_actions[c0:c1]])
    if model.reward_models:
        columns = [
            format_values(
                rm.choice[c0:c1] if rm.choice is not None else np.zeros(num_choices), what="reward"
            )
            for rm in model.reward_models
        ]
        action_line = np.strings.add(
            np.strings.add(np.strings.add(action_line, " ["), join_columns(columns, ",")), "]"
        )

    # -- transition lines ------------------------------------------------------------------------
    trans_line = np.strings.add(
        np.strings.add("\t\t", T.indices[e0:e1].astype(STR)),
        np.strings.add(" : ", format_values(T.data[e0:e1], what="probability")),
    )

    # -- interleave: state s, [valuation], then each choice's action line and its transitions ----
    write_values = valuations and len(model.variable_names) > 0
    per_state = 2 if write_values else 1
    indptr = T.indptr[c0 : c1 + 1].astype(np.int64) - e0
    local_rg = rg[s0 : s1 + 1].astype(np.int64) - c0
    states = np.arange(num_states, dtype=np.int64)
    state_pos = states * per_state + local_rg[:-1] + indptr[local_rg[:-1]]
    choices = np.arange(num_choices, dtype=np.int64)
    action_pos = (
        (model.choice_states[c0:c1].astype(np.int64) - s0 + 1) * per_state + choices + indptr[:-1]
    )
    trans_choice = np.repeat(choices, np.diff(indptr))
    trans_pos = action_pos[trans_choice] + 1 + (np.arange(nnz) - indptr[trans_choice])
    lines = np.empty(num_states * per_state + num_choices + nnz, dtype=STR)
    lines[state_pos] = state_line
    lines[action_pos] = action_line
    lines[trans_pos] = trans_line
    if write_values:
        values = model.state_values[s0:s1]
        columns = [
            np.strings.add(name + "=", values[:, v].astype(STR))
            for v, name in enumerate(model.variable_names)
        ]
        lines[state_pos + 1] = np.strings.add(
            np.strings.add("//[", join_columns(columns, "\t& ")), "]"
        )
    return "\n".join(lines.tolist()) + "\n"


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
