"""Where a path may settle, and which probability objectives it then satisfies.

Every probability objective of a multi-objective query is reduced (by the caller, through DFA
products and complements) to a **condition on the end component a path settles in**:

* ``INSIDE A``: the component lies within the state set ``A`` (``F G a``; and a co-safe formula
  whose accepting set ``A`` is closed under successors, so that a path satisfies it exactly when
  it settles inside ``A``; its complement is ``INSIDE`` the complement);
* ``MEETS B``: the component contains a state of ``B`` (``G F b``: visited infinitely often).

A settling option is a state ``s`` together with the set of conditions some end component
containing ``s`` satisfies when the path stays in it forever, visiting all its states (the
component's choices played uniformly at random). For ``MEETS`` conditions the maximal end
components suffice; ``INSIDE`` conditions may need a smaller component (inside ``A``), so the
components are recomputed for every subset of the ``INSIDE`` conditions (2^k decompositions,
k small). Only the maximal condition sets of each state are kept: settling with more
conditions satisfied is never worse, since every objective is in the maximising sense.

Only ``allowed`` choices may be repeated forever: the caller passes the choices that collect no
reward in any total-reward objective (a path settling elsewhere would collect infinite reward).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from itertools import combinations

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import end_components
from posgmc.errors import LimitError

__all__ = ["ConditionKind", "Condition", "Settling", "settling_options", "settling",
           "MAX_INSIDE_CONDITIONS"]

MAX_INSIDE_CONDITIONS = 10
"""At most this many ``INSIDE`` conditions (their subsets are enumerated)."""


class ConditionKind(enum.Enum):
    INSIDE = "inside"
    MEETS = "meets"


@dataclass(frozen=True, eq=False)
class Condition:
    """A condition on the settling end component; ``states``: bool[S]."""

    kind: ConditionKind
    states: np.ndarray

    def negated(self) -> Condition:
        """Not (inside A) = meets (not A); not (meets B) = inside (not B)."""
        kind = ConditionKind.MEETS if self.kind is ConditionKind.INSIDE else ConditionKind.INSIDE
        return Condition(kind, ~self.states)


@dataclass(frozen=True, eq=False)
class Settling:
    """The settling options with the end components they settle in.

    ``stop_state``: int64[K], ``stop_sat``: bool[K, n] (as :func:`settling_options`);
    ``stop_block``: int64[K], the component option k settles in; ``block_states[b]`` (int64[])
    are the states of component b and
    ``block_choices[b]`` (int64[]) its internal allowed choices (every one of their successors is
    in the component; under them, played uniformly, the component is one closed class)."""

    stop_state: np.ndarray
    stop_sat: np.ndarray
    stop_block: np.ndarray
    block_states: tuple[np.ndarray, ...]
    block_choices: tuple[np.ndarray, ...]


def settling_options(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    conditions: tuple[Condition, ...],
    *,
    allowed: np.ndarray,
    settle: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``(stop_state, stop_sat)`` of :func:`settling`."""
    found = settling(transitions, row_groups, conditions, allowed=allowed, settle=settle)
    return found.stop_state, found.stop_sat


def settling(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    conditions: tuple[Condition, ...],
    *,
    allowed: np.ndarray,
    settle: np.ndarray,
) -> Settling:
    """The settling options of an MDP.

    Args:
        transitions: csr float64 [C, S], rows grouped by ``row_groups`` (int64[S + 1]).
        conditions: the probability objectives' conditions.
        allowed: bool[C], the choices that may be repeated forever.
        settle: bool[S], the states where a path may settle (all but the transient layers of a
            step-unfolded model).

    Returns:
        The :class:`Settling`: ``stop_state`` int64[K], ``stop_sat`` bool[K, len(conditions)],
        and the component of each option.

    Raises:
        LimitError: more than :data:`MAX_INSIDE_CONDITIONS` ``INSIDE`` conditions.
    """
    num_choices, num_states = transitions.shape
    owner = np.repeat(np.arange(num_states), np.diff(row_groups))
    inside = [i for i, c in enumerate(conditions) if c.kind is ConditionKind.INSIDE]
    if len(inside) > MAX_INSIDE_CONDITIONS:
        raise LimitError(
            f"{len(inside)} objectives of the F G / co-safe kind: at most "
            f"{MAX_INSIDE_CONDITIONS} are supported"
        )
    masks = np.array([c.states for c in conditions], dtype=bool).reshape(
        len(conditions), num_states
    )
    found_state: list[np.ndarray] = []
    found_sat: list[np.ndarray] = []
    found_block: list[np.ndarray] = []
    block_states: list[np.ndarray] = []
    block_choices: list[np.ndarray] = []
    for size in range(len(inside) + 1):
        for subset in combinations(inside, size):
            region = settle.copy()
            for i in subset:
                region &= masks[i]
            # a choice may be repeated inside the region only if all its mass stays there
            leaves = transitions @ (~region).astype(float) > 0
            ok = allowed & region[owner] & ~leaves
            if not ok.any():
                continue
            mec_of, num_mecs, internal = end_components(transitions, owner, ok)
            members = np.flatnonzero(mec_of >= 0)
            if members.size == 0:
                continue
            comp = mec_of[members]
            rows = np.flatnonzero(internal)
            rows = rows[mec_of[owner[rows]] >= 0]
            by_state = np.argsort(comp, kind="stable")
            by_row = np.argsort(mec_of[owner[rows]], kind="stable")
            state_cuts = np.searchsorted(comp[by_state], np.arange(num_mecs + 1))
            row_cuts = np.searchsorted(mec_of[owner[rows]][by_row], np.arange(num_mecs + 1))
            offset = len(block_states)
            for m in range(num_mecs):
                block_states.append(members[by_state[state_cuts[m]:state_cuts[m + 1]]])
                block_choices.append(rows[by_row[row_cuts[m]:row_cuts[m + 1]]])
            found_block.append(offset + comp)
            size_of = np.bincount(comp, minlength=num_mecs)
            sat = np.zeros((num_mecs, len(conditions)), dtype=bool)
            for i, cond in enumerate(conditions):
                hits = np.bincount(
                    comp, weights=masks[i, members].astype(float), minlength=num_mecs
                )
                sat[:, i] = hits == size_of if cond.kind is ConditionKind.INSIDE else hits > 0
            found_state.append(members)
            found_sat.append(sat[comp])
    if not found_state:
        empty = np.zeros(0, dtype=np.int64)
        return Settling(empty, np.zeros((0, len(conditions)), dtype=bool), empty, (), ())
    states = np.concatenate(found_state)
    sats = np.concatenate(found_sat)
    blocks = np.concatenate(found_block)
    stop_state, stop_sat, first = _maximal(states, sats)
    return Settling(stop_state, stop_sat, blocks[first], tuple(block_states), tuple(block_choices))


def _maximal(states: np.ndarray, sats: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distinct (state, set) pairs, without sets strictly contained in another set of the same
    state; and for each the index of its first occurrence in the input."""
    n = sats.shape[1]
    packed = (sats.astype(np.int64) << np.arange(n, dtype=np.int64)).sum(axis=1) if n else \
        np.zeros(states.size, dtype=np.int64)
    width = np.int64(1) << n
    keys, first = np.unique(states.astype(np.int64) * width + packed, return_index=True)
    state, bits = keys // width, keys % width
    dominated = np.zeros(keys.size, dtype=bool)
    values = np.unique(bits)
    for v in values:
        for w in values:
            if v != w and (w & v) == v:  # w is a strict superset of v
                rows = np.flatnonzero(bits == v)
                dominated[rows] |= np.isin(state[rows] * width + w, keys)
    state, bits, first = state[~dominated], bits[~dominated], first[~dominated]
    sat = ((bits[:, None] >> np.arange(n, dtype=np.int64)) & 1).astype(bool)
    return state, sat.reshape(state.size, n), first
