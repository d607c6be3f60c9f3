"""Compiled passes of the graph analysis (:mod:`posgmc.engines.graph`): the transposed pattern,
the attractor as one backward worklist search, and the per-choice "leaves the region" test.

Every function here is a :func:`~posgmc.engines.kernels.compiled` kernel over plain arrays; the
caller (``graph.py``) chooses the dtypes (int32 where the indices fit), passes every input
read-only (one compiled variant per dtype combination) and keeps the numpy path for when
:func:`~posgmc.engines.kernels.enabled` is False. Large outputs are allocated inside the kernels
(see :func:`_transpose_pattern` on why). The arrays are those of
:class:`~posgmc.engines.graph.Structure`: ``indptr``/``indices`` the csr
pattern of the choice matrix [C, S], ``back_ptr``/``back_choices`` its transpose (for state t the
choices with an edge into t), ``row_groups`` int64[S + 1], ``choice_state`` [C].

The attractor search (:func:`attract`) is the classical linear-time one (e.g. Baier & Katoen,
*Principles of Model Checking*, algorithm 46 for Prob0, and the attractor of turn-based games):
a queue of states that have joined, and per state a counter of the choices still to be hit
before it joins (1 for a state of the attracting player, its number of allowed choices for the
other player's); every choice is hit at most once, so the work is O(S + C + transitions) whatever
the number of layers. States are taken from the queue in the order they joined, so the layer of a
state (the round of the layered search in which it joins) is one more than the layer of the state
whose processing completed its counter, exactly the layers of the numpy search.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled

__all__ = ["transpose_pattern", "attract", "leaving_choices", "restrict_to_region"]


def _transpose_pattern(
    indptr: np.ndarray,
    indices: np.ndarray,
    row_groups: np.ndarray,
    ptr_type: np.ndarray,
    choice_type: np.ndarray,
    state_type: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(back_ptr, back_choices, choice_state)`` of a csr pattern ``indptr``/``indices`` whose
    rows are grouped by ``row_groups``: the transpose by a counting sort (choices ascending per
    state, ``back_ptr`` itself the fill pointer), and the state of every row. The ``*_type``
    arguments are empty arrays of the wanted dtypes.

    The outputs are allocated here, by numba's allocator, not by numpy: numpy asks the kernel for
    transparent huge pages on large arrays, and on a machine whose memory is fragmented their
    first touch (the kernel compacting memory) cost 3-5 times the system time of small pages."""
    num_rows = indptr.size - 1
    num_cols = row_groups.size - 1
    back_ptr = np.zeros(num_cols + 1, dtype=ptr_type.dtype)
    back_choices = np.empty(indices.size, dtype=choice_type.dtype)
    choice_state = np.empty(num_rows, dtype=state_type.dtype)
    for s in range(num_cols):
        for c in range(row_groups[s], row_groups[s + 1]):
            choice_state[c] = s
    for k in range(indices.size):
        back_ptr[indices[k]] += 1
    total = 0
    for t in range(num_cols):  # counts -> starts
        count = back_ptr[t]
        back_ptr[t] = total
        total += count
    for c in range(num_rows):
        for k in range(indptr[c], indptr[c + 1]):
            t = indices[k]
            back_choices[back_ptr[t]] = c
            back_ptr[t] += 1
    for t in range(num_cols, 0, -1):  # each entry now holds the next state's start
        back_ptr[t] = back_ptr[t - 1]
    back_ptr[0] = 0
    return back_ptr, back_choices, choice_state


transpose_pattern = compiled(_transpose_pattern)


def _attract(
    back_ptr: np.ndarray,
    back_choices: np.ndarray,
    row_groups: np.ndarray,
    choice_state: np.ndarray,
    existential: np.ndarray,
    open_: np.ndarray,
    allowed: np.ndarray,
    use_allowed: bool,
    extra_choices: np.ndarray,
    preferred: np.ndarray,
    use_preferred: bool,
    inside: np.ndarray,
    layer: np.ndarray,
    use_layer: bool,
) -> np.ndarray:
    """The attractor of ``inside`` (updated in place), as one backward worklist search; returns
    the witnesses, int64[S]: for every joined state a choice that hit the set in the layer where
    it joined, -1 elsewhere (allocated here: see :func:`_transpose_pattern` on numpy's huge
    pages).

    Args:
        back_ptr, back_choices, row_groups, choice_state: the structure (module docstring).
        existential: bool[S], the states that join with one hitting choice (the others need all
            their allowed choices to hit).
        open_: bool[S], the states that may still join (candidates outside ``inside``); cleared
            in place as states join.
        allowed: bool[C], read only with ``use_allowed``: the choices that may hit.
        extra_choices: int64[k], choices that hit from the start (a target outside the graph).
        preferred: int64[S], read only with ``use_preferred``: the witness to report for a state
            when it is hit in the layer where the state joins.
        inside: bool[S], the set to attract to on entry, the attractor on exit.
        layer: int64[S], written only with ``use_layer``: 0 for the states of the initial set,
            the layer where each joined state joined.
    """
    num_states = row_groups.size - 1
    witness = np.full(num_states, -1, dtype=np.int64)
    # choices still to be hit before a state joins; a state with none allowed never joins
    remaining = np.zeros(num_states, dtype=np.int32)
    num_open = 0
    for s in range(num_states):
        if inside[s]:
            if use_layer:
                layer[s] = 0
            continue
        if not open_[s]:
            continue
        if existential[s]:
            need = 1
        elif use_allowed:
            need = 0
            for c in range(row_groups[s], row_groups[s + 1]):
                if allowed[c]:
                    need += 1
        else:
            need = row_groups[s + 1] - row_groups[s]
        if need == 0:
            open_[s] = False
        else:
            remaining[s] = need
            num_open += 1
    if num_open == 0:
        return witness
    # the states in the order they joined (initial ones first); the layer of each state is
    # tracked by the queue's segments: queue[head:level_end] is the current layer
    queue = np.empty(num_states, dtype=choice_state.dtype)
    tail = 0
    for s in range(num_states):
        if inside[s]:
            queue[tail] = s
            tail += 1
    # the layer where each state joined, kept only to recognise a preferred choice in time
    joined = np.zeros(num_states if use_preferred else 0, dtype=np.int32)
    hit = np.zeros(choice_state.size, dtype=np.bool_)
    head = 0
    level_end = tail
    level = 1  # the layer that a state completed by the choices hit now joins in
    # the extra choices hit in the first layer, as the edges into the initial set do
    for i in range(extra_choices.size):
        c = extra_choices[i]
        if hit[c] or (use_allowed and not allowed[c]):
            continue
        hit[c] = True
        s = choice_state[c]
        if open_[s]:
            remaining[s] -= 1
            if remaining[s] == 0:
                open_[s] = False
                inside[s] = True
                witness[s] = c
                if use_layer:
                    layer[s] = 1
                if use_preferred:
                    joined[s] = 1
                queue[tail] = s
                tail += 1
                num_open -= 1
        elif use_preferred and joined[s] == 1 and preferred[s] == c:
            witness[s] = c
    last = 1  # the latest layer a state joined in
    while head < tail:
        if head == level_end:
            level += 1
            level_end = tail
        # nobody left to join: stop, unless a preferred choice may still be hit in the last layer
        if num_open == 0 and not (use_preferred and level <= last):
            break
        t = queue[head]
        head += 1
        for k in range(back_ptr[t], back_ptr[t + 1]):
            c = back_choices[k]
            if hit[c] or (use_allowed and not allowed[c]):
                continue
            hit[c] = True
            s = choice_state[c]
            if open_[s]:
                remaining[s] -= 1
                if remaining[s] == 0:
                    open_[s] = False
                    inside[s] = True
                    witness[s] = c
                    if use_layer:
                        layer[s] = level
                    if use_preferred:
                        joined[s] = level
                    last = level
                    queue[tail] = s
                    tail += 1
                    num_open -= 1
            elif use_preferred and joined[s] == level and preferred[s] == c:
                witness[s] = c
    return witness


attract = compiled(_attract)


def _leaving_choices(indptr: np.ndarray, indices: np.ndarray, region: np.ndarray) -> np.ndarray:
    """bool[C]: choice c has an edge to a state outside ``region`` (bool[S])."""
    out = np.empty(indptr.size - 1, dtype=np.bool_)
    for c in range(indptr.size - 1):
        leaves = False
        for k in range(indptr[c], indptr[c + 1]):
            if not region[indices[k]]:
                leaves = True
                break
        out[c] = leaves
    return out


leaving_choices = compiled(_leaving_choices)


def _restrict_to_region(
    indptr: np.ndarray,
    indices: np.ndarray,
    row_groups: np.ndarray,
    region: np.ndarray,
    usable: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One round's restriction of the almost-sure search, in one pass over the states of
    ``region`` (bool[S]): returns ``(safe, leaks)``, ``safe[c]`` (bool[C]) = c is usable and stays
    in the region, ``leaks[s]`` (bool[S]) = a usable choice of s leaves it. Both are False for
    the states outside the region (the caller never reads them there)."""
    safe = np.zeros(indptr.size - 1, dtype=np.bool_)
    leaks = np.zeros(row_groups.size - 1, dtype=np.bool_)
    for s in range(row_groups.size - 1):
        if not region[s]:
            continue
        any_leak = False
        for c in range(row_groups[s], row_groups[s + 1]):
            if not usable[c]:
                continue
            stays = True
            for k in range(indptr[c], indptr[c + 1]):
                if not region[indices[k]]:
                    stays = False
                    break
            safe[c] = stays
            if not stays:
                any_leak = True
        leaks[s] = any_leak
    return safe, leaks


restrict_to_region = compiled(_restrict_to_region)
