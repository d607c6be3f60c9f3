"""The product of an explicit model with the DFA of a co-safe LTL formula.

Product states are the reachable pairs ``(s, q)`` of a model state and a DFA state, where ``q`` is
the DFA state after reading the labels of the path up to and including ``s`` (the DFA reads the
letter of the current state before moving, see :mod:`posgmc.engines.ltl.dfa`):

* initial: ``(s0, delta[q0, L(s0)])`` for each initial state ``s0`` (or each of ``starts``);
* choice ``c`` of ``s`` in ``(s, q)`` moves to ``(t, delta[q, L(t)])`` with probability
  ``P(c, t)``.

So "reach an accepting product state" is "the path has a good prefix", i.e. satisfies the formula,
and the expected reward collected before an accepting product state is reached is the reward of
``R[co-safe]``. The product has the model's type; each product choice copies its model choice
(action, owner, choice reward), each product state copies its model state's player, labels, state
reward and valuation (plus the DFA state as an extra variable).

Observations: with ``observe_dfa_state`` (the default) each observation id becomes the pair
(model observation, DFA state), which is what a player who remembers its observation history knows
*if every atom is a function of its observations*; otherwise the automaton state reveals hidden
information and the flag should be off, in which case observation ids are carried over unchanged.
For fully observable checking the flag makes no difference.

Exploration is breadth-first over frontier arrays (no Python loop per state): the successors of a
whole frontier are one gather over the model's state graph, DFA moves are one indexing of ``delta``
with letters packed from the atom values, and pairs are keys ``s * Q + q``, deduplicated by
sorting and numbered in discovery order (level by level, by key within a level). The cost is
linear in the product's transitions plus a few numpy calls per BFS level (tens of microseconds:
a chain of 10^5 states takes seconds).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import scipy.sparse as sp

from posgmc.engines.ltl.dfa import Dfa, LetterGraph
from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model

__all__ = ["Product", "letter_graph", "pack_letters", "product"]

DFA_VARIABLE = "_dfa"
"""Name of the state-value / observation column holding the DFA state (made unique if taken)."""

_DENSE_INDEX_LIMIT = 1 << 26
"""Up to this many (s, q) pairs, product ids are kept in a dense int64 array indexed by pair."""


@dataclass(frozen=True, eq=False)
class Product:
    """A model-DFA product. ``P`` = number of product states.

    ``model``: the product model (same type, players, actions and reward names as the original).
    ``state_of``: int64[P], the model state of each product state.
    ``dfa_state_of``: int64[P], the DFA state of each product state.
    ``accepting``: bool[P], product states whose DFA state is accepting (the reachability
    target; the set is closed under successors).
    ``rejecting``: bool[P], product states in the DFA's rejecting sink (the formula can no longer
    be satisfied).
    ``initial_map``: int64[k], the product state of each of the original model's initial states,
    in the order of ``original.initial_states``.
    ``dfa``: the automaton.
    """

    model: ExplicitModel
    state_of: np.ndarray
    dfa_state_of: np.ndarray
    accepting: np.ndarray
    rejecting: np.ndarray
    initial_map: np.ndarray
    dfa: Dfa

    @property
    def num_states(self) -> int:
        return int(self.state_of.size)


def pack_letters(atom_values: np.ndarray) -> np.ndarray:
    """int64[S]: the letter of each state, bit i set when atom i holds there.

    Args:
        atom_values: bool[n, S].

    Returns:
        The packed letters.
    """
    values = np.asarray(atom_values, dtype=bool)
    letters = np.zeros(values.shape[1], dtype=np.int64)
    for i in range(values.shape[0]):  # one pass per atom, at most 62
        letters |= values[i].astype(np.int64) << i
    return letters


def letter_graph(
    model: ExplicitModel, atom_values: np.ndarray, starts: np.ndarray | None = None
) -> LetterGraph:
    """The letters of ``model``'s states and which can follow which (for
    :func:`~posgmc.engines.ltl.dfa.to_dfa`: the automaton is then built for this model only).

    Args:
        model: the model.
        atom_values: bool[n, S], as for :func:`product`.
        starts: the states paths start in (default: the initial states).
    """
    letters = pack_letters(atom_values)
    alphabet, column = np.unique(letters, return_inverse=True)
    column = column.reshape(-1)
    K = alphabet.size
    graph = _state_graph(model).tocoo()
    follow = sp.csr_matrix(
        (np.ones(graph.row.size, dtype=bool), (column[graph.row], column[graph.col])), shape=(K, K)
    )
    follow.sum_duplicates()
    start_states = model.initial_states if starts is None else np.asarray(starts, dtype=np.int64)
    start_mask = np.zeros(K, dtype=bool)
    start_mask[column[start_states]] = True
    return LetterGraph(alphabet=alphabet, starts=start_mask, follow=follow)


def _expand_ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenation of ``range(starts[i], starts[i] + counts[i])`` for all i, vectorized."""
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.cumsum(counts) - counts
    return np.repeat(starts - offsets, counts) + np.arange(total, dtype=np.int64)


def _state_graph(model: ExplicitModel) -> sp.csr_matrix:
    """The model's successor relation, S x S (pattern only)."""
    T = model.transitions
    rows = np.repeat(model.choice_states, np.diff(T.indptr))
    graph = sp.csr_matrix(
        (np.ones(rows.size, dtype=np.int8), (rows, T.indices)),
        shape=(model.num_states, model.num_states),
    )
    graph.sum_duplicates()
    return graph


def _sorted_unique(keys: np.ndarray) -> np.ndarray:
    """Sorted distinct keys (a sort and a mask: cheaper than ``np.unique`` on large int arrays)."""
    keys = np.sort(keys)
    if keys.size > 1:
        keys = keys[np.concatenate(([True], keys[1:] != keys[:-1]))]
    return keys


class _PairIndex:
    """Product state ids of pair keys ``s * Q + q`` in [0, size), assigned in discovery order.

    Small key spaces use a dense id array (-1: not discovered) so that membership and lookup are
    one gather; larger ones keep sorted keys and use ``np.isin`` / ``np.searchsorted``.
    """

    def __init__(self, size: int) -> None:
        self._dense = np.full(size, -1, dtype=np.int64) if size <= _DENSE_INDEX_LIMIT else None
        self._sorted = np.zeros(0, dtype=np.int64)
        self._levels: list[np.ndarray] = []
        self.count = 0

    def discover(self, keys: np.ndarray) -> np.ndarray:
        """Give ids to the keys not seen before; return those keys, sorted and distinct."""
        if self._dense is not None:
            fresh = _sorted_unique(keys[self._dense[keys] < 0])
            self._dense[fresh] = np.arange(self.count, self.count + fresh.size)
        else:
            fresh = _sorted_unique(keys)
            fresh = fresh[~np.isin(fresh, self._sorted, assume_unique=True)]
            self._sorted = np.union1d(self._sorted, fresh)
        self._levels.append(fresh)
        self.count += fresh.size
        return fresh

    def keys(self) -> np.ndarray:
        """int64[P]: the key of each product state, in id order."""
        return np.concatenate(self._levels) if self._levels else np.zeros(0, dtype=np.int64)

    def lookup(self, keys: np.ndarray) -> np.ndarray:
        """The ids of discovered keys."""
        if self._dense is not None:
            ids: np.ndarray = self._dense[keys]
            return ids
        all_keys = self.keys()
        order = np.argsort(all_keys)
        return order[np.searchsorted(all_keys[order], keys)]


def reachable_pairs(
    model: ExplicitModel,
    delta: np.ndarray,
    initial: int,
    letters: np.ndarray,
    *,
    starts: np.ndarray | None = None,
    jump_ptr: np.ndarray | None = None,
    jump_to: np.ndarray | None = None,
) -> tuple[_PairIndex, np.ndarray]:
    """The product states reachable from the starts, as keys ``s * Q + q``: their index (sorted
    keys, lookup) and the initial keys.

    Breadth-first over frontiers of keys: a model step reads the successor's letter
    (``delta[q, letters[t]]``); with ``jump_ptr``/``jump_to`` (CSR over automaton states) an
    automaton state also moves without a model step (an LDBA's epsilon jumps).

    Args:
        model: the explicit model; ``delta``: int[Q, letters] the automaton's moves;
        initial: its initial state; letters: int64[S] the delta column of each model state;
        starts: the model states paths start in (default: the initial states).
    """
    S, Q = model.num_states, delta.shape[0]
    num_letters = delta.shape[1]
    delta_flat = delta.astype(np.int64).reshape(-1)  # delta[q, l] = delta_flat[q * L + l]
    init_s = model.initial_states if starts is None else np.asarray(starts, dtype=np.int64)
    init_keys = init_s * Q + delta_flat[initial * num_letters + letters[init_s]]
    graph = _state_graph(model)
    degree = np.diff(graph.indptr)
    index = _PairIndex(S * Q)
    frontier = index.discover(init_keys)
    while frontier.size:
        s, q = np.divmod(frontier, Q)
        counts = degree[s]
        t = graph.indices[_expand_ranges(graph.indptr[s], counts)].astype(np.int64)
        q_next = delta_flat[np.repeat(q * num_letters, counts) + letters[t]]
        found = t * Q + q_next
        if jump_ptr is not None and jump_to is not None:
            jumps = np.diff(jump_ptr)[q]
            jq = jump_to[_expand_ranges(jump_ptr[q], jumps)]
            found = np.concatenate([found, np.repeat(s, jumps) * Q + jq])
        frontier = index.discover(found)
    return index, init_keys


def _unique_name(name: str, taken: tuple[str, ...]) -> str:
    while name in taken:
        name = "_" + name
    return name


def product(
    model: ExplicitModel,
    dfa: Dfa,
    atom_values: np.ndarray,
    *,
    observe_dfa_state: bool = True,
    starts: np.ndarray | None = None,
) -> Product:
    """Build the reachable product of ``model`` and ``dfa`` (see the module docstring).

    Args:
        model: any explicit model (dtmc, mdp, pomdp, smg, posg).
        dfa: the automaton, e.g. from :func:`~posgmc.engines.ltl.dfa.to_dfa`.
        atom_values: bool[len(dfa.atoms), S]: row i is where ``dfa.atoms[i]`` holds.
        observe_dfa_state: make each observation the pair (observation, DFA state); when False,
            observation ids are copied unchanged.
        starts: the model states whose paths are followed (default: the initial states); a
            nested query needs every state (``np.arange(S)``).

    Returns:
        The :class:`Product`.

    Raises:
        ValueError: ``atom_values`` does not have shape (number of atoms, S) (a caller bug).
    """
    S = model.num_states
    Q = dfa.num_states
    values = np.asarray(atom_values, dtype=bool)
    if values.ndim != 2 or values.shape != (dfa.num_atoms, S):
        raise ValueError(
            f"atom_values has shape {values.shape}, expected {(dfa.num_atoms, S)}"
        )
    letters = dfa.columns(pack_letters(values))  # the delta column of each state's letter
    delta = dfa.delta.astype(np.int64)

    index, init_keys = reachable_pairs(model, delta, dfa.initial, letters, starts=starts)
    keys = index.keys()
    num_letters = dfa.delta.shape[1]
    delta_flat = delta.reshape(-1)  # delta[q, letter] = delta_flat[q * num_letters + letter]
    state_of, dfa_state_of = np.divmod(keys, Q)
    P = keys.size

    # -- assembly --------------------------------------------------------------------------------
    rg = model.row_groups
    choice_counts = np.diff(rg)[state_of]
    row_groups = np.concatenate([[0], np.cumsum(choice_counts)])
    choice_of = _expand_ranges(rg[state_of], choice_counts)  # model choice of each product choice
    choice_q = np.repeat(dfa_state_of, choice_counts)
    T = model.transitions
    entry_counts = np.diff(T.indptr)[choice_of]
    entries = _expand_ranges(T.indptr[choice_of].astype(np.int64), entry_counts)
    targets = T.indices[entries].astype(np.int64)
    target_q = delta_flat[np.repeat(choice_q * num_letters, entry_counts) + letters[targets]]
    transitions = sp.csr_matrix(
        (
            T.data[entries],
            index.lookup(targets * Q + target_q),
            np.concatenate([[0], np.cumsum(entry_counts)]),
        ),
        shape=(choice_of.size, P),
    )

    initial_map = index.lookup(init_keys)
    initial_mask = np.zeros(P, dtype=bool)
    initial_mask[initial_map] = True
    labels = {name: np.asarray(lab)[state_of] for name, lab in model.labels.items()}
    labels["init"] = initial_mask

    dfa_name = _unique_name(DFA_VARIABLE, model.variable_names)
    state_values = np.column_stack(
        [model.state_values[state_of].reshape(P, -1), dfa_state_of]
    ).astype(np.int64)

    rewards = tuple(
        RewardModel(
            rm.name,
            state=None if rm.state is None else rm.state[state_of],
            choice=None if rm.choice is None else rm.choice[choice_of],
        )
        for rm in model.reward_models
    )

    observations = tuple(
        _product_observation(obs, state_of, dfa_state_of, Q, observe_dfa_state=observe_dfa_state)
        for obs in model.observations
    )

    product_model = make_model(
        model.model_type,
        row_groups,
        transitions,
        initial_states=np.unique(initial_map),
        choice_actions=model.choice_actions[choice_of],
        action_names=model.action_names,
        state_players=model.state_players[state_of],
        player_names=model.player_names,
        observations=observations,
        labels=MappingProxyType(labels),
        reward_models=rewards,
        variable_names=model.variable_names + (dfa_name,),
        boolean_variables=model.boolean_variables,
        state_values=state_values,
        deadlocks=np.flatnonzero(np.isin(state_of, model.deadlocks)),
    )
    rejecting = (
        np.zeros(P, dtype=bool) if dfa.rejecting_sink is None
        else dfa_state_of == dfa.rejecting_sink
    )
    return Product(
        model=product_model,
        state_of=state_of.astype(np.int64),
        dfa_state_of=dfa_state_of.astype(np.int64),
        accepting=dfa.accepting[dfa_state_of],
        rejecting=rejecting,
        initial_map=initial_map.astype(np.int64),
        dfa=dfa,
    )


def _product_observation(
    obs: Observation,
    state_of: np.ndarray,
    dfa_state_of: np.ndarray,
    num_dfa_states: int,
    *,
    observe_dfa_state: bool,
) -> Observation:
    ids = obs.state_ids[state_of].astype(np.int64)
    if not observe_dfa_state:
        return Observation(obs.player, ids.astype(np.int32), obs.names, obs.values)
    # ids of the observed pairs, numbered in order of (observation, DFA state)
    pair_keys, pair_ids = np.unique(ids * num_dfa_states + dfa_state_of, return_inverse=True)
    base, q = np.divmod(pair_keys, num_dfa_states)
    values = np.column_stack([obs.values[base].reshape(base.size, -1), q]).astype(np.int64)
    return Observation(
        obs.player,
        pair_ids.reshape(-1).astype(np.int32),
        obs.names + (_unique_name(DFA_VARIABLE, obs.names),),
        values,
    )
