"""Compiled strongly connected components of a model's state graph (Tarjan's algorithm, iterative).

The numpy/scipy path (:func:`posgmc.engines.scc.components`) builds a state graph, sums its
duplicate entries (a sort) and lets ``scipy.sparse.csgraph`` convert it to float64 before one
linear pass, and on a large model most of its time goes into those copies. This kernel
walks the model's own csr arrays instead (the successors of state s are the entries of its rows,
one slice, duplicates harmless) with an explicit stack, so no copy of the transitions is made, and
only through the states the caller asks about (the unknown states of a system: the known ones,
often half of the model, are not visited).

Labels are given in the order the components complete, which in Tarjan's algorithm is a reverse
topological order of the condensation (every successor component of a component completes
before it), the same guarantee as scipy's Pearce variant.
"""

from __future__ import annotations

import numpy as np

from posgmc.engines.kernels import compiled


def _tarjan(
    indptr: np.ndarray, indices: np.ndarray, row_groups: np.ndarray, within: np.ndarray
) -> tuple[np.ndarray, int]:
    """``(labels, count)``: int32[S] component labels in completion order (-1 outside
    ``within``), and their number.

    Args:
        indptr, indices: the csr structure of the transitions [C, S], rows grouped by state.
        row_groups: int64[S + 1]; the rows of state s are ``row_groups[s]:row_groups[s+1]``.
        within: bool[S]: the subgraph decomposed (its states and the edges between them).
    """
    S = row_groups.size - 1
    index = np.full(S, -1, dtype=np.int32)
    low = np.empty(S, dtype=np.int32)
    on_stack = np.zeros(S, dtype=np.bool_)
    stack = np.empty(S, dtype=np.int32)  # Tarjan's stack of visited, unassigned states
    call = np.empty(S, dtype=np.int32)  # the depth-first path (explicit recursion)
    edge = np.empty(S, dtype=np.int64)  # next entry to look at, per state on the path
    labels = np.full(S, -1, dtype=np.int32)
    counter = 0
    count = 0
    top = 0
    for root in range(S):
        if index[root] != -1 or not within[root]:
            continue
        depth = 0
        call[0] = root
        index[root] = counter
        low[root] = counter
        counter += 1
        stack[top] = root
        top += 1
        on_stack[root] = True
        edge[root] = indptr[row_groups[root]]
        while depth >= 0:
            v = call[depth]
            e = edge[v]
            end = indptr[row_groups[v + 1]]
            descended = False
            while e < end:
                w = indices[e]
                e += 1
                if not within[w]:
                    continue
                if index[w] == -1:
                    edge[v] = e
                    index[w] = counter
                    low[w] = counter
                    counter += 1
                    stack[top] = w
                    top += 1
                    on_stack[w] = True
                    edge[w] = indptr[row_groups[w]]
                    depth += 1
                    call[depth] = w
                    descended = True
                    break
                if on_stack[w] and index[w] < low[v]:
                    low[v] = index[w]
            if descended:
                continue
            edge[v] = e
            if low[v] == index[v]:
                while True:
                    top -= 1
                    w = stack[top]
                    on_stack[w] = False
                    labels[w] = count
                    if w == v:
                        break
                count += 1
            depth -= 1
            if depth >= 0:
                u = call[depth]
                if low[v] < low[u]:
                    low[u] = low[v]
    return labels, count


tarjan = compiled(_tarjan)


def _seed_component(
    indptr: np.ndarray,
    indices: np.ndarray,
    row_groups: np.ndarray,
    back_ptr: np.ndarray,
    back_choices: np.ndarray,
    choice_state: np.ndarray,
    within: np.ndarray,
    seed: int,
    threshold: int,
) -> int:
    """The size of the strongly connected component of ``seed`` in the subgraph induced by
    ``within`` if it exceeds ``threshold``; otherwise some number ``<= threshold``.

    The component is the intersection of the states that reach ``seed`` (a backward search over
    the transposed pattern ``back_ptr``/``back_choices``/``choice_state``, see
    :class:`~posgmc.engines.graph.Structure`) and the states ``seed`` reaches (a forward search
    over ``indptr``/``indices``/``row_groups``). When the backward set alone holds at most
    ``threshold`` states, the forward search is skipped and its size is returned. Two
    breadth-first searches touch each edge at most once each: far cheaper than a whole
    decomposition (:func:`_tarjan`), which a giant component makes useless.
    """
    S = row_groups.size - 1
    back = np.zeros(S, dtype=np.bool_)
    queue = np.empty(S, dtype=np.int32)
    back[seed] = True
    queue[0] = seed
    head = 0
    tail = 1
    while head < tail:
        t = queue[head]
        head += 1
        for k in range(back_ptr[t], back_ptr[t + 1]):
            s = choice_state[back_choices[k]]
            if within[s] and not back[s]:
                back[s] = True
                queue[tail] = s
                tail += 1
    if tail <= threshold:
        return tail
    ahead = np.zeros(S, dtype=np.bool_)
    ahead[seed] = True
    queue[0] = seed
    head = 0
    tail = 1
    size = 1
    while head < tail:
        s = queue[head]
        head += 1
        for e in range(indptr[row_groups[s]], indptr[row_groups[s + 1]]):
            w = indices[e]
            if within[w] and not ahead[w]:
                ahead[w] = True
                queue[tail] = w
                tail += 1
                if back[w]:
                    size += 1
    return size


seed_component = compiled(_seed_component)
