"""CTL's path quantifiers over the underlying graph of a model: ``A`` (all paths) and ``E`` (some
path), as PRISM checks them (``prism/src/explicit/NonProbModelChecker.java``): probabilities do
not matter, only which states can follow which, through any choice (for an mdp the nondeterminism
is one more kind of branching). Every state has a successor (deadlocks got a self-loop).

The graph is turned into a :class:`~posgmc.engines.graph.Structure` whose choices are its edges,
one successor each, so that the attractor of :mod:`posgmc.engines.graph` computes both
quantifiers: a state joins ``E [ a U b ]`` when *some* edge leads into the set, ``A [ a U b ]``
when *all* do. The other operators reduce to these (``G``, ``W`` and ``R`` through negation).
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import Structure, attractor, row_of_entries
from posgmc.model.explicit import ExplicitModel

__all__ = ["edge_structure", "exists_next", "exists_until", "forall_next", "forall_until"]

_EDGES: weakref.WeakKeyDictionary[ExplicitModel, Structure] = weakref.WeakKeyDictionary()


def edge_structure(model: ExplicitModel) -> Structure:
    """The model's state graph as a structure with one choice per edge ``s -> t`` (cached)."""
    found = _EDGES.get(model)
    if found is None:
        t = model.transitions
        source = model_choice_state(model)[row_of_entries(t)]
        adj = sp.csr_matrix((np.ones(t.nnz), (source, t.indices)),
                            shape=(model.num_states, model.num_states))
        adj.sum_duplicates()
        num_edges = adj.nnz
        edges = sp.csr_matrix((np.ones(num_edges), adj.indices.astype(np.int64),
                               np.arange(num_edges + 1, dtype=np.int64)),
                              shape=(num_edges, model.num_states))
        found = Structure.build(edges, adj.indptr.astype(np.int64))
        _EDGES[model] = found
    return found


def model_choice_state(model: ExplicitModel) -> np.ndarray:
    """int64[C]: the state of each choice."""
    counts = np.diff(model.row_groups)
    return np.repeat(np.arange(model.num_states, dtype=np.int64), counts)


def _successor_hits(g: Structure, target: np.ndarray) -> np.ndarray:
    """int64[S]: how many edges of each state lead into ``target``."""
    into = np.asarray(g.transitions @ target.astype(np.float64)) > 0
    return np.add.reduceat(into.astype(np.int64), g.row_groups[:-1])


def exists_next(model: ExplicitModel, target: np.ndarray) -> np.ndarray:
    """bool[S]: ``E [ X target ]``, some successor satisfies ``target``."""
    return _successor_hits(edge_structure(model), target) > 0


def forall_next(model: ExplicitModel, target: np.ndarray) -> np.ndarray:
    """bool[S]: ``A [ X target ]``, every successor satisfies ``target``."""
    g = edge_structure(model)
    out: np.ndarray = _successor_hits(g, target) == g.num_choices
    return out


def exists_until(model: ExplicitModel, remain: np.ndarray, target: np.ndarray) -> np.ndarray:
    """bool[S]: ``E [ remain U target ]``."""
    g = edge_structure(model)
    everyone = np.ones(model.num_states, dtype=np.bool_)
    inside, _ = attractor(g, target, existential=everyone, candidates=remain & ~target)
    return inside


def forall_until(model: ExplicitModel, remain: np.ndarray, target: np.ndarray) -> np.ndarray:
    """bool[S]: ``A [ remain U target ]`` (the least fixpoint: every path reaches ``target``
    through ``remain``; a cycle inside ``remain & !target`` escapes it)."""
    g = edge_structure(model)
    nobody = np.zeros(model.num_states, dtype=np.bool_)
    inside, _ = attractor(g, target, existential=nobody, candidates=remain & ~target)
    return inside
