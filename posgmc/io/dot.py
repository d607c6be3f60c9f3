"""Draw a small :class:`ExplicitModel` as a Graphviz DOT graph (to look at, not to read back).

States are nodes labelled with their number, their valuation, their observation ids and their
labels (comma-separated, init and deadlock first);
initial states have a double border. In games the owner is shown by the shape: player 0 a circle,
player 1 a box, player 2 a diamond (then hexagon, octagon, triangle), as in PRISM-games' pictures
of turn-based games. In nondeterministic models each choice is a small point joined to its state
by an undirected edge carrying the action name, and the point's edges carry the probabilities;
in a DTMC the state's edges carry the probabilities directly. The drawing is meant for a few
hundred states; larger models are refused (``max_states``).
"""

from __future__ import annotations

import os
from typing import IO

import numpy as np

from posgmc.errors import UnsupportedError
from posgmc.io._text import format_values, write_to
from posgmc.model.explicit import ExplicitModel

__all__ = ["write_dot", "dot_text"]

_SHAPES = ("circle", "box", "diamond", "hexagon", "octagon", "triangle")


def write_dot(
    model: ExplicitModel,
    target: str | os.PathLike[str] | IO[str],
    *,
    max_states: int = 1000,
) -> None:
    """Write the DOT picture of ``model`` to a stream, or atomically to a file.

    Args:
        model: the model.
        target: an open text stream or a path.
        max_states: refuse models with more states than this (a drawing of them is unreadable).

    Raises:
        UnsupportedError: the model has more than ``max_states`` states, or non-finite numbers.
        OSError: the file cannot be written.
    """
    write_to(target, dot_text(model, max_states=max_states))


def dot_text(model: ExplicitModel, *, max_states: int = 1000) -> str:
    """The DOT text :func:`write_dot` writes (see it for the arguments)."""
    num_states = model.num_states
    if num_states > max_states:
        raise UnsupportedError(
            f"the model has {num_states} states; DOT pictures are limited to {max_states}",
            hint="pass a larger max_states (the picture will be hard to read), "
            "or export DRN or PRISM explicit files instead",
        )
    T = model.transitions
    rg = model.row_groups
    probabilities = format_values(T.data, what="probability").tolist()
    game = model.model_type.is_game
    nondeterministic = model.model_type.is_nondeterministic
    label_names = [n for n in ("init", "deadlock") if n in model.labels]
    label_names += [n for n in model.labels if n not in ("init", "deadlock")]
    label_sets = (
        np.stack([np.asarray(model.labels[n], dtype=bool) for n in label_names])
        if label_names
        else None
    )
    observations = [
        (model.player_names[o.player] if model.player_names else "", o.state_ids)
        for o in model.observations
    ]
    init = np.zeros(num_states, dtype=bool)
    init[model.initial_states] = True

    out = [
        "digraph model {",
        "  rankdir=LR;",
        '  node [fontname="Helvetica", fontsize=10];',
        '  edge [fontname="Helvetica", fontsize=9];',
    ]
    # Bounded by max_states, so plain loops are fine here.
    for s in range(num_states):
        parts = [str(s)]
        if model.variable_names:
            values = zip(model.variable_names, model.state_values[s].tolist())
            parts.append("(" + ",".join(f"{n}={v}" for n, v in values) + ")")
        for owner, ids in observations:
            parts.append(f"z{'_' + owner if owner else ''}={ids[s]}")
        if label_sets is not None:
            names = [label_names[k] for k in np.flatnonzero(label_sets[:, s])]
            if names:
                parts.append(", ".join(names))
        shape = _SHAPES[int(model.state_players[s]) % len(_SHAPES)] if game else "circle"
        attributes = [f"label={_quote(chr(10).join(parts))}", f"shape={shape}"]
        if game:
            attributes.append(f"tooltip={_quote('player ' + _player(model, s))}")
        if init[s]:
            attributes.append("peripheries=2")
        out.append(f"  s{s} [{', '.join(attributes)}];")
    for s in range(num_states):
        for c in range(int(rg[s]), int(rg[s + 1])):
            action = model.action_names[int(model.choice_actions[c])]
            if nondeterministic:
                out.append(f'  c{c} [shape=point, width=0.08, label=""];')
                out.append(f"  s{s} -> c{c} [arrowhead=none, label={_quote(action)}];")
                origin = f"c{c}"
            else:
                origin = f"s{s}"
            for k in range(int(T.indptr[c]), int(T.indptr[c + 1])):
                text = probabilities[k]
                if not nondeterministic and action:
                    text += f" : {action}"
                out.append(f"  {origin} -> s{int(T.indices[k])} [label={_quote(text)}];")
    out.append("}")
    return "\n".join(out) + "\n"


def _player(model: ExplicitModel, s: int) -> str:
    p = int(model.state_players[s])
    return model.player_names[p] if p < len(model.player_names) else str(p)


def _quote(text: str) -> str:
    """A DOT double-quoted string; newlines become DOT's centred line breaks."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'
