"""Compiled passes of the graph analysis (:mod:`posgmc.engines.graph`): the transposed pattern,
the attractor as one backward worklist search, and the per-choice "leaves the region" test.

Every function here is a :func:`~posgmc.engines.kernels.compiled` kernel over plain arrays; the
caller (``graph.py``) allocates the outputs, so it chooses their dtypes (int32 where the indices
fit), and keeps the numpy path for when :func:`~posgmc.engines.kernels.enabled` is False. The
arrays are those of :class:`~posgmc.engines.graph.Structure`: ``indptr``/``indices`` the csr
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
    indptr: np.ndarray, indices: np.ndarray, back_ptr: np.ndarray, back_choices: np.ndarray
) -> None:
    """Fill ``back_ptr`` (zeros on entry, [S + 1]) and ``back_choices`` ([nnz]) with the transpose
    of the csr pattern ``indptr``/``indices``: a counting sort, choices ascending per state."""
    num_rows = indptr.size - 1
    num_cols = back_ptr.size - 1
    for k in range(indices.size):
        back_ptr[indices[k] + 1] += 1
    for t in range(num_cols):
        back_ptr[t + 1] += back_ptr[t]
    fill = back_ptr[:num_cols].copy()
    for c in range(num_rows):
        for k in range(indptr[c], indptr[c + 1]):
            t = indices[k]
            back_choices[fill[t]] = c
            fill[t] += 1


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
    witness: np.ndarray,
    layer: np.ndarray,
    use_layer: bool,
) -> None:
    """The attractor of ``inside`` (updated in place), as one backward worklist search.

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
        witness: int64[S], -1 on entry; on exit for every joined state a choice that hit the set
            in the layer where it joined.
        layer: int64[S], written only with ``use_layer``: 0 for the states of the initial set,
            the layer where each joined state joined.
    """
    num_states = row_groups.size - 1
    # choices still to be hit before a state joins; a state with none allowed never joins
    remaining = np.zeros(num_states, dtype=np.int64)
    depth = np.zeros(num_states, dtype=np.int64)
    queue = np.empty(num_states, dtype=np.int64)
    head = 0
    tail = 0
    num_open = 0
    for s in range(num_states):
        if inside[s]:
            queue[tail] = s
            tail += 1
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
        return
    hit = np.zeros(choice_state.size, dtype=np.bool_)
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
                depth[s] = 1
                queue[tail] = s
                tail += 1
                num_open -= 1
        elif use_preferred and inside[s] and depth[s] == 1 and preferred[s] == c:
            witness[s] = c
    last = 1  # the latest layer a state joined in
    while head < tail:
        t = queue[head]
        level = depth[t] + 1
        # nobody left to join: stop, unless a preferred choice may still be hit in the last layer
        if num_open == 0 and not (use_preferred and level <= last):
            break
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
                    depth[s] = level
                    last = level
                    queue[tail] = s
                    tail += 1
                    num_open -= 1
            elif use_preferred and depth[s] == level and preferred[s] == c and inside[s]:
                witness[s] = c
    if use_layer:
        for i in range(tail):
            s = queue[i]
            if depth[s] > 0:
                layer[s] = depth[s]


attract = compiled(_attract)


def _leaving_choices(
    indptr: np.ndarray, indices: np.ndarray, region: np.ndarray, out: np.ndarray
) -> None:
    """``out[c]`` (bool[C]) = choice c has an edge to a state outside ``region``."""
    for c in range(indptr.size - 1):
        leaves = False
        for k in range(indptr[c], indptr[c + 1]):
            if not region[indices[k]]:
                leaves = True
                break
        out[c] = leaves


leaving_choices = compiled(_leaving_choices)


def _restrict_to_region(
    indptr: np.ndarray,
    indices: np.ndarray,
    row_groups: np.ndarray,
    region: np.ndarray,
    usable: np.ndarray,
    safe: np.ndarray,
    leaks: np.ndarray,
) -> None:
    """One round's restriction of the almost-sure search, in one pass over the states of
    ``region`` (bool[S]): ``safe[c]`` (bool[C]) = c is usable and stays in the region;
    ``leaks[s]`` (bool[S]) = a usable choice of s leaves it. Entries of states outside the region
    are left as they were (False on entry: the caller never reads them)."""
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


restrict_to_region = compiled(_restrict_to_region)
