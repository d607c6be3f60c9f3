"""The compiled SCC decomposition (:mod:`posgmc.engines.kernels.components`) against scipy's: the
same partition of the states, labels in a reverse topological order of the condensation."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import kernels, scc
from posgmc.engines.graph import structure_of
from posgmc.model.explicit import ExplicitModel
from tests.engines.engine_models import small_models

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")


def _same_partition(a: np.ndarray, b: np.ndarray) -> bool:
    """Two labelings define the same partition: the pairs (a, b) form a bijection."""
    pairs = np.unique(np.stack([a, b], axis=1), axis=0)
    return bool(
        pairs.shape[0] == np.unique(a).size == np.unique(b).size
    )


def _labels(model: ExplicitModel, compiled: bool, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    monkeypatch.setattr(kernels.STATE, "use", compiled)
    g = structure_of(model)
    return scc.components(g.transitions, g.row_groups)


def test_hand_graph() -> None:
    """0 -> 1 -> 2 -> 1, 2 -> 3, 3 -> 3: components {3}, {1, 2}, {0}, completed in that order
    (a successor component is completed, so labelled, first)."""
    from posgmc.engines.kernels.components import tarjan

    T = sp.csr_matrix(np.array([[0, 1, 0, 0], [0, 0, 1, 0], [0, 0.5, 0, 0.5], [0, 0, 0, 1.0]]))
    labels, count = tarjan(T.indptr, T.indices, np.arange(5), np.ones(4, dtype=bool))
    assert count == 3
    assert labels.tolist() == [2, 1, 1, 0]
    # without state 2 the cycle is cut: {0}, {1}, {3}, only 0 -> 1 left; state 2 gets no label
    within = np.array([True, True, False, True])
    labels, count = tarjan(T.indptr, T.indices, np.arange(5), within)
    assert count == 3
    assert labels[2] == -1 and labels[1] < labels[0] and labels[3] >= 0


@settings(max_examples=200, deadline=None)
@given(small_models(max_states=8), st.data())
def test_same_partition_as_scipy_and_topological(model: ExplicitModel, data: st.DataObject) -> None:
    with pytest.MonkeyPatch.context() as mp:
        ours = _labels(model, True, mp)
        theirs = _labels(model, False, mp)
    assert ours.shape == theirs.shape == (model.num_states,)
    assert _same_partition(ours, theirs)
    # every transition goes to the same or a smaller label
    g = structure_of(model)
    T = g.transitions.tocoo()
    src = g.choice_state[T.row]
    assert np.all(ours[T.col] <= ours[src])


@settings(max_examples=200, deadline=None)
@given(small_models(max_states=8), st.data())
def test_subgraph_components(model: ExplicitModel, data: st.DataObject) -> None:
    """Restricted to a random set of states: scipy's partition of the induced subgraph, in a
    reverse topological order of it, and no label outside."""
    from scipy.sparse.csgraph import connected_components

    S = model.num_states
    within = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    g = structure_of(model)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        ours = scc.components(g.transitions, g.row_groups, within)
    assert np.all(ours[~within] == -1) and np.all(ours[within] >= 0)
    T = g.transitions.tocoo()
    src = g.choice_state[T.row]
    inside = within[src] & within[T.col]
    idx = np.flatnonzero(within)
    local = np.full(S, -1)
    local[idx] = np.arange(idx.size)
    graph = sp.csr_matrix(
        (np.ones(int(inside.sum())), (local[src[inside]], local[T.col[inside]])),
        shape=(idx.size, idx.size),
    )
    if idx.size:
        _, theirs = connected_components(graph, directed=True, connection="strong")
        assert _same_partition(ours[idx], theirs)
    assert np.all(ours[T.col[inside]] <= ours[src[inside]])


@settings(max_examples=200, deadline=None)
@given(small_models(max_states=8), st.data())
def test_seed_component_is_the_seeds_component(model: ExplicitModel, data: st.DataObject) -> None:
    """``seed_component`` against the compiled decomposition of the same subgraph (itself checked
    against scipy above): above the threshold it is the size of the seed's component, at or
    below it a number at most the threshold; and the giant-component shortcut of
    ``topological_blocks`` makes the decision the decomposition makes."""
    from posgmc.engines.kernels.components import seed_component

    S = model.num_states
    within = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    if not within.any():
        return
    unk = np.flatnonzero(within)
    seed = int(data.draw(st.sampled_from(unk.tolist())))
    threshold = data.draw(st.integers(0, S))
    g = structure_of(model)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        labels = scc.components(g.transitions, g.row_groups, within)
        size = seed_component(
            g.transitions.indptr, g.transitions.indices, g.row_groups, g.back_ptr,
            g.back_choices, g.choice_state, within, seed, threshold,
        )
    exact = int(np.count_nonzero(labels == labels[seed]))
    if exact > threshold:
        assert size == exact
    else:
        assert size <= threshold
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        mp.setattr(scc, "MIN_BAND_STATES", 1)
        transpose = (g.back_ptr, g.back_choices, g.choice_state)
        shortcut = scc.topological_blocks(
            g.transitions, g.row_groups, unk, layer=None, band_states=None, transpose=transpose
        )
        full = scc.topological_blocks(
            g.transitions, g.row_groups, unk, layer=None, band_states=None
        )
    assert (shortcut is None) == (full is None)
    if full is not None and shortcut is not None:
        assert all(np.array_equal(a, b) for a, b in zip(shortcut, full))
    giant = exact > scc.MAX_GIANT_SHARE * unk.size and seed == unk[0]
    if giant and unk.size >= 2:
        assert shortcut is None


def test_a_giant_component_skips_the_decomposition(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ring of 200 states (one component; hand-built) and a chain of 200 (every state its own
    component): with the transposed pattern given, the ring is refused without Tarjan's pass (the
    first state's component is all of it), the chain still gets its decomposition."""
    from posgmc.model.explicit import make_model
    from posgmc.syntax.ast import ModelType

    k = 200
    src = np.arange(k)
    monkeypatch.setattr(kernels.STATE, "use", True)
    monkeypatch.setattr(scc, "MIN_BAND_STATES", 1)
    calls: list[int] = []
    real = scc.components

    def counted(*args: object, **kwargs: object) -> np.ndarray:
        calls.append(1)
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(scc, "components", counted)
    for successor, giant in (((src + 1) % k, True), (np.minimum(src + 1, k - 1), False)):
        T = sp.csr_matrix((np.ones(k), (src, successor)), shape=(k, k))
        g = structure_of(make_model(ModelType.MDP, np.arange(k + 1), T))
        calls.clear()
        found = scc.topological_blocks(
            g.transitions, g.row_groups, src, layer=None, band_states=None,
            transpose=(g.back_ptr, g.back_choices, g.choice_state),
        )
        assert (found is None) == giant
        assert calls == ([] if giant else [1])
