"""The product of a model with an LDBA, and its two questions: accepting end components
(maximal probability of an LTL formula) and accepting cycles (some path satisfies it).

Product states are the reachable pairs ``(s, q)`` with ``q`` the automaton state after reading the
letters up to and including ``s`` (the convention of :mod:`posgmc.engines.ltl.product`). The
choices of ``(s, q)`` are

* each model choice ``c`` of ``s``, moving to ``(t, delta[q, L(t)])`` with probability
  ``P(c, t)``;
* then one choice per epsilon jump ``q -> q'`` of the automaton, moving to ``(s, q')`` with
  probability 1 (the scheduler guesses when and how to enter the accepting component).

The product is an MDP whatever the model (a dtmc's product has the jumps as its only
nondeterminism). The automaton is limit-deterministic, so (Courcoubetis & Yannakakis; Sickert
et al., CAV 2016) the maximal probability that a path of the model satisfies the formula is the
maximal probability of reaching, in the product, an end component that contains an accepting
state: :func:`accepting_end_components`. For a dtmc that maximum is *the* probability. Some path
satisfies the formula iff a product path reaches a cycle through an accepting state:
:func:`accepting_cycles` (PRISM's ``E [ ltl ]``).

Exploration is breadth-first over frontier arrays as in :mod:`posgmc.engines.ltl.product`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from posgmc.engines.graph import end_components, row_of_entries
from posgmc.engines.ltl.ldba import Ldba
from posgmc.engines.ltl.product import _expand_ranges, pack_letters, reachable_pairs
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType

__all__ = ["OmegaProduct", "accepting_cycles", "accepting_end_components", "omega_product"]


@dataclass(frozen=True, eq=False)
class OmegaProduct:
    """A model-LDBA product. ``P`` = number of product states.

    ``model``: the product, an MDP (model choices first in each state, then jumps).
    ``state_of``: int64[P], the model state of each product state.
    ``automaton_state_of``: int64[P].
    ``accepting``: bool[P], product states whose automaton state is accepting.
    ``initial_map``: int64[k], the product state of each start state (in the order given).
    ``automaton``: the LDBA.
    """

    model: ExplicitModel
    state_of: np.ndarray
    automaton_state_of: np.ndarray
    accepting: np.ndarray
    initial_map: np.ndarray
    automaton: Ldba

    @property
    def num_states(self) -> int:
        return int(self.state_of.size)


def omega_product(
    model: ExplicitModel,
    ldba: Ldba,
    atom_values: np.ndarray,
    *,
    starts: np.ndarray | None = None,
) -> OmegaProduct:
    """Build the reachable product of ``model`` and ``ldba`` (module docstring).

    Args:
        model: a dtmc or mdp (any explicit model; its players and observations are dropped).
        ldba: the automaton over (a superset of) the model's letters.
        atom_values: bool[len(ldba.atoms), S].
        starts: the model states paths start in (default: the initial states).

    Raises:
        ValueError: ``atom_values`` has the wrong shape (a caller bug).
    """
    S = model.num_states
    Q = ldba.num_states
    values = np.asarray(atom_values, dtype=bool)
    if values.ndim != 2 or values.shape != (ldba.num_atoms, S):
        raise ValueError(f"atom_values has shape {values.shape}, expected {(ldba.num_atoms, S)}")
    letters = ldba.columns(pack_letters(values))
    K = ldba.delta.shape[1]
    delta_flat = ldba.delta.astype(np.int64).reshape(-1)
    jump_ptr, jump_to = ldba.jump_ptr, ldba.jump_to
    jump_count = np.diff(jump_ptr)

    index, init_keys = reachable_pairs(model, ldba.delta, ldba.initial, letters, starts=starts,
                                       jump_ptr=jump_ptr, jump_to=jump_to)
    keys = index.keys()
    state_of, q_of = np.divmod(keys, Q)
    P = keys.size

    # -- assembly: per product state its model choices, then its jumps ---------------------------
    rg = model.row_groups
    model_counts = np.diff(rg)[state_of]
    jumps = jump_count[q_of]
    row_groups = np.concatenate([[0], np.cumsum(model_counts + jumps)]).astype(np.int64)
    # model-choice rows
    choice_of = _expand_ranges(rg[state_of], model_counts)
    model_rows = _expand_ranges(row_groups[:-1], model_counts)
    choice_q = np.repeat(q_of, model_counts)
    T = model.transitions
    entry_counts = np.diff(T.indptr)[choice_of]
    entries = _expand_ranges(T.indptr[choice_of].astype(np.int64), entry_counts)
    targets = T.indices[entries].astype(np.int64)
    target_q = delta_flat[np.repeat(choice_q * K, entry_counts) + letters[targets]]
    rows_m = np.repeat(model_rows, entry_counts)
    cols_m = index.lookup(targets * Q + target_q)
    # jump rows
    jump_rows = _expand_ranges(row_groups[:-1] + model_counts, jumps)
    jump_targets = jump_to[_expand_ranges(jump_ptr[q_of], jumps)]
    cols_j = index.lookup(np.repeat(state_of, jumps) * Q + jump_targets)
    num_rows = int(row_groups[-1])
    # the source of each product entry: a model entry, or -1 for a jump (probability 1); a row
    # never has two entries to one column (distinct model successors, distinct jump targets)
    source = np.concatenate([entries, np.full(jump_rows.size, -1, dtype=np.int64)])
    order = sp.csr_matrix(
        (
            np.arange(1, source.size + 1, dtype=np.float64),
            (np.concatenate([rows_m, jump_rows]), np.concatenate([cols_m, cols_j])),
        ),
        shape=(num_rows, P),
    )
    order.sort_indices()
    source = source[order.data.astype(np.int64) - 1]  # in the csr's entry order
    probabilities = np.where(source >= 0, T.data[np.maximum(source, 0)], 1.0)
    transitions = sp.csr_matrix((probabilities, order.indices, order.indptr), shape=(num_rows, P))
    initial_map = index.lookup(init_keys)
    product_model = make_model(
        ModelType.MDP,
        row_groups,
        transitions,
        initial_states=np.unique(initial_map),
        variable_names=("_state", "_automaton"),
        state_values=np.column_stack([state_of, q_of]).astype(np.int64),
    )
    if model.exact_probabilities is not None:  # exact mode: the fractions follow the entries
        exact = np.empty(source.size, dtype=object)
        exact[:] = [Fraction(1) if k < 0 else model.exact_probabilities[k] for k in source.tolist()]
        product_model = replace(product_model, exact_probabilities=exact)
    return OmegaProduct(
        model=product_model,
        state_of=state_of.astype(np.int64),
        automaton_state_of=q_of.astype(np.int64),
        accepting=ldba.accepting[q_of],
        initial_map=initial_map.astype(np.int64),
        automaton=ldba,
    )


def accepting_end_components(prod: OmegaProduct) -> np.ndarray:
    """bool[P]: the states of the maximal end components that contain an accepting state (a
    scheduler staying in one visits all its states infinitely often, almost surely)."""
    m = prod.model
    counts = np.diff(m.row_groups)
    choice_state = np.repeat(np.arange(m.num_states, dtype=np.int64), counts)
    allowed = np.ones(m.num_choices, dtype=bool)
    mec_of, num_mecs, _ = end_components(m.transitions, choice_state, allowed)
    if num_mecs == 0:
        return np.zeros(m.num_states, dtype=bool)
    good = np.zeros(num_mecs, dtype=bool)
    hit = mec_of[prod.accepting & (mec_of >= 0)]
    good[hit] = True
    region: np.ndarray = (mec_of >= 0) & good[np.maximum(mec_of, 0)]
    return region


def accepting_cycles(prod: OmegaProduct) -> np.ndarray:
    """bool[P]: the product states from which some path reaches a cycle through an accepting
    state (an accepting lasso: the graph ignores probabilities)."""
    m = prod.model
    T = m.transitions
    counts = np.diff(m.row_groups)
    choice_state = np.repeat(np.arange(m.num_states, dtype=np.int64), counts)
    src = choice_state[row_of_entries(T)]
    graph = sp.csr_matrix(
        (np.ones(T.nnz, dtype=np.int8), (src, T.indices)), shape=(m.num_states, m.num_states)
    )
    graph.sum_duplicates()
    _, comp = connected_components(graph, directed=True, connection="strong")
    coo = graph.tocoo()
    internal = comp[coo.row] == comp[coo.col]  # an edge inside a component: a cycle there
    cyclic = np.zeros(int(comp.max()) + 1, dtype=bool)
    cyclic[comp[coo.row[internal]]] = True
    accepting_comp = np.zeros_like(cyclic)
    accepting_comp[comp[prod.accepting]] = True
    goal = cyclic[comp] & accepting_comp[comp]
    # backward reachability of the goal
    back = graph.T.tocsr()
    reach: np.ndarray = goal.copy()
    frontier = np.flatnonzero(reach)
    while frontier.size:
        preds = back.indices[_expand_ranges(back.indptr[frontier].astype(np.int64),
                                            np.diff(back.indptr)[frontier].astype(np.int64))]
        preds = np.unique(preds)
        frontier = preds[~reach[preds]]
        reach[frontier] = True
    return reach
