"""Choices named for strategies: a label unique in its state stays, the others become the choice's
local index (``#k``), as Storm and PAYNT name choices."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.model.actions import choices_by_index


def test_distinct_labels_are_kept() -> None:
    # two states: [a, b] and [a]; no state repeats a label
    acts = np.array([1, 2, 1], dtype=np.int32)
    assert choices_by_index(acts, np.array([0, 2, 3]), ("", "a", "b")) is None


def test_unlabelled_and_shared_labels_become_local_indices() -> None:
    # state 0: '', '' (a DRN without choice labels); state 1: a, a, b; state 2: '' alone
    acts = np.array([0, 0, 1, 1, 2, 0], dtype=np.int32)
    named = choices_by_index(acts, np.array([0, 2, 5, 6]), ("", "a", "b"))
    assert named is not None
    ids, names = named
    assert names == ("", "a", "b", "#0", "#1")
    assert [names[i] for i in ids.tolist()] == ["#0", "#1", "#0", "#1", "b", ""]
    assert ids.dtype == acts.dtype


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.lists(st.integers(0, 3), min_size=1, max_size=5), min_size=1, max_size=8)
)
def test_every_state_offers_distinct_names(states: list[list[int]]) -> None:
    acts = np.array([a for s in states for a in s], dtype=np.int32)
    groups = np.concatenate([[0], np.cumsum([len(s) for s in states])])
    base = ("", "a", "b", "c")
    named = choices_by_index(acts, groups, base)
    ids, names = named if named is not None else (acts, base)
    assert names[: len(base)] == base
    for s, labels in enumerate(states):
        got = [names[i] for i in ids[groups[s] : groups[s + 1]].tolist()]
        assert len(set(got)) == len(got)
        for k, (label, name) in enumerate(zip(labels, got)):
            # a label unique in its state is kept; the others are the local index
            assert name == (base[label] if labels.count(label) == 1 else f"#{k}")


def test_a_wide_state_takes_the_sorting_path() -> None:
    # 12 choices in one state (more than the pairwise passes handle): labels a, '', a, '', ...
    acts = np.array([1, 0] * 6, dtype=np.int32)
    named = choices_by_index(acts, np.array([0, 12]), ("", "a"))
    assert named is not None
    ids, names = named
    assert [names[i] for i in ids.tolist()] == [f"#{k}" for k in range(12)]
