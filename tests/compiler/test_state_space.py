"""Packing of states into keys and the two key -> number indexes."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.compiler import build_model
from posgmc.compiler.state_space import DirectIndex, HashIndex, StateEncoding, make_index
from posgmc.syntax import ast as A
from tests.compiler.flatlib import cmd, flat_model, module, upd, var
from tests.compiler.helpers import compare_with_reference


@st.composite
def ranges_and_values(draw: st.DrawFn) -> tuple[list[tuple[int, int, bool]], list[np.ndarray]]:
    num_vars = draw(st.integers(1, 6))
    ranges = []
    for _ in range(num_vars):
        if draw(st.booleans()):
            ranges.append((0, 1, True))
        else:
            lo = draw(st.integers(-(10**6), 10**6))
            hi = lo + draw(st.sampled_from([0, 1, 5, 1000, 2**20, 2**40]))
            ranges.append((lo, hi, False))
    m = draw(st.integers(1, 30))
    cols = [
        np.array([draw(st.integers(lo, hi)) for _ in range(m)], dtype=np.int64)
        for lo, hi, _ in ranges
    ]
    return ranges, cols


@given(ranges_and_values())
def test_encode_decode_round_trip_and_order(
    data: tuple[list[tuple[int, int, bool]], list[np.ndarray]],
) -> None:
    ranges, cols = data
    enc = StateEncoding(ranges)
    keys = enc.encode(cols)
    assert keys.shape == (cols[0].size, enc.num_words)
    assert np.all(keys >= 0)
    back = enc.decode_values(keys)
    for i, col in enumerate(cols):
        assert back[:, i].tolist() == col.tolist()
    # key order (word by word) is the lexicographic order of valuations
    rows = [tuple(int(c[j]) for c in cols) for j in range(cols[0].size)]
    by_key = sorted(range(len(rows)), key=lambda j: tuple(keys[j]))
    assert [rows[j] for j in by_key] == sorted(rows)


def test_wide_states_use_several_words() -> None:
    enc = StateEncoding([(0, 2**40, False), (0, 2**40, False)])
    assert enc.num_words == 2
    assert StateEncoding([(0, 3, False), (0, 1, True)]).key_space == 8


@settings(max_examples=50)
@given(st.lists(st.integers(0, 999), min_size=1, max_size=200), st.integers(1, 3))
def test_direct_and_hash_index_number_alike(values: list[int], width: int) -> None:
    keys = np.array([[v * 7 % 1000] * width for v in values], dtype=np.int64)
    hashed = HashIndex(width, initial_bits=2)
    numbers_h, firsts_h = hashed.number_new(keys, 5)
    # first occurrences get 5, 6, ... in order; repeats get the number of their first occurrence
    seen: dict[tuple[int, ...], int] = {}
    expected = [seen.setdefault(tuple(k), 5 + len(seen)) for k in keys.tolist()]
    assert numbers_h.tolist() == expected
    assert hashed.lookup(keys).tolist() == expected
    assert hashed.lookup(keys + 1000).tolist() == [-1] * len(values)
    if width == 1:
        direct = DirectIndex(2000, wide=False)
        numbers_d, firsts_d = direct.number_new(keys, 5)
        assert numbers_d.tolist() == expected and firsts_d.tolist() == firsts_h.tolist()
        assert direct.lookup(keys).tolist() == expected


def test_make_index_picks_direct_for_small_key_spaces() -> None:
    assert isinstance(make_index(StateEncoding([(0, 99, False)]), wide=False), DirectIndex)
    assert isinstance(make_index(StateEncoding([(0, 2**30, False)]), wide=False), HashIndex)
    assert isinstance(make_index(StateEncoding([(0, 2**40, False)] * 2), wide=False), HashIndex)


def _walker(high: int, dims: int) -> object:
    """Steps of high/3 up to high and back to 0, per variable: at most 5 values each."""
    names = [f"v{i}" for i in range(dims)]
    cmds = [
        cmd(
            "m",
            None,
            "true",
            upd(0.5, (n, f"min({n} + {high // 3}, {high})")),
            upd(0.5, (n, f"0 if {n} == {high} else {n}")),
        )
        for n in names
    ]
    return flat_model(
        A.ModelType.MDP, [var(n, 0, high, module="m") for n in names], [module("m", names, cmds)]
    )


def test_hash_index_model_equals_reference() -> None:
    # one variable over [0..10^9]: key space above the direct table's limit
    flat = _walker(10**9, 1)
    compare_with_reference(flat)  # type: ignore[arg-type]
    # 0 -> 333333333 -> 666666666 -> 999999999 -> 10^9 (min with high), back to 0: 5 states
    assert build_model(flat).model.num_states == 5  # type: ignore[arg-type]


def test_multi_word_model_equals_reference() -> None:
    # three variables over [0..2^40]: 123 bits, two key words
    flat = _walker(2**40, 3)
    compare_with_reference(flat)  # type: ignore[arg-type]


def test_hash_index_builds_the_same_model_as_the_direct_table(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from posgmc.compiler import state_space
    from tests.compiler.flatlib import pursuit

    direct = build_model(pursuit(5)).model
    monkeypatch.setattr(state_space, "DIRECT_LIMIT", 1)
    hashed = build_model(pursuit(5)).model
    assert hashed.num_states == direct.num_states
    assert np.array_equal(hashed.state_values, direct.state_values)
    assert (hashed.transitions != direct.transitions).nnz == 0
