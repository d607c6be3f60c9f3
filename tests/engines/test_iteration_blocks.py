"""The blocked (Gauss-Seidel) layout of :class:`~posgmc.engines.system.System`.

Large systems are laid out in blocks (the backward-search layers of the positive region) and the
lower iteration and the verification sweep them in order. Small test models stay below the size
where that happens, so these tests lower the thresholds and check (1) the layout invariants, (2)
that the Bellman operator is unchanged, (3) that the bounds still enclose the exact value
(reference: the exact rational solver, as in ``test_engine_random.py``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines import system as it
from posgmc.engines.graph import positive_reach, structure_of
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import as_floats, small_models

SETTINGS = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture
def tiny_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(it, "_MIN_BLOCKED_STATES", 0)
    monkeypatch.setattr(it, "_MAX_BLOCKS", 3)


def _maximize(model: ExplicitModel, flip: bool) -> np.ndarray:
    if model.model_type is ModelType.SMG:
        return (model.state_players == 0) ^ flip
    return np.full(model.num_states, flip)


def _reference_bellman(model: ExplicitModel, sys: it.System, x: np.ndarray) -> np.ndarray:
    """B(x) by a plain loop over the states (the definition)."""
    y = sys.offset + sys.matrix @ x
    out = np.empty(sys.n)
    for s in range(sys.n):
        vals = y[sys.row_state == s]
        out[s] = vals.max() if s < sys.num_max else vals.min()
    return out


def test_block_of_merges_consecutive_layers() -> None:
    # at most 2 blocks; layers 0..3 with 1, 1, 4, 2 states: chunks of 4 states -> layers
    # {0, 1, 2} start in chunk 0, layer 3 starts at state 6 -> chunk 1
    layer = np.array([3, 0, 2, 2, 1, 2, 3, 2])
    assert it._block_of(layer, 2).tolist() == [1, 0, 0, 0, 0, 0, 1, 0]


def test_blocked_layout_invariants(tiny_blocks: None) -> None:
    @SETTINGS
    @given(small_models(max_states=8), st.booleans(), st.data())
    def check(model: ExplicitModel, flip: bool, data: st.DataObject) -> None:
        S = model.num_states
        g = structure_of(model)
        maximize = _maximize(model, flip)
        layer = np.array(data.draw(st.lists(st.integers(-1, 4), min_size=S, max_size=S)))
        sys = it.build_system(g, np.ones(S, bool), maximize=maximize, layer=layer)
        # every usable choice is one row, once
        assert sorted(sys.rows.tolist()) == list(range(model.num_choices))
        assert np.array_equal(g.choice_state[sys.rows], sys.states[sys.row_state])
        # entries cover their states' j-th rows; blocks own contiguous rows, in layer order
        rank = sys.rows - model.row_groups[sys.states[sys.row_state]]
        covered = np.zeros(sys.m, bool)
        for rs, ml, a, nl, b, j in sys.entries:
            assert np.array_equal(sys.row_state[rs : rs + a], np.arange(ml, ml + a))
            assert np.array_equal(sys.row_state[rs + a : rs + a + b], np.arange(nl, nl + b))
            assert np.all(rank[rs : rs + a + b] == j)
            covered[rs : rs + a + b] = True
        assert covered.all()
        lay = np.where(layer < 0, layer.max() + 1, layer)[sys.states]
        block_layers = [
            lay[np.r_[ml : ml + a, nl : nl + b]] for _, _, ml, a, nl, b, _ in sys.plan
        ]
        for earlier, later in zip(block_layers, block_layers[1:]):
            assert earlier.max() <= later.min()
        assert sys.maximize.tolist() == maximize[sys.states].tolist()
        x = np.arange(sys.n, dtype=float) % 3
        assert np.allclose(it.bellman(sys, x), _reference_bellman(model, sys, x))
        first = sys.first_row
        assert np.array_equal(sys.row_state[first], np.arange(sys.n))
        assert np.all(rank[first] == 0)

    check()


def test_blocked_reach_bounds_enclose_exact_value(tiny_blocks: None) -> None:
    @SETTINGS
    @given(small_models(max_states=8), st.booleans(), st.data())
    def check(model: ExplicitModel, flip: bool, data: st.DataObject) -> None:
        S = model.num_states
        target = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
        maximize = _maximize(model, flip)
        ref = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
        res = obj.reach_probability(model, target, maximize=maximize)
        assert res.sound and res.converged
        assert np.all(res.lower <= ref + 1e-9) and np.all(ref <= res.upper + 1e-9)
        assert np.all(res.upper - res.lower <= 2e-6 + 1e-9)

    check()


def test_reach_probability_uses_blocks_on_a_long_chain(monkeypatch: pytest.MonkeyPatch) -> None:
    """A chain s_0 -> s_1 -> ... -> s_k -> goal with a leak at every step: the blocks follow the
    distance to the goal and the value is p^(k+1) (hand derivation: each step survives with p).
    One block per layer: a sweep carries the value down the whole chain, where Jacobi steps need
    k + 1 of them."""
    monkeypatch.setattr(it, "_MIN_BLOCKED_STATES", 0)
    monkeypatch.setattr(it, "_MAX_BLOCKS", 64)
    k, p = 30, 0.75
    S = k + 3  # s_0..s_k, goal = k+1, sink = k+2
    rows = np.zeros((S, S))
    for i in range(k + 1):
        rows[i, i + 1] = p
        rows[i, S - 1] = 1 - p
    rows[k + 1, k + 1] = rows[k + 2, k + 2] = 1.0
    from posgmc.model.explicit import make_model

    model = make_model(ModelType.MDP, np.arange(S + 1), rows)
    assert model.num_states == S and model.num_choices == S
    target = np.zeros(S, bool)
    target[k + 1] = True
    g = structure_of(model)
    layer = np.full(S, -1)
    positive_reach(g, target, np.ones(S, bool), existential=np.ones(S, bool), layer=layer)
    assert layer[: k + 2].tolist() == list(range(k + 1, -1, -1))
    res = obj.reach_probability(model, target, maximize=np.ones(S, bool))
    assert abs(res.values[0] - p ** (k + 1)) <= 1e-6
    assert res.lower[0] <= p ** (k + 1) <= res.upper[0]
    assert res.iterations <= 5
    monkeypatch.setattr(it, "_MIN_BLOCKED_STATES", 10**9)
    assert obj.reach_probability(model, target, maximize=np.ones(S, bool)).iterations > k


@given(
    keep=st.lists(st.booleans(), min_size=0, max_size=40),
    chunk=st.integers(min_value=1, max_value=7),
)
@SETTINGS
def test_in_place_compaction_equals_boolean_indexing(keep: list[bool], chunk: int) -> None:
    """``_compact`` (the layout's in-place filter of the matrix entries) gives ``a[keep]`` for
    every chunk size, for arrays of different dtypes at once (definition: numpy's boolean index)."""
    mask = np.array(keep, dtype=bool)
    data = np.arange(mask.size, dtype=np.float64) * 0.5
    cols = np.arange(mask.size, dtype=np.int32)[::-1].copy()
    want_data, want_cols = data[mask], cols[mask]
    old = it._COMPACT_CHUNK
    it._COMPACT_CHUNK = chunk  # hypothesis runs this body many times: no fixture, restore below
    try:
        got_data, got_cols = it._compact(mask, data, cols)
    finally:
        it._COMPACT_CHUNK = old
    assert np.array_equal(got_data, want_data) and np.array_equal(got_cols, want_cols)
