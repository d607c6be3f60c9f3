"""The support-keyed memo of the graph searches (posgmc.engines.support_cache and its use in
posgmc.engines.graph): a digest tells inputs apart, the cache stays within its byte budget, and a
remembered search answers exactly what the search computes (sets, witnesses, layers), for a
structure of the same support but other probabilities too."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import graph
from posgmc.engines.graph import Structure, attractor, structure_of
from posgmc.engines.support_cache import SupportCache, clear_all, digest
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import small_models


def test_digest_tells_dtype_shape_and_order_apart() -> None:
    a = np.array([1, 0, 1], dtype=bool)
    assert digest(a) == digest(a.copy())
    assert digest(a) != digest(a.astype(np.int8))  # same bytes, other dtype
    assert digest(np.zeros(4, np.int32)) != digest(np.zeros((2, 2), np.int32))  # other shape
    assert digest(a, None) != digest(None, a)
    assert digest(b"ab", b"c") != digest(b"a", b"bc")  # parts are delimited
    assert digest(1) != digest(None) != digest(b"")
    # empty, 0-d and strided arrays are digested by their contents too
    assert digest(np.zeros(0)) != digest(np.zeros((0, 3))) != digest(np.array(0.0))
    strided = np.arange(6).reshape(3, 2)[:, 0]
    assert digest(strided) == digest(np.array([0, 2, 4]))


def test_cache_keeps_the_most_recent_within_its_budget() -> None:
    cache: SupportCache[np.ndarray] = SupportCache(lambda a: a.nbytes, budget=3 * 800)
    arrays = [np.full(100, i, dtype=np.int64) for i in range(4)]  # 800 bytes each
    for i in range(3):
        cache.put(digest(i), arrays[i])
    assert cache.get(digest(0)) is arrays[0]  # 0 is now the most recent
    cache.put(digest(3), arrays[3])  # over budget: drops the least recent, 1
    assert len(cache) == 3 and cache.get(digest(1)) is None
    assert all(cache.get(digest(i)) is arrays[i] for i in (0, 2, 3))
    cache.put(digest(9), np.zeros(1000))  # larger than the budget: not kept
    assert cache.get(digest(9)) is None and len(cache) == 3


def _refilled(model: ExplicitModel, rng: np.random.Generator) -> sp.csr_matrix:
    """The model's matrix with other probabilities on the same support."""
    T = model.transitions
    data = rng.uniform(0.1, 1.0, T.nnz)
    return sp.csr_matrix((data, T.indices, T.indptr), shape=T.shape)


@settings(max_examples=200, deadline=None)
@given(model=small_models(ModelType.SMG, max_states=7), data=st.data())
def test_a_remembered_attractor_is_the_computed_one(model: ExplicitModel, data) -> None:  # type: ignore[no-untyped-def]
    S, C = model.num_states, model.num_choices

    def mask(n: int) -> np.ndarray:
        return np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)

    initial, existential, candidates = mask(S), mask(S), mask(S)
    allowed = mask(C) if data.draw(st.booleans()) else None
    initial_choices = mask(C) if data.draw(st.booleans()) else None
    preferred = (np.array(data.draw(st.lists(st.integers(-1, C - 1), min_size=S, max_size=S)))
                 if data.draw(st.booleans()) else None)
    g = structure_of(model)
    # the same support with other probabilities: the same key, the same transposed arrays
    other = Structure.build(_refilled(model, np.random.default_rng(0)), model.row_groups)
    assert other.key == g.key and other.back_choices is g.back_choices

    def run(structure: Structure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        layer = np.full(S, -7, dtype=np.int64)  # untouched entries must stay as they were
        inside, witness = attractor(structure, initial, existential=existential,
                                    candidates=candidates, allowed=allowed,
                                    initial_choices=initial_choices, preferred=preferred,
                                    layer=layer)
        return inside, witness, layer

    graph._ATTRACTORS.clear()
    computed = run(g)
    assert graph._ATTRACTORS.misses == 1
    for structure in (g, other):
        remembered = run(structure)
        for a, b in zip(computed, remembered):
            assert a.tolist() == b.tolist()
    assert graph._ATTRACTORS.hits == 2
    # the answers handed out are the caller's own: changing them changes no later answer
    expected = [a.copy() for a in computed]
    computed[0][:] = ~computed[0]
    computed[1][:] = 5
    for a, b in zip(expected, run(g)):
        assert a.tolist() == b.tolist()
    # other arguments on a warm cache are answered as on a cold one (no key covers too little)
    initial, existential, candidates = mask(S), mask(S), mask(S)
    allowed = mask(C) if data.draw(st.booleans()) else None
    warm = run(g)
    graph._ATTRACTORS.clear()
    for a, b in zip(run(g), warm):
        assert a.tolist() == b.tolist()

def test_other_supports_other_keys() -> None:
    rows = np.array([[0.5, 0.5], [0.0, 1.0]])
    a = Structure.build(sp.csr_matrix(rows), np.array([0, 1, 2]))
    b = Structure.build(sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0]])), np.array([0, 1, 2]))
    c = Structure.build(sp.csr_matrix(rows), np.array([0, 2, 2]))  # other row groups
    assert len({a.key, b.key, c.key}) == 3
    everyone = np.ones(2, dtype=bool)
    goal = np.array([False, True])
    # 0 reaches 1 in a, not in b (where 0 only loops)
    assert attractor(a, goal, existential=everyone, candidates=everyone)[0].tolist() == [1, 1]
    assert attractor(b, goal, existential=everyone, candidates=everyone)[0].tolist() == [0, 1]


def test_clear_all_forgets_every_cache() -> None:
    cache: SupportCache[np.ndarray] = SupportCache(lambda a: a.nbytes)
    cache.put(digest(1), np.zeros(3))
    m = make_model(ModelType.MDP, [0, 1, 2], np.array([[0.0, 1.0], [0.0, 1.0]]))
    attractor(structure_of(m), np.array([False, True]), existential=np.ones(2, dtype=bool),
              candidates=np.ones(2, dtype=bool))
    assert len(cache) == 1 and len(graph._ATTRACTORS) > 0
    clear_all()
    assert len(cache) == 0 and len(graph._ATTRACTORS) == 0 and len(graph._TRANSPOSED) == 0
