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
from collections.abc import Mapping
from typing import IO

import numpy as np

from posgmc.errors import UnsupportedError
from posgmc.io._text import STR, format_values, join_columns, write_to
from posgmc.io.drn.header import PLAYERS_PREFIX
from posgmc.io.drn.lines import NOLABEL
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import ModelType

__all__ = ["write_drn", "drn_text"]

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
        tokens.append(name or NOLABEL)
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
