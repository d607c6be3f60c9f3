"""Export an :class:`ExplicitModel` to PRISM's explicit files (``.tra .sta .lab .srew .trew .obs``).

The layout follows PRISM-games' own exporter (``prism/src/io/PrismExplicitExporter.java``), with its
optional ``#`` header lines, so that ``prism -importmodel base.all`` (or the files one by one) reads
what is written here. Numbers are written exactly (shortest round-trip form; integers plainly).

``base.tra`` — transitions, one line per (choice, target), sorted by state, choice, target::

    dtmc      S T                 then  s t p [action]
    mdp       S C T               then  s j t p [action]          (j: choice index within s)
    pomdp     S C T O             then  "- - s - o" per initial state, then s j t p o(t) [action]
    smg       S:P C T             then  s:p j t p [action]        (p: 0-based owner of s)

``base.sta`` — ``(x,y)`` then ``s:(1,0)`` per state (written when the model has variables;
Booleans are written as 0/1 since the compiled model keeps integers only).
``base.lab`` — ``0="init" 1="deadlock" 2="goal"`` then ``s: 0 2`` for each state with a label.
``base.srew`` / ``base.trew`` — per reward structure (``base1.srew``, ``base2.srew``, ... when
there are several, as PRISM names them): ``S nnz`` then ``s r``; ``S C nnz`` then ``s j t r`` (dtmc:
``S nnz`` then ``s t r``), the choice's reward repeated on each of its transitions as PRISM does.
``base.obs`` (pomdp) — ``(o1,o2)`` then ``z:(v1,v2)``: the observable values of each id.

posgmc's extension for **posg** (PRISM-games has no such model type): ``base.tra`` is written in
the smg layout with the header ``# Transitions (SMG)``, so PRISM-games reads the underlying
fully observable game, followed by a comment line saying so. The observations go to
``base.pobs``::

    # Player observations
    (p1,p2)                       the players who observe partially, in player order
    s:(z1,z2)                     the observation id of state s for each of them

and each such player's observable values to ``base.<player>.obs`` in the ``.obs`` layout above.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from posgmc.errors import UnsupportedError
from posgmc.io._text import STR, format_values, join_columns
from posgmc.io.atomic import atomic_open
from posgmc.model.explicit import ExplicitModel, Observation
from posgmc.syntax.ast import ModelType

__all__ = ["write_prism_explicit", "prism_explicit_texts"]

_TYPE_HEADER = {
    ModelType.DTMC: "DTMC",
    ModelType.MDP: "MDP",
    ModelType.POMDP: "POMDP",
    ModelType.SMG: "SMG",
    ModelType.POSG: "SMG",
}


def write_prism_explicit(
    model: ExplicitModel, basename: str | os.PathLike[str], *, headers: bool = True
) -> tuple[Path, ...]:
    """Write ``model`` to PRISM explicit files named ``basename`` + extension.

    Every file is built in memory first and then written atomically, so an error leaves no file
    changed.

    Args:
        model: the model.
        basename: path without extension, e.g. ``out/model`` for ``out/model.tra`` etc.
        headers: write PRISM's optional ``# ...`` header lines.

    Returns:
        The paths written, ``.tra`` first.

    Raises:
        UnsupportedError: non-finite numbers, or a label containing a double quote.
        OSError: a file cannot be written.
    """
    texts = prism_explicit_texts(model, basename, headers=headers)
    for path, text in texts.items():
        with atomic_open(path) as handle:
            handle.write(text)
    return tuple(texts)


def prism_explicit_texts(
    model: ExplicitModel, basename: str | os.PathLike[str], *, headers: bool = True
) -> dict[Path, str]:
    """The file contents :func:`write_prism_explicit` writes, by path (see it for the arguments)."""
    base = os.fspath(basename)
    files: dict[Path, str] = {Path(base + ".tra"): _transitions(model, headers=headers)}
    if model.variable_names:
        files[Path(base + ".sta")] = _states(model, headers=headers)
    files[Path(base + ".lab")] = _labels(model, headers=headers)
    many = len(model.reward_models) > 1
    for r in range(len(model.reward_models)):
        stem = f"{base}{r + 1}" if many else base
        files[Path(stem + ".srew")] = _state_rewards(model, r, headers=headers)
        files[Path(stem + ".trew")] = _transition_rewards(model, r, headers=headers)
    if model.model_type is ModelType.POMDP:
        files[Path(base + ".obs")] = _observation_values(model.observations[0], headers=headers)
    elif model.model_type is ModelType.POSG and model.observations:
        files[Path(base + ".pobs")] = _player_observations(model, headers=headers)
        for obs in model.observations:
            name = model.player_names[obs.player] if model.player_names else str(obs.player)
            files[Path(f"{base}.{name}.obs")] = _observation_values(obs, headers=headers)
    return files


def _ints(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.int64).astype(STR)


def _lines(head: list[str], body: np.ndarray) -> str:
    return "\n".join(head + body.tolist()) + "\n"


def _transitions(model: ExplicitModel, *, headers: bool) -> str:
    T = model.transitions
    mt = model.model_type
    indptr = T.indptr.astype(np.int64)
    trans_choice = np.repeat(np.arange(model.num_choices, dtype=np.int64), np.diff(indptr))
    source = model.choice_states[trans_choice]
    local = trans_choice - model.row_groups[source]
    head: list[str] = []
    if headers:
        head.append(f"# Transitions ({_TYPE_HEADER[mt]})")
        if mt is ModelType.POSG:
            head.append(
                "# posgmc: a partially observable game written as its fully observable SMG; "
                "the observations are in the .pobs file"
            )
    sizes = [str(model.num_states)]
    if mt.is_game:
        sizes[0] += f":{len(model.player_names)}"
    if mt.is_nondeterministic:
        sizes.append(str(model.num_choices))
    sizes.append(str(T.nnz))
    if mt is ModelType.POMDP:
        sizes.append(str(model.observations[0].num_observations))
    head.append(" ".join(sizes))

    src = _ints(source)
    if mt.is_game:
        src = join_columns([src, _ints(model.state_players[source])], ":")
    columns = [src]
    if mt.is_nondeterministic:
        columns.append(_ints(local))
    columns += [_ints(T.indices), format_values(T.data, what="probability")]
    if mt is ModelType.POMDP:
        ids = model.observations[0].state_ids
        columns.append(_ints(ids[T.indices]))
        init = model.initial_states
        head += [f"- - {s} - {ids[s]}" for s in init.tolist()]
    body = join_columns(columns, " ")
    actions = np.array(model.action_names, dtype=STR)[model.choice_actions[trans_choice]]
    labelled = np.strings.str_len(actions) > 0
    body[labelled] = np.strings.add(np.strings.add(body[labelled], " "), actions[labelled])
    return _lines(head, body)


def _states(model: ExplicitModel, *, headers: bool) -> str:
    head = ["# States"] if headers else []
    head.append("(" + ",".join(model.variable_names) + ")")
    columns = [_ints(model.state_values[:, v]) for v in range(len(model.variable_names))]
    values = join_columns(columns, ",")
    body = np.strings.add(
        np.strings.add(_ints(np.arange(model.num_states)), ":("), np.strings.add(values, ")")
    )
    return _lines(head, body)


def _labels(model: ExplicitModel, *, headers: bool) -> str:
    names = [n for n in ("init", "deadlock") if n in model.labels]
    names += [n for n in model.labels if n not in ("init", "deadlock")]
    for name in names:
        if '"' in name or not name:
            raise UnsupportedError(
                f"the label {name!r} cannot be written in a PRISM .lab file",
                hint="rename the label",
            )
    head = ["# Labels"] if headers else []
    head.append(" ".join(f'{i}="{n}"' for i, n in enumerate(names)))
    acc = np.full(model.num_states, "", dtype=STR)
    for i, name in enumerate(names):
        token = np.full(model.num_states, "", dtype=STR)
        token[np.asarray(model.labels[name], dtype=bool)] = f" {i}"
        acc = np.strings.add(acc, token)
    has = np.strings.str_len(acc) > 0
    states = np.flatnonzero(has)
    body = np.strings.add(np.strings.add(_ints(states), ":"), acc[has])  # type: ignore[arg-type]  # numpy stubs: str_ only, not StringDType
    return _lines(head, body)


def _reward_header(name: str | None, kind: str) -> list[str]:
    title = "# Reward structure" + (f' "{name}"' if name else "")
    return [title, f"# {kind} rewards"]


def _state_rewards(model: ExplicitModel, r: int, *, headers: bool) -> str:
    rm = model.reward_models[r]
    values = rm.state if rm.state is not None else np.zeros(model.num_states)
    nonzero = np.flatnonzero(values)
    head = _reward_header(rm.name, "State") if headers else []
    head.append(f"{model.num_states} {nonzero.size}")
    body = join_columns([_ints(nonzero), format_values(values[nonzero], what="reward")], " ")
    return _lines(head, body)


def _transition_rewards(model: ExplicitModel, r: int, *, headers: bool) -> str:
    rm = model.reward_models[r]
    T = model.transitions
    choice_values = rm.choice if rm.choice is not None else np.zeros(model.num_choices)
    indptr = T.indptr.astype(np.int64)
    trans_choice = np.repeat(np.arange(model.num_choices, dtype=np.int64), np.diff(indptr))
    values = choice_values[trans_choice]
    keep = np.flatnonzero(values)
    source = model.choice_states[trans_choice[keep]]
    head = _reward_header(rm.name, "Transition") if headers else []
    columns = [_ints(source)]
    if model.model_type.is_nondeterministic:
        head.append(f"{model.num_states} {model.num_choices} {keep.size}")
        columns.append(_ints(trans_choice[keep] - model.row_groups[source]))
    else:
        head.append(f"{model.num_states} {keep.size}")
    columns += [_ints(T.indices[keep]), format_values(values[keep], what="reward")]
    return _lines(head, join_columns(columns, " "))


def _observation_values(obs: Observation, *, headers: bool) -> str:
    head = ["# Observations"] if headers else []
    head.append("(" + ",".join(obs.names) + ")")
    count = obs.num_observations
    if obs.names:
        values = join_columns([_ints(obs.values[:, k]) for k in range(len(obs.names))], ",")
    else:
        values = np.full(count, "", dtype=STR)
    body = np.strings.add(
        np.strings.add(_ints(np.arange(count)), ":("), np.strings.add(values, ")")
    )
    return _lines(head, body)


def _player_observations(model: ExplicitModel, *, headers: bool) -> str:
    observations = sorted(model.observations, key=lambda o: o.player)
    names = [model.player_names[o.player] for o in observations]
    head = ["# Player observations"] if headers else []
    head.append("(" + ",".join(names) + ")")
    ids = join_columns([_ints(o.state_ids) for o in observations], ",")
    body = np.strings.add(
        np.strings.add(_ints(np.arange(model.num_states)), ":("), np.strings.add(ids, ")")
    )
    return _lines(head, body)
