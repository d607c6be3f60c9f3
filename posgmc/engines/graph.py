"""Graph precomputation on the choice/state structure: attractors, qualitative reachability, MECs.

Everything works on a :class:`Structure` (the rows of a transition matrix grouped by state, the
layout of :class:`~posgmc.model.explicit.ExplicitModel`, and its transposed pattern, built once
per model). With the compiled kernels (:mod:`posgmc.engines.kernels`, the default) an attractor is
one backward worklist search over the transposed pattern with a counter per state
(:mod:`posgmc.engines.kernels.graph`), so its work is linear in the transitions whatever the
number of layers. The numpy fallback searches layer by layer: each layer gathers the predecessor
choices of the frontier in one fancy-indexing step, so its work is linear too and its Python
overhead is per layer, never per state. Both give the same sets and layers (the tests run both).

Per-state quantifiers. A state whose entry of ``existential`` is True joins an attractor when *some*
allowed choice has an edge into the set; any other state joins when *all* its allowed choices do
(and it has at least one). This is the controllable/uncontrollable predecessor of turn-based games;
for an mdp or dtmc all states share one quantifier.

Qualitative reachability (``positive_reach``/``almost_sure_reach``) is exact for turn-based
stochastic games: the value of ``remain U target`` is 0 exactly outside the positive attractor,
and 1 exactly on the almost-sure winning region, computed by the classical nested fixpoint
``nu Y. mu X. target | (remain & CPre(Y, X))``.

End components: :func:`end_components` returns the maximal end components of a sub-structure by
iterated strongly-connected-component decomposition (``scipy.sparse.csgraph``), removing choices
that leave their component until nothing changes.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from posgmc.engines import kernels, scc
from posgmc.engines.kernels import graph as graph_kernels
from posgmc.engines.support_cache import SupportCache, digest
from posgmc.model.explicit import ExplicitModel

__all__ = [
    "Structure",
    "structure_of",
    "concat_ranges",
    "attractor",
    "positive_reach",
    "almost_sure_reach",
    "positive_buchi",
    "safe_region",
    "end_components",
    "row_of_entries",
    "leaving_choices",
]


@dataclass(frozen=True, eq=False)
class Structure:
    """The choice/state layout of a transition matrix and its transposed pattern.

    ``transitions``: csr float64 [C, S] (the model's own matrix, not a copy);
    ``back_ptr``: int32[S + 1] and ``back_choices``: int32[nnz] (each int64 when its values do not
    fit): the transpose of the matrix's *pattern*: for state t the choices with an edge into t are
    ``back_choices[back_ptr[t]:back_ptr[t + 1]]``, ascending (the searches never read the
    probabilities, so the transpose carries 4 bytes per entry);
    ``row_groups``: int64[S + 1] (the model's own array); ``choice_state``: int32[C] (int64 when S
    does not fit), the state of every choice; ``num_choices``: int64[S] (computed when first
    read); ``key``: the digest of the support (``indptr``, ``indices``, ``row_groups``): two
    structures with the same key have the same searches (:mod:`posgmc.engines.support_cache`).
    The transposed arrays are read-only: structures of one support share them.
    """

    transitions: sp.csr_matrix
    back_ptr: np.ndarray
    back_choices: np.ndarray
    row_groups: np.ndarray
    choice_state: np.ndarray
    key: bytes = b""

    @cached_property
    def num_choices(self) -> np.ndarray:
        """int64[S]: the number of choices of every state."""
        return np.diff(self.row_groups)

    @property
    def num_states(self) -> int:
        return int(self.row_groups.size - 1)

    @property
    def num_choices_total(self) -> int:
        return int(self.row_groups[-1])

    @staticmethod
    def build(transitions: sp.csr_matrix, row_groups: np.ndarray) -> Structure:
        """The structure of a csr matrix whose rows are grouped by ``row_groups`` (the transposed
        pattern computed once per support: see :data:`_TRANSPOSED`)."""
        key = digest(transitions.indptr, transitions.indices, row_groups,
                     int(transitions.shape[1]), int(_compiled(int(transitions.shape[0]))))
        found = _TRANSPOSED.get(key)
        if found is None:
            found = _transposed_pattern(transitions, row_groups)
            for a in found:
                a.flags.writeable = False
            _TRANSPOSED.put(key, found)
        back_ptr, back_choices, choice_state = found
        return Structure(
            transitions=transitions,
            back_ptr=back_ptr,
            back_choices=back_choices,
            row_groups=row_groups,
            choice_state=choice_state,
            key=key,
        )


def _nbytes(arrays: tuple[np.ndarray | None, ...]) -> int:
    return sum(a.nbytes for a in arrays if a is not None)


_TRANSPOSED: SupportCache[tuple[np.ndarray, np.ndarray, np.ndarray]] = SupportCache(_nbytes)
"""The transposed pattern of every recently built support (a cache, not configuration): the
products of a synthesis with strategies of one support, and the chains of one policy, share it."""


def _index_dtype(bound: int) -> type[np.signedinteger[Any]]:
    """int32 when every index below ``bound`` fits, else int64."""
    return np.int32 if bound < 2**31 - 1 else np.int64


_WARMING = threading.local()
"""``_WARMING.on`` is True in the warm-up thread only (:func:`_warm_up`)."""


def _compiled(size: int) -> bool:
    """Whether to take the compiled path on a model of ``size`` choices: the kernels are on and
    the model is large enough that numba's start-up (:mod:`posgmc.engines.kernels`) pays
    (:data:`posgmc.engines.scc.COMPILED_MIN_SIZE`, read at call time: tests lower it), or
    this is the warm-up thread loading the kernels on a two-state structure."""
    if getattr(_WARMING, "on", False):
        return kernels.enabled()
    return scc.compiled_at(size)


def _ro(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``: the kernels' inputs are always passed read-only, so that a
    model's frozen arrays and a fresh array select the same compiled (and cached) variant."""
    view = a.view()
    view.flags.writeable = False
    return view


def _transposed_pattern(
    transitions: sp.csr_matrix, row_groups: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(back_ptr, back_choices, choice_state)`` of :class:`Structure` for a csr matrix."""
    C, S = transitions.shape
    ptr_type = np.zeros(0, dtype=_index_dtype(transitions.nnz))
    choice_type = np.zeros(0, dtype=_index_dtype(C))
    state_type = np.zeros(0, dtype=_index_dtype(S))
    if _compiled(C):
        found: tuple[np.ndarray, np.ndarray, np.ndarray] = graph_kernels.transpose_pattern(
            _ro(transitions.indptr),
            _ro(transitions.indices),
            _ro(row_groups),
            ptr_type,
            choice_type,
            state_type,
        )
        return found
    pattern = sp.csr_matrix(
        (np.ones(transitions.nnz, dtype=np.int8), transitions.indices, transitions.indptr),
        shape=transitions.shape,
    ).tocsc()
    pattern.sort_indices()
    return (
        pattern.indptr.astype(ptr_type.dtype, copy=False),
        pattern.indices.astype(choice_type.dtype, copy=False),
        np.repeat(np.arange(S, dtype=state_type.dtype), np.diff(row_groups)),
    )


# The transpose of a large model is costly (a pass over every transition and a copy of them);
# models are frozen, so one structure per model object is kept for as long as the model lives
# (a cache, not configuration).
_STRUCTURES: weakref.WeakKeyDictionary[ExplicitModel, Structure] = weakref.WeakKeyDictionary()


def structure_of(model: ExplicitModel) -> Structure:
    """The (cached) :class:`Structure` of a model's transition matrix."""
    found = _STRUCTURES.get(model)
    if found is None:
        found = Structure.build(model.transitions, model.row_groups)
        _STRUCTURES[model] = found
    return found


def concat_ranges(starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The concatenation of ``arange(starts[i], ends[i])`` over i (int64), without a Python loop."""
    lengths = ends - starts
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.cumsum(lengths) - lengths
    out: np.ndarray = np.arange(total, dtype=np.int64) + np.repeat(starts - offsets, lengths)
    return out


def row_of_entries(matrix: sp.csr_matrix) -> np.ndarray:
    """int64[nnz]: the row of every stored entry of a csr matrix."""
    return np.repeat(np.arange(matrix.shape[0], dtype=np.int64), np.diff(matrix.indptr))


def attractor(
    g: Structure,
    initial: np.ndarray,
    *,
    existential: np.ndarray,
    candidates: np.ndarray,
    allowed: np.ndarray | None = None,
    initial_choices: np.ndarray | None = None,
    preferred: np.ndarray | None = None,
    layer: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The states that can be forced (with positive probability per step) into ``initial``.

    Args:
        g: the structure.
        initial: bool[S], the set to attract to (always part of the result).
        existential: bool[S], see the module docstring.
        candidates: bool[S], the states allowed to join.
        allowed: bool[C] or None (all): the choices that may be used; for a universal state the
            quantifier ranges over its allowed choices only.
        initial_choices: bool[C] or None: choices that count as hitting the set from the start (a
            target outside the structure, e.g. a choice with probability mass to a goal).
        preferred: int64[S] or None: a choice to report as witness when it qualifies in the layer
            where its state joins.
        layer: int64[S] or None: filled in place with the round where each state joined (0 for
            ``initial``; others untouched), an order in which values propagate.

    Returns:
        ``(inside, witness)``: bool[S] the attractor; int64[S] for each joined state a choice that
        hit the set when the state joined (a memoryless attractor strategy for existential states),
        -1 elsewhere.
    """
    compiled = _compiled(g.num_choices_total)
    key = digest(
        g.key or digest(g.transitions.indptr, g.transitions.indices, g.row_groups),
        int(compiled),
        _flags(initial),
        _flags(existential),
        _flags(candidates),
        None if allowed is None else _flags(allowed),
        None if initial_choices is None else _flags(initial_choices),
        None if preferred is None else np.asarray(preferred, dtype=np.int64),
    )
    found = _ATTRACTORS.get(key)
    if found is None:
        layers = np.full(g.num_states, -1, dtype=np.int64)
        search = _attractor_compiled if compiled else _attractor_layered
        inside, witness = search(
            g,
            initial,
            existential=existential,
            candidates=candidates,
            allowed=allowed,
            initial_choices=initial_choices,
            preferred=preferred,
            layer=layers,
        )
        joined = np.flatnonzero(layers >= 0)
        found = (inside, witness, joined, layers[joined])
        for a in found:
            a.flags.writeable = False
        _ATTRACTORS.put(key, found)
    inside, witness, joined, joined_layer = found
    if layer is not None:
        layer[joined] = joined_layer
    return inside.copy(), witness.copy()


def _flags(a: np.ndarray) -> np.ndarray:
    """``a`` as bool (a digest must not tell a bool mask from the same mask as int8)."""
    return np.asarray(a, dtype=bool)


_ATTRACTORS: SupportCache[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = SupportCache(
    _nbytes
)
"""Recent attractors by the digest of their structure's support and arguments (a cache, not
configuration): synthesis repeats the same searches on products of one support."""


def _attractor_layered(
    g: Structure,
    initial: np.ndarray,
    *,
    existential: np.ndarray,
    candidates: np.ndarray,
    allowed: np.ndarray | None,
    initial_choices: np.ndarray | None,
    preferred: np.ndarray | None,
    layer: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`attractor` by the numpy search, layer by layer."""
    S = g.num_states
    C = g.num_choices_total
    inside = initial.copy()
    witness = np.full(S, -1, dtype=np.int64)
    if allowed is None:
        allowed_count = g.num_choices
    else:
        allowed_count = np.add.reduceat(allowed, g.row_groups[:-1], dtype=np.int64)
    all_existential = bool(existential.all())
    need = np.where(existential, 1, allowed_count)
    open_ = candidates & ~inside & (allowed_count > 0)
    count = np.zeros(S, dtype=np.int64) if not all_existential else None
    hit = np.zeros(C, dtype=bool)
    # "stamps" deduplicate index arrays in O(k) (no sort): after stamp[a] = arange(len(a)), the
    # positions i with stamp[a[i]] == i hold each distinct value once
    stamp_c = np.empty(C, dtype=np.int64)
    stamp_s = np.empty(S, dtype=np.int64)
    bw_ptr = g.back_ptr
    bw_idx = g.back_choices
    frontier = np.flatnonzero(initial)
    extra = None if initial_choices is None else np.flatnonzero(initial_choices)
    if layer is not None:
        layer[frontier] = 0
    if not open_.any():  # nobody can join: no search (its first layer could be the whole model)
        return inside, witness
    level = 0
    while True:
        level += 1
        preds = bw_idx[
            concat_ranges(bw_ptr[frontier].astype(np.int64), bw_ptr[frontier + 1].astype(np.int64))
        ]
        if extra is not None:
            preds = np.concatenate([preds, extra])
            extra = None
        keep = ~hit[preds]
        if allowed is not None:
            keep &= allowed[preds]
        preds = preds[keep]
        if preds.size == 0:
            break
        k = np.arange(preds.size)
        stamp_c[preds] = k
        preds = preds[stamp_c[preds] == k]
        hit[preds] = True
        st = g.choice_state[preds]
        if count is None:
            cond = open_[st]
        else:
            np.add.at(count, st, 1)
            cond = open_[st] & (count[st] >= need[st])
        cand_st = st[cond]
        if cand_st.size == 0:
            break
        cand_ch = preds[cond]
        k = np.arange(cand_st.size)
        stamp_s[cand_st] = k
        new = cand_st[stamp_s[cand_st] == k]
        witness[cand_st] = cand_ch
        if preferred is not None:
            pm = cand_ch == preferred[cand_st]
            witness[cand_st[pm]] = cand_ch[pm]
        open_[new] = False
        inside[new] = True
        if layer is not None:
            layer[new] = level
        frontier = new
    return inside, witness


_NO_INDEX = np.zeros(0, dtype=np.int64)
_NO_FLAG = np.zeros(0, dtype=bool)


def _attractor_compiled(
    g: Structure,
    initial: np.ndarray,
    *,
    existential: np.ndarray,
    candidates: np.ndarray,
    allowed: np.ndarray | None,
    initial_choices: np.ndarray | None,
    preferred: np.ndarray | None,
    layer: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`attractor` by the compiled worklist search (:func:`graph_kernels.attract`)."""
    inside = np.ascontiguousarray(initial, dtype=bool).copy()
    open_ = np.ascontiguousarray(candidates & ~inside)
    extra = _NO_INDEX if initial_choices is None else np.flatnonzero(initial_choices)
    layer_out = layer if layer is not None else _NO_INDEX
    witness: np.ndarray = graph_kernels.attract(
        _ro(g.back_ptr),
        _ro(g.back_choices),
        _ro(g.row_groups),
        _ro(g.choice_state),
        _ro(np.ascontiguousarray(existential, dtype=bool)),
        open_,
        _ro(_NO_FLAG if allowed is None else np.ascontiguousarray(allowed, dtype=bool)),
        allowed is not None,
        _ro(extra),
        _ro(_NO_INDEX if preferred is None else np.ascontiguousarray(preferred, dtype=np.int64)),
        preferred is not None,
        inside,
        layer_out,
        layer is not None,
    )
    return inside, witness


def _warm_up() -> None:
    """Run every graph kernel once on a two-state structure with the dtypes of a model's
    (int32 indices), so that their cached machine code is loaded (see
    :func:`posgmc.engines.kernels.warm_up_in_background`)."""
    _WARMING.on = True
    try:
        g = Structure.build(
            sp.csr_matrix(
                (np.ones(2), np.array([1, 1], np.int32), np.array([0, 1, 2], np.int32))
            ),
            np.array([0, 1, 2], dtype=np.int64),
        )
        both = np.ones(2, dtype=bool)
        first = np.array([True, False])
        attractor(g, ~first, existential=first, candidates=both, allowed=both,
                  initial_choices=~both, preferred=np.zeros(2, np.int64),
                  layer=np.full(2, -1, dtype=np.int64))
        leaving_choices(g, first)
        _restrict_to_region(g, first, both)
    finally:
        _WARMING.on = False


kernels.on_warm_up(_warm_up)


def positive_reach(
    g: Structure,
    target: np.ndarray,
    remain: np.ndarray,
    *,
    existential: np.ndarray,
    layer: np.ndarray | None = None,
) -> np.ndarray:
    """bool[S]: states where ``P(remain U target) > 0`` can be forced by the existential states.

    Its complement is exactly the set of states of value 0 (the universal states can make the
    probability 0 against any choice of the existential ones). ``layer``: see :func:`attractor`.
    """
    inside, _ = attractor(
        g, target, existential=existential, candidates=remain & ~target, layer=layer
    )
    return inside


def leaving_choices(g: Structure, region: np.ndarray) -> np.ndarray:
    """bool[C]: the choices with an edge to a state outside ``region`` (bool[S])."""
    if _compiled(g.num_choices_total):
        T = g.transitions
        out: np.ndarray = graph_kernels.leaving_choices(
            _ro(T.indptr), _ro(T.indices), _ro(np.ascontiguousarray(region, dtype=bool))
        )
        return out
    outside = (~region).astype(np.float64)
    return np.asarray(g.transitions @ outside) > 0


def _restrict_to_region(
    g: Structure, region: np.ndarray, usable: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(safe, leaks)`` for the states of ``region``: bool[C] the usable choices that stay in it,
    bool[S] the states with a usable choice that leaves it (entries outside ``region`` are
    meaningless on the compiled path: nobody outside the region can join the next attractor)."""
    if _compiled(g.num_choices_total):
        T = g.transitions
        found: tuple[np.ndarray, np.ndarray] = graph_kernels.restrict_to_region(
            _ro(T.indptr),
            _ro(T.indices),
            _ro(g.row_groups),
            _ro(np.ascontiguousarray(region, dtype=bool)),
            _ro(np.ascontiguousarray(usable, dtype=bool)),
        )
        return found
    safe = usable & ~leaving_choices(g, region)
    leaks = np.logical_or.reduceat(~safe & usable, g.row_groups[:-1])
    return safe, leaks


def almost_sure_reach(
    g: Structure,
    target: np.ndarray,
    remain: np.ndarray,
    *,
    existential: np.ndarray,
    allowed: np.ndarray | None = None,
    target_choices: np.ndarray | None = None,
    start: np.ndarray | None = None,
    universal_allowed: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The almost-sure region of ``remain U target`` for the existential states, and a strategy.

    Args:
        g: the structure.
        target, remain: bool[S].
        existential: bool[S], the states of the player who wants to reach.
        allowed: bool[C] or None: restricts the choices of the existential player (the universal
            player keeps all its choices).
        target_choices: bool[C] or None: taking one of these choices (from a state of the region,
            staying in the region) also counts as reaching.
        start: bool[S] or None: the result of :func:`positive_reach` for the same arguments, if
            already known (saves one backward search; ignored with ``allowed``/``target_choices``).
        universal_allowed: bool[C] or None: restricts the universal player's choices (a sub-game);
            each universal state of the region needs at least one allowed choice.

    Returns:
        ``(region, witness)``: bool[S] the states where reaching is almost sure; int64[S] an
        almost-surely winning memoryless choice for the existential states of the region outside
        ``target`` (the attractor choice of the last round), -1 elsewhere.
    """
    one_player = target_choices is None and bool(existential.all())
    region, witness, done = _almost_sure_reach_nested(
        g,
        target,
        remain,
        existential=existential,
        allowed=allowed,
        target_choices=target_choices,
        start=start,
        universal_allowed=universal_allowed,
        max_rounds=_NESTED_ROUNDS if one_player else None,
    )
    if done:
        return region, witness
    # many rounds ahead (each a full backward search): finish in one step on the end-component
    # quotient, from the region left so far (the states removed are losing)
    return _almost_sure_reach_one_player(g, target, remain, allowed=allowed, superset=region)


_NESTED_ROUNDS = 6
"""Rounds of the nested fixpoint tried before a one-player problem switches to the end-component
quotient: most models settle in two or three rounds, where the quotient's decomposition would cost
more; grids where the region shrinks one layer per round need hundreds."""


def _almost_sure_reach_nested(
    g: Structure,
    target: np.ndarray,
    remain: np.ndarray,
    *,
    existential: np.ndarray,
    allowed: np.ndarray | None,
    target_choices: np.ndarray | None,
    start: np.ndarray | None,
    universal_allowed: np.ndarray | None,
    max_rounds: int | None = None,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`almost_sure_reach` by the nested fixpoint (any quantifiers).

    Returns ``(region, witness, done)``; with ``max_rounds`` the search may stop early with
    ``done`` False, ``region`` then being a superset of the answer (every state removed so far is
    losing) and ``witness`` meaningless."""
    exist_choice = existential[g.choice_state]
    usable = np.ones(g.num_choices_total, dtype=bool)
    if allowed is not None:
        usable &= allowed | ~exist_choice
    if universal_allowed is not None:
        usable &= universal_allowed | exist_choice
    goal_choices = None if target_choices is None else target_choices & usable
    if (
        start is not None
        and allowed is None
        and universal_allowed is None
        and target_choices is None
    ):
        region = start & (remain | target)
        # a superset of the answer that saves most rounds in games: the universal player's
        # positive attractor to the value-0 states cannot be almost-surely winning
        losing = ~region
        if (~existential).any():
            spoil, _ = attractor(g, losing, existential=~existential, candidates=region & ~target)
            region = region & ~spoil
    else:
        region, _ = attractor(
            g,
            target,
            existential=existential,
            candidates=remain & ~target,
            allowed=usable,
            initial_choices=goal_choices,
        )
    rounds = 0
    while True:
        if max_rounds is not None and rounds >= max_rounds:
            return region, np.full(g.num_states, -1, dtype=np.int64), False
        rounds += 1
        # a universal state with a choice leaving the region cannot be in it
        safe, leaks = _restrict_to_region(g, region, usable)
        new, witness = attractor(
            g,
            target,
            existential=existential,
            candidates=region & remain & ~target & (existential | ~leaks),
            allowed=safe,
            initial_choices=None if goal_choices is None else goal_choices & safe,
        )
        if int(new.sum()) == int(region.sum()):
            return new, witness, True
        region = new


def _almost_sure_reach_one_player(
    g: Structure,
    target: np.ndarray,
    remain: np.ndarray,
    *,
    allowed: np.ndarray | None,
    superset: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`almost_sure_reach` when every state is existential (an mdp's ``Pmax = 1``), without
    the nested fixpoint, whose number of rounds can reach the hundreds on large grids.

    Under any strategy the play eventually stays in an end component, so with the target made
    absorbing: collapse every maximal end component of the candidate states (positive reach,
    outside the target) into one node whose choices are its exits (the choices that leave it). The
    quotient has no end components, so every strategy reaches the target or a "losing" sink (an
    exit-free node, or a state outside the candidates) almost surely, and reaching the target
    almost surely is *surely avoiding* the losing sinks: the complement of the universal attractor
    of the losing nodes. An end component can be left through any of its exits almost surely, so
    the original states of a node win exactly when the node does. One attractor towards the target
    inside the winning region then gives the memoryless witness, as the last round of the nested
    fixpoint would.

    ``superset``: bool[S], states outside it are known to be losing (e.g. the region left by some
    rounds of the nested fixpoint, or the positive-reach region).
    """
    S = g.num_states
    usable = np.ones(g.num_choices_total, dtype=bool) if allowed is None else allowed.copy()
    cand = superset & remain & ~target
    n = int(cand.sum())
    local_of = np.full(S, -1, dtype=np.int64)
    local_of[cand] = np.arange(n, dtype=np.int64)
    rows = np.flatnonzero(usable & cand[g.choice_state])
    sub = g.transitions[rows]
    dest = local_of[sub.indices]
    inside = dest >= 0
    kept = np.zeros(sub.nnz + 1, dtype=np.int64)
    np.cumsum(inside, out=kept[1:])
    kept_ptr = kept[sub.indptr]
    stays = np.diff(kept_ptr) == np.diff(sub.indptr)
    row_owner = local_of[g.choice_state[rows]]
    inner = sp.csr_matrix((sub.data[inside], dest[inside], kept_ptr), shape=(rows.size, n))
    mec_of, num_mecs, internal = end_components(inner, row_owner, stays)
    # nodes: one per end component, one per candidate outside every end component, then LOSE
    loose = mec_of < 0
    node_of = mec_of.copy()
    node_of[loose] = num_mecs + np.arange(int(loose.sum()), dtype=np.int64)
    num_nodes = num_mecs + int(loose.sum())
    lose = num_nodes
    exits = np.flatnonzero(~internal)
    exit_node = node_of[row_owner[exits]]
    order = np.argsort(exit_node, kind="stable")
    exits, exit_node = exits[order], exit_node[order]
    # the successors of every exit as nodes: a candidate its node, any other non-target state
    # LOSE; mass into the target leads to WIN, which cannot be attracted and needs no edge
    node_of_state = np.full(S, lose, dtype=np.int64)
    node_of_state[cand] = node_of
    node_of_state[target] = -1
    ex = sub[exits]
    dest = node_of_state[ex.indices]
    keep = dest >= 0
    kept_before = np.zeros(dest.size + 1, dtype=np.int64)
    np.cumsum(keep, out=kept_before[1:])
    quotient = sp.csr_matrix(
        (np.ones(int(kept_before[-1])), dest[keep], kept_before[ex.indptr]),
        shape=(exits.size, num_nodes + 1),
    )
    exit_counts = np.bincount(exit_node, minlength=num_nodes + 1)
    row_groups = np.zeros(num_nodes + 2, dtype=np.int64)
    np.cumsum(exit_counts, out=row_groups[1:])
    q = Structure.build(quotient, row_groups)
    initial = exit_counts == 0  # exit-free nodes are traps; LOSE has no rows either
    losing, _ = attractor(
        q,
        initial,
        existential=np.zeros(num_nodes + 1, dtype=bool),
        candidates=np.arange(num_nodes + 1) < lose,
    )
    region = target.copy()
    region[np.flatnonzero(cand)[~losing[node_of]]] = True
    safe = usable & ~leaving_choices(g, region)
    return attractor(
        g,
        target,
        existential=np.ones(S, dtype=bool),
        candidates=region & ~target,
        allowed=safe,
    )


def positive_buchi(
    g: Structure, good: np.ndarray, region: np.ndarray, *, existential: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """States from which the existential player can make the play take ``good`` choices infinitely
    often with positive probability, never leaving ``region``, and a strategy for it.

    Computed by sub-games: the almost-sure Büchi region (greatest fixpoint ``Y = almost-sure reach,
    inside Y, of good choices that stay in Y``) of the current sub-game is added together with its
    positive attractor; the next sub-game drops these states and the universal player's choices
    into them (the universal player avoids them where it can), until a sub-game has no almost-sure
    region. A state where the universal player can only choose between a good cycle and a move
    into the winning region is thereby found winning in the second round.

    Returns:
        ``(winning, witness)``: bool[S]; int64[S] for the existential states of ``winning`` a
        choice that keeps the promise (inside an almost-sure region: a good choice or a step
        towards one, staying inside; elsewhere: a step towards such a region), -1 elsewhere.
    """
    winning = np.zeros(g.num_states, dtype=bool)
    witness = np.full(g.num_states, -1, dtype=np.int64)
    none = np.zeros(g.num_states, dtype=bool)
    while True:
        sub = region & ~winning
        avoid = ~leaving_choices(g, ~winning)  # choices with no edge into the winning part
        current = sub.copy()
        core_witness = witness
        while True:
            stay = ~leaving_choices(g, current)
            new, core_witness = almost_sure_reach(
                g,
                none,
                current,
                existential=existential,
                target_choices=good & stay & current[g.choice_state],
                universal_allowed=avoid,
            )
            new &= current
            if int(new.sum()) == int(current.sum()):
                break
            current = new
        if not current.any():
            return winning, witness
        take = current & existential & (core_witness >= 0)
        witness[take] = core_witness[take]
        grown, attract = attractor(g, winning | current, existential=existential, candidates=region)
        added = grown & ~winning & ~current & existential & (attract >= 0)
        witness[added] = attract[added]
        winning = grown


def safe_region(
    g: Structure,
    region: np.ndarray,
    *,
    existential: np.ndarray,
    good: np.ndarray | None = None,
    frozen: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The largest subset of ``region`` in which the existential states can keep the play forever
    (surely) using only ``good`` choices.

    Existential states need one good choice with all successors inside; universal states need every
    choice good and inside. ``frozen`` states (bool[S]) always stay in the set (absorbing for the
    question, e.g. a target).

    Returns ``(safe, choice)``: bool[S]; int64[S] for each existential non-frozen state of ``safe``
    a qualifying choice (-1 elsewhere).

    The complement is one attractor of the other player (one backward search, not a pass over
    the model per round): starting from the states outside ``region`` (and not frozen), a
    universal state of the region leaves when one of its choices is not good or has an edge out,
    an existential one when every good choice has an edge out (at once when it has none).
    """
    ok = np.ones(g.num_choices_total, dtype=bool) if good is None else good
    keep_always = np.zeros(g.num_states, dtype=bool) if frozen is None else frozen
    movable = region & ~keep_always
    exist_choice = existential[g.choice_state]
    # existential states without a good choice cannot stay anywhere
    good_count = np.bincount(g.choice_state[ok], minlength=g.num_states)
    lost = ~(region | keep_always) | (movable & existential & (good_count == 0))
    out, _ = attractor(
        g,
        lost,
        existential=~existential,
        candidates=movable,
        allowed=ok | ~exist_choice,
        initial_choices=~ok & ~exist_choice,
    )
    current = ~out
    choice = np.full(g.num_states, -1, dtype=np.int64)
    stays = ok & ~leaving_choices(g, current) & current[g.choice_state]
    idx = np.flatnonzero(stays)[::-1]
    choice[g.choice_state[idx]] = idx  # the first qualifying choice wins
    choice[~(current & existential) | keep_always] = -1
    return current, choice


def end_components(
    matrix: sp.csr_matrix, state_of_row: np.ndarray, allowed: np.ndarray
) -> tuple[np.ndarray, int, np.ndarray]:
    """Maximal end components of the sub-structure made of the ``allowed`` choices.

    Args:
        matrix: csr [m, n]: row r is a choice of state ``state_of_row[r]`` (rows need not be
            grouped); a row whose probability mass leaves the n columns must not be allowed (it
            cannot be part of an end component).
        state_of_row: int64[m].
        allowed: bool[m].

    Returns:
        ``(mec_of, num_mecs, internal)``: int64[n] the component of each state (-1: none);
        bool[m] the allowed choices that stay inside their state's component.
    """
    m, n = matrix.shape
    rows = np.flatnonzero(allowed)
    # group the rows by state (timsort: the rows of a slot layout are few sorted runs), so that the
    # state graph of every round is a csr matrix built without a coo conversion
    rows = rows[np.argsort(state_of_row[rows], kind="stable")]
    sub = matrix[rows]
    k = rows.size
    entry_row = row_of_entries(sub)  # sub-row of every entry
    row_owner = state_of_row[rows]
    sub_src = row_owner[entry_row]
    sub_dst = sub.indices.astype(np.int64)
    idx_dtype = np.int32 if n < 2**31 - 1 and sub.nnz < 2**31 - 1 else np.int64
    dst_small = sub.indices.astype(idx_dtype)
    back: sp.csc_matrix | None = None  # for a state t, the sub-rows with an edge into t
    on = np.ones(k, dtype=bool)  # sub-row still active
    count = np.bincount(row_owner, minlength=n)
    labels = np.zeros(n, dtype=np.int64)
    stamp = np.empty(k, dtype=np.int64)

    def deactivate(sub_rows: np.ndarray) -> np.ndarray:
        """Switch rows off; return the states that lost their last row."""
        sub_rows = sub_rows[on[sub_rows]]
        if sub_rows.size == 0:
            return np.zeros(0, dtype=np.int64)
        idx = np.arange(sub_rows.size)
        stamp[sub_rows] = idx
        sub_rows = sub_rows[stamp[sub_rows] == idx]
        on[sub_rows] = False
        owners = row_owner[sub_rows]
        np.subtract.at(count, owners, 1)
        owners = np.unique(owners)
        out: np.ndarray = owners[count[owners] == 0]
        return out

    while True:
        keep = on[entry_row]
        indptr = np.zeros(n + 1, dtype=idx_dtype)
        np.cumsum(np.bincount(sub_src[keep], minlength=n), out=indptr[1:])
        graph = sp.csr_matrix(
            (np.ones(int(indptr[-1]), dtype=np.float64), dst_small[keep], indptr), shape=(n, n)
        )
        # scipy's strongly-connected-components routine loops forever on duplicate entries
        graph.sum_duplicates()
        _, lab = connected_components(graph, directed=True, connection="strong")
        labels = lab.astype(np.int64)
        alive = count > 0
        leaving = keep & ((labels[sub_dst] != labels[sub_src]) | ~alive[sub_dst])
        if not leaving.any():
            break
        dead = deactivate(np.unique(entry_row[leaving]))
        # states without rows are gone: rows into them leave too (a backward search, so that the
        # next decomposition only has to handle real splits)
        if dead.size and back is None:
            back = sub.tocsc()
        while dead.size and back is not None:
            back_ptr = back.indptr.astype(np.int64, copy=False)
            preds = back.indices[concat_ranges(back_ptr[dead], back_ptr[dead + 1])]
            dead = deactivate(preds)
    active = np.zeros(m, dtype=bool)
    active[rows[on]] = True
    alive = np.zeros(n, dtype=bool)
    alive[state_of_row[active]] = True
    mec_of = np.full(n, -1, dtype=np.int64)
    if not alive.any():
        return mec_of, 0, np.zeros(m, dtype=bool)
    _, compact = np.unique(labels[alive], return_inverse=True)
    mec_of[alive] = compact
    return mec_of, int(compact.max()) + 1, active
