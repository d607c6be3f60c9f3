"""The strategy of an occupation-LP solution, and the Markov chain it induces, for re-checking
the LP's answer with the sound engines.

From a solution ``x = (y, z)`` of :class:`~posgmc.engines.multi.lp.OccupationLP` (Forejt et al.,
TACAS 2011, and PRISM's construction): in state ``s`` before settling, with ``T(s) = sum_{c of s}
y[c] + sum_{k at s} z[k]``, take choice ``c`` with probability ``y[c] / T(s)``, or settle in
option ``k`` with probability ``z[k] / T(s)``; once settled in option ``k``, play the internal
choices of its end component (:class:`~posgmc.engines.multi.settle.Settling`) uniformly for ever.
Where ``T(s) = 0`` (a state the solution never visits) the first choice is taken. The strategy
is randomised with one bit of memory per component (settled or not), on the LP's MDP (the
model's product with the objectives' automata, unfolded by steps for cumulative rewards).

**Any** non-negative ``x`` gives a strategy this way, whether or not it solves the LP exactly; so
the values the sound engines compute on the induced chain (:func:`occupation_chain`) are proven
values **of that strategy**: a proven lower bound on what the best strategy achieves for a
maximised objective (upper, for a minimised one), whatever HiGHS's floating-point errors were.
A probability objective is counted only for paths that settle in a component satisfying it (a
path that satisfies it otherwise is not counted), so its value on the chain is a lower bound on
the strategy's own probability of the condition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines.multi.settle import Settling
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType

__all__ = ["InducedChain", "occupation_chain"]


@dataclass(frozen=True, eq=False)
class InducedChain:
    """``model``: the dtmc, states ``0..S-1`` the LP's MDP before settling, then one state per
    (component, state of it); its labels ``sat<i>`` (the settled states satisfying condition i).
    ``choice_probability``: float64[C + K], the strategy's probability of each choice and
    settling option in its state. ``rewards``: objective index -> float64[n], the expected
    reward of each chain state (its one choice) under the strategy."""

    model: ExplicitModel
    choice_probability: np.ndarray
    rewards: dict[int, np.ndarray]


def occupation_chain(
    transitions: sp.csr_matrix,
    row_groups: np.ndarray,
    initial: int,
    settling: Settling,
    x: np.ndarray,
    rewards: dict[int, np.ndarray],
) -> InducedChain:
    """The dtmc of the LP solution ``x``'s strategy (module docstring).

    Args:
        transitions: csr [C, S] of the LP's MDP, grouped by ``row_groups``.
        initial: its initial state.
        settling: its settling options and components.
        x: float64[C + K], an LP solution (negative entries, floating-point noise, count as 0).
        rewards: objective index -> float64[C], non-negative choice rewards.
    """
    num_choices, num_states = transitions.shape
    owner = np.repeat(np.arange(num_states), np.diff(row_groups))
    y = np.clip(x[:num_choices], 0.0, None)
    z = np.clip(x[num_choices:], 0.0, None)
    total = np.bincount(owner, weights=y, minlength=num_states)
    total += np.bincount(settling.stop_state, weights=z, minlength=num_states)
    unvisited = total <= 0
    first = row_groups[:-1]
    py = np.where(total[owner] > 0, y / np.where(total[owner] > 0, total[owner], 1.0), 0.0)
    py[first[unvisited]] = 1.0
    pz = np.where(
        total[settling.stop_state] > 0,
        z / np.where(total[settling.stop_state] > 0, total[settling.stop_state], 1.0),
        0.0,
    )
    # the settled copies: one per (component, state of it), numbered after the S states, in
    # the order of the key block * S + state (components' states are sorted)
    num_blocks = len(settling.block_states)
    sizes = np.array([b.size for b in settling.block_states], dtype=np.int64)
    n = num_states + int(sizes.sum())
    all_block = np.repeat(np.arange(num_blocks, dtype=np.int64), sizes)
    all_state = (np.concatenate(settling.block_states) if num_blocks
                 else np.zeros(0, dtype=np.int64))
    keys = all_block * num_states + all_state

    def copy(block: np.ndarray, state: np.ndarray) -> np.ndarray:
        found: np.ndarray = num_states + np.searchsorted(keys, block * num_states + state)
        return found

    # before settling: sum_c py[c] P(c, .) + sum_k pz[k] e_{copy(block k, s)}
    pick = sp.csr_matrix((py, (owner, np.arange(num_choices))), shape=(num_states, num_choices))
    moves = (pick @ transitions).tocoo()
    k_cols = copy(settling.stop_block, settling.stop_state)
    # settled: the component's internal choices uniformly, successors mapped into the copy
    b_rows = np.concatenate(
        [np.full(c.size, b, dtype=np.int64) for b, c in enumerate(settling.block_choices)]
        or [np.zeros(0, np.int64)]
    )
    b_choices = (np.concatenate(settling.block_choices) if num_blocks
                 else np.zeros(0, dtype=np.int64))
    src = copy(b_rows, owner[b_choices])
    count = np.bincount(src - num_states, minlength=n - num_states).astype(float)
    sub = transitions[b_choices].tocoo()
    s_rows = src[sub.row]
    s_cols = copy(b_rows[sub.row], sub.col)
    s_data = sub.data / count[s_rows - num_states]
    matrix = sp.csr_matrix(
        (np.concatenate([moves.data, pz, s_data]),
         (np.concatenate([moves.row, settling.stop_state, s_rows]),
          np.concatenate([moves.col, k_cols, s_cols]))),
        shape=(n, n),
    )
    labels = {}
    for i in range(settling.stop_sat.shape[1]):
        block_sat = np.zeros(num_blocks, dtype=bool)
        block_sat[settling.stop_block[settling.stop_sat[:, i]]] = True
        lab = np.zeros(n, dtype=bool)
        lab[num_states:] = block_sat[all_block]
        labels[f"sat{i}"] = lab
    chain_rewards = {}
    for j, r in rewards.items():
        state = np.zeros(n)
        state[:num_states] = np.bincount(owner, weights=py * r, minlength=num_states)
        chain_rewards[j] = state
    model = make_model(ModelType.DTMC, np.arange(n + 1), matrix, initial_states=(initial,),
                       labels=labels)
    return InducedChain(model, np.concatenate([py, pz]), chain_rewards)
