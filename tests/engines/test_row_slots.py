"""The slot layout's optimum and first optimal row agree with ``reduceat`` and a scan of each
state's rows, for any row groups (hypothesis: random counts >= 1 and values with ties)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines.row_slots import RowSlots


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(1, 4), min_size=1, max_size=30), st.integers(0, 2**32 - 1),
       st.sampled_from([np.maximum, np.minimum]))
def test_slots_agree_with_reduceat(counts_list: list[int], seed: int, ufunc: np.ufunc) -> None:
    counts = np.array(counts_list, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    values = np.random.default_rng(seed).integers(0, 3, size=int(counts.sum())).astype(float)
    by_slot = RowSlots.of(starts, counts)
    assert sorted(by_slot.order.tolist()) == list(range(values.size))  # every row once
    best = by_slot.best(values[by_slot.order], ufunc)
    assert np.array_equal(best, ufunc.reduceat(values, starts))
    pick = by_slot.first_attaining(values[by_slot.order], best)
    first = [next(j for j in range(c) if values[s + j] == b)
             for s, c, b in zip(starts.tolist(), counts.tolist(), best.tolist())]
    assert pick.tolist() == first


def test_one_row_per_state_is_a_copy() -> None:
    by_slot = RowSlots.of(np.arange(3), np.ones(3, dtype=np.int64))
    assert by_slot.slots == () and by_slot.order.tolist() == [0, 1, 2]
    assert by_slot.best(np.array([3.0, 1.0, 2.0]), np.maximum).tolist() == [3.0, 1.0, 2.0]
