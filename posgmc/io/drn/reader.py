"""Read DRN into an :class:`ExplicitModel`: the entry points, and how DRN maps onto the model.

Semantics of the model read:

* ``@type: POSMG`` becomes :attr:`ModelType.POSG`. PAYNT's semantics: the player of the property's
  coalition observes through the ``{z}`` ids, the others see everything. Since the file gives one
  observation per state, every player gets an :class:`Observation` with these ids; the property
  decides which player's observation is used.
* ``player_names`` are ``("0", "1", ...)`` (as many as the largest player index + 1) unless the
  header has a ``//@players: p1 p2`` comment (written by
  :func:`~posgmc.io.drn.writer.write_drn`) naming them.
* The label ``init`` marks the initial states and ``deadlock`` the states whose self-loop was
  added by the exporter.
* ``__NOLABEL__`` is the unlabelled action, and a file whose action tokens are all the choice's
  local index (Storm's output without choice labels) is read as unlabelled.
* State valuations are kept only when every state has a well-formed ``//[...]`` comment with the
  same variables (Storm's exporter writes true Booleans as an empty item, which makes them
  unreadable; such files are read without valuations).

How the lines are parsed, the choices and transitions built and the reward models named: see
:mod:`posgmc.io.drn.body`, :mod:`posgmc.io.drn.transitions` and :mod:`posgmc.io.drn.rewards`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from posgmc.io._text import STR
from posgmc.io.drn.body import (
    Body,
    States,
    check_state_count,
    classify,
    parse_actions,
    parse_states,
    valuations,
)
from posgmc.io.drn.header import PLAYERS_PREFIX, Header, read_header
from posgmc.io.drn.lines import NOLABEL
from posgmc.io.drn.rewards import parse_reward_models
from posgmc.io.drn.source import DrnText
from posgmc.io.drn.transitions import dtmc_choices, nondeterministic_choices, parse_transitions
from posgmc.io.reading import read_text
from posgmc.model.actions import (
    action_signatures,
    conflict_message,
    labels_of,
    observation_action_conflict,
)
from posgmc.model.explicit import ExplicitModel, ModelInvariantError, Observation, make_model
from posgmc.syntax.ast import ModelType

__all__ = ["read_drn", "parse_drn"]


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
    text = read_text(path)  # UTF-8 problems as file:line:col errors
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
    drn = DrnText(text, file)
    nul = text.find("\x00")
    if nul >= 0:  # never valid in DRN, and numpy's strings would drop it silently
        line = text.count("\n", 0, nul) + 1
        column = nul - (text.rfind("\n", 0, nul) + 1) + 1
        raise drn.error("a NUL character is not allowed in a DRN file", line, column, column + 1)
    return _read(drn)


def _read(drn: DrnText) -> ExplicitModel:
    """The model of ``drn``: header, body, choices, transitions, rewards, then make_model."""
    header = read_header(drn)
    model_type = header.model_type
    assert model_type is not None  # read_header guarantees it
    body = classify(drn, header)
    state_idx = np.flatnonzero(body.is_state)
    check_state_count(drn, header, body, state_idx)
    states = parse_states(drn, body, state_idx, model_type)
    action_idx = np.flatnonzero(body.is_action)
    actions = parse_actions(drn, body, action_idx)
    if model_type is ModelType.DTMC:
        choices = dtmc_choices(drn, header, body, state_idx, action_idx, actions)
    else:
        choices = nondeterministic_choices(drn, header, body, state_idx, action_idx, actions)
    transitions = parse_transitions(drn, header, body, choices, num_states=int(state_idx.size))
    choice_actions, action_names = _action_ids(choices.names, choices.row_groups)
    labels = states.labels
    if "init" not in labels:
        raise drn.whole_line_error(
            "no state is labelled init",
            body.line(state_idx[0]),
            hint="add the label init to the initial state, e.g. 'state 0 init'",
        )
    reward_models = parse_reward_models(drn, header, model_type, states, actions, choices)
    players, player_names = _players(drn, states, model_type, header)
    variable_names, state_values = valuations(body, state_idx)
    observations = _observations(states, model_type, player_names)
    _check_observed_actions(
        drn, body, state_idx, observations, players, player_names, model_type,
        choice_actions, choices.row_groups, action_names,
    )
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
            observations=observations,
            labels=labels,
            reward_models=reward_models,
            variable_names=variable_names,
            state_values=state_values,
            deadlocks=np.flatnonzero(labels["deadlock"]) if "deadlock" in labels else None,
        )
    except ModelInvariantError as e:  # pragma: no cover - every invariant is checked above
        raise drn.whole_line_error(f"invalid model: {e.message}", header.model_line) from None


def _check_observed_actions(
    drn: DrnText,
    body: Body,
    state_idx: np.ndarray,
    observations: tuple[Observation, ...],
    players: np.ndarray,
    player_names: tuple[str, ...],
    model_type: ModelType,
    choice_actions: np.ndarray,
    row_groups: np.ndarray,
    action_names: tuple[str, ...],
) -> None:
    """States a player cannot tell apart offer the same actions, as in a PRISM model
    (:mod:`posgmc.model.actions`); with no action labels at all, the same number of choices."""
    if not observations:
        return
    if action_names == ("",):
        signatures = np.diff(row_groups).astype(np.int64).reshape(-1, 1)
    else:
        signatures = action_signatures(choice_actions, row_groups, len(action_names))
    for obs in observations:
        owned = (
            np.flatnonzero(players == obs.player)
            if model_type.is_game
            else np.arange(players.size)
        )
        conflict = observation_action_conflict(obs.state_ids, owned, signatures)
        if conflict is None:
            continue
        s, t = conflict
        if action_names == ("",):
            a_s = {f"{int(signatures[s, 0])} choices"}
            a_t = {f"{int(signatures[t, 0])} choices"}
        else:
            a_s = labels_of(signatures[s], action_names)
            a_t = labels_of(signatures[t], action_names)
        who = f"player {player_names[obs.player]}" if model_type.is_game else "the agent"
        message, hint = conflict_message(str(s), str(t), who, int(obs.state_ids[s]), a_s, a_t)
        raise drn.whole_line_error(message, body.line(state_idx[t]), hint=hint)


def _players(
    drn: DrnText, states: States, model_type: ModelType, header: Header
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
        raise drn.whole_line_error(
            f"the {PLAYERS_PREFIX} comment must name {num_players} distinct players "
            f"(players 0 to {num_players - 1} own states)",
            header.players_line,
        )
    return players.astype(np.int32), names


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
    tokens[tokens == NOLABEL] = ""
    uniq, first, inverse = np.unique(tokens, return_index=True, return_inverse=True)
    ordered = [str(u) for u in uniq[np.argsort(first, kind="stable")]]
    action_names = ("",) + tuple(n for n in ordered if n)
    position = {n: i for i, n in enumerate(action_names)}
    lookup = np.array([position[str(u)] for u in uniq], dtype=np.int32)
    return lookup[inverse.ravel()], action_names


def _observations(
    states: States, model_type: ModelType, player_names: tuple[str, ...]
) -> tuple[Observation, ...]:
    if not model_type.is_partially_observable or states.observation is None:
        return ()
    ids = states.observation.astype(np.int32)  # the parsers keep ids below 2^31
    values = np.zeros((int(ids.max()) + 1, 0), dtype=np.int64)
    players = range(len(player_names)) if model_type.is_game else range(1)
    return tuple(Observation(p, ids, (), values) for p in players)
