"""Which actions each state offers, and the rule that states a player cannot tell apart offer the
same ones (PRISM's POMDP check: "states with the same observation must have the same actions").

One definition for every input: the PRISM compiler (:mod:`posgmc.compiler.assemble`) and the DRN
reader (:mod:`posgmc.io.drn.reader`) both call :func:`observation_action_conflict` and word the
error with :func:`conflict_message`.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "INDEX_PREFIX",
    "action_signatures",
    "choices_by_index",
    "conflict_message",
    "labels_of",
    "observation_action_conflict",
]

INDEX_PREFIX = "#"
"""A choice named by its local index: ``#0`` is the first choice of its state."""


def action_signatures(
    choice_actions: np.ndarray, row_groups: np.ndarray, num_actions: int
) -> np.ndarray:
    """int64[S, W]: bit sets of the action labels offered in each state (62 labels per word).

    Args:
        choice_actions: int[C], the action id of each choice (0: unlabelled).
        row_groups: int[S + 1], the choices of state s are ``row_groups[s]:row_groups[s+1]``.
        num_actions: the number of action ids.
    """
    num_words = max(1, -(-num_actions // 62))
    starts = row_groups[:-1]
    out = np.empty((starts.size, num_words), dtype=np.int64)
    word = choice_actions // 62
    bit = np.left_shift(np.int64(1), (choice_actions % 62).astype(np.int64))
    for w in range(num_words):
        bits = np.where(word == w, bit, 0)
        out[:, w] = np.bitwise_or.reduceat(bits, starts)
    return out


def labels_of(signature: np.ndarray, action_names: tuple[str, ...]) -> set[str]:
    """The action labels (``[name]``) set in one state's signature."""
    out = set()
    for a, name in enumerate(action_names):
        if (int(signature[a // 62]) >> (a % 62)) & 1:
            out.add(f"[{name}]")
    return out


def observation_action_conflict(
    ids: np.ndarray, states: np.ndarray, signatures: np.ndarray
) -> tuple[int, int] | None:
    """The first pair (s, t) of ``states`` with the same observation id and different action
    signatures (s the first state of that observation), or None.

    Args:
        ids: int[S], each state's observation id.
        states: the states the check covers (a player's own states in a game).
        signatures: int64[S, W] from :func:`action_signatures` (or any per-state rows to compare).
    """
    if states.size == 0:
        return None
    z = ids[states]
    _, first = np.unique(z, return_index=True)
    rep_of_z = np.full(int(ids.max()) + 1, -1, dtype=np.int64)
    rep_of_z[z[first]] = states[first]
    rep = rep_of_z[z]
    differ = np.any(signatures[states] != signatures[rep], axis=1)
    if not differ.any():
        return None
    k = int(np.flatnonzero(differ)[0])
    return int(rep[k]), int(states[k])


def conflict_message(
    s_text: str, t_text: str, who: str, observation: int, a_s: set[str], a_t: set[str]
) -> tuple[str, str]:
    """(message, hint) of an observation-action conflict between states s and t."""
    message = (
        f"states {s_text} and {t_text} look the same to {who} (observation {observation}) but "
        f"offer different actions: {', '.join(sorted(a_s - a_t)) or 'none'} only in the first, "
        f"{', '.join(sorted(a_t - a_s)) or 'none'} only in the second"
    )
    hint = (
        "states with the same observation must enable the same action labels; observe more "
        "or make the commands' guards depend only on observed values"
    )
    return message, hint


def _shared_labels(
    actions: np.ndarray,
    row_groups: np.ndarray,
    sizes: np.ndarray,
    state_of: np.ndarray,
    widest: int,
    num_actions: int,
) -> np.ndarray:
    """bool[C]: choices whose label another choice of their state has. States of a few choices
    (the usual case) compare each choice with the ones 1, 2, ... places after it, in passes over
    the whole array; wider ones sort the (state, label) pairs."""
    clash = np.zeros(actions.size, dtype=bool)
    if widest <= 8:
        local = np.arange(actions.size) - row_groups[state_of]
        room = sizes[state_of] - local  # choices from this one to the state's end
        for d in range(1, widest):
            idx = np.flatnonzero(room > d)
            same = idx[actions[idx] == actions[idx + d]]
            clash[same] = True
            clash[same + d] = True
        return clash
    pair = state_of * max(1, num_actions) + actions
    order = np.argsort(pair, kind="stable")
    ordered = pair[order]
    same_sorted = ordered[1:] == ordered[:-1]
    clash[order[1:][same_sorted]] = True
    clash[order[:-1][same_sorted]] = True
    return clash


def choices_by_index(
    choice_actions: np.ndarray, row_groups: np.ndarray, action_names: tuple[str, ...]
) -> tuple[np.ndarray, tuple[str, ...]] | None:
    """Names a strategy can use for every choice: a choice whose label is unique in its state
    keeps it; choices that share a label in their state (unlabelled ones included, as in a DRN
    POMDP without choice labels, e.g. Cassandra's hallway) are named by their local index,
    ``#0``, ``#1``, ..., as Storm and PAYNT name choices. None when no state has such choices.

    Returns:
        The new choice action ids and action names (the old names first, then the ``#k`` names
        that are not among them, by k).
    """
    if choice_actions.size == 0:
        return None
    sizes = np.diff(row_groups)
    widest = int(sizes.max(initial=0))
    if widest <= 1:
        return None
    state_of = np.repeat(np.arange(sizes.size, dtype=np.int64), sizes)
    clash = _shared_labels(choice_actions, row_groups, sizes, state_of, widest, len(action_names))
    if not clash.any():
        return None
    local = np.arange(choice_actions.size) - row_groups[state_of]
    ks = np.unique(local[clash]).tolist()
    names = list(action_names)
    position = {n: i for i, n in enumerate(names)}
    ids = np.empty(max(ks) + 1, dtype=np.int64)
    for k in ks:
        name = f"{INDEX_PREFIX}{k}"
        if name not in position:
            position[name] = len(names)
            names.append(name)
        ids[k] = position[name]
    out = choice_actions.astype(np.int64, copy=True)
    out[clash] = ids[local[clash]]
    return out.astype(choice_actions.dtype), tuple(names)
