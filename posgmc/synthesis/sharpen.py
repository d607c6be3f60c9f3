"""Sharpening a synthesised strategy for people: probabilities within a hair of 0 or 1 become 0 or
1, and memory nodes the strategy can never enter are dropped.

The gradient search works on softmax logits, so its strategies never hold an exact 0 or 1: a
defence that is deterministic in effect prints as 0.9999 in every cell, with memory updates of
1e-5 that no one can read. :func:`sharpen` rounds every action probability and every memory-update
probability that lies within ``within`` (default 1e-3) of 0 to 0 (the rest of its distribution is
rescaled, so one within ``within`` of 1 becomes 1), and keeps only the memory nodes reachable from
the initial node through updates that the strategy plays with positive probability (over any
observation: a syntactic over-approximation of the nodes a run can enter, so no node a run enters
is dropped).

The result is a different strategy, so its number must be proven again: the caller checks it
soundly and keeps it unless the original proves strictly more (:func:`keeps_original`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posgmc.checking.results import Bound
from posgmc.strategies.fss import FiniteStateStrategy

__all__ = ["SHARPEN_WITHIN", "Sharpening", "keeps_original", "sharpen"]

SHARPEN_WITHIN = 1e-3
"""How close to 0 or 1 a probability must be to be sharpened."""


@dataclass(frozen=True, eq=False)
class Sharpening:
    """A sharpened strategy and what changed: ``probabilities`` action and update probabilities
    set to exactly 0 or 1, ``nodes_dropped`` unreachable memory nodes removed."""

    strategy: FiniteStateStrategy
    probabilities: int
    nodes_dropped: int

    @property
    def changed(self) -> bool:
        return bool(self.probabilities or self.nodes_dropped)

    def text(self) -> str:
        """``14 probabilities sharpened to 0 or 1, 1 unreachable memory node dropped``."""
        parts = []
        if self.probabilities:
            many = "probabilities" if self.probabilities != 1 else "probability"
            parts.append(f"{self.probabilities} {many} sharpened to 0 or 1")
        if self.nodes_dropped:
            parts.append(f"{self.nodes_dropped} unreachable memory node"
                         f"{'s' if self.nodes_dropped != 1 else ''} dropped")
        return ", ".join(parts)


def _sharpen_rows(rows: np.ndarray, live: np.ndarray,
                  within: float) -> tuple[np.ndarray, np.ndarray]:
    """``rows`` (distributions over the last axis, the memory node first) with each probability
    in (0, within) set to 0 and the row rescaled to sum 1, where ``live`` (rows' shape without
    the last axis) holds; a row whose every probability is that small is left alone. Returns the
    rows and, per memory node, how many probabilities became exactly 0 or 1."""
    small = (rows > 0) & (rows < within) & live[..., None]
    kept = np.where(small, 0.0, rows)
    sums = kept.sum(axis=-1, keepdims=True)
    ok = (sums[..., 0] > 0) & live
    out = np.where(ok[..., None], kept / np.where(sums > 0, sums, 1.0), rows)
    ones = ok[..., None] & (out == 1.0) & (rows != 1.0)
    zeros = ok[..., None] & small
    moved = (zeros | ones).reshape(rows.shape[0], -1).sum(axis=1)
    return out, moved


def _reachable_nodes(fss: FiniteStateStrategy, action: np.ndarray,
                     update: np.ndarray) -> np.ndarray:
    """bool[k]: the nodes reachable from the initial one through updates of played actions."""
    played = action > 0  # [k, Z, A]
    edges = np.any(played[..., None] & (update > 0), axis=(1, 2))  # [k, k]
    seen = np.zeros(fss.memory_size, dtype=bool)
    seen[fss.initial_memory] = True
    frontier = seen.copy()
    while frontier.any():
        nxt = edges[frontier].any(axis=0) & ~seen
        seen |= nxt
        frontier = nxt
    return seen


def sharpen(fss: FiniteStateStrategy, *, within: float = SHARPEN_WITHIN) -> Sharpening:
    """The strategy with probabilities within ``within`` of 0 or 1 made exact and its unreachable
    memory nodes dropped (see the module docstring); ``changed`` False when there was nothing to
    do."""
    ruled = fss.has_rule  # [k, Z]
    action, moved_a = _sharpen_rows(fss.action, ruled, within)
    update, moved_u = _sharpen_rows(fss.update, action > 0, within)
    keep = _reachable_nodes(fss, action, update)
    dropped = int((~keep).sum())
    moved = int((moved_a + moved_u)[keep].sum())  # in the nodes kept
    if dropped:
        nodes = np.flatnonzero(keep)
        action = action[nodes]
        update = update[nodes][..., nodes]
        initial = int(np.searchsorted(nodes, fss.initial_memory))
    else:
        initial = fss.initial_memory
    sharp = FiniteStateStrategy.from_arrays(
        player=fss.player, initial_memory=initial, observables=fss.observables,
        observation_values=fss.observation_values.copy(), actions=fss.actions, action=action,
        update=update, boolean=fss.boolean)
    return Sharpening(sharp, moved, dropped)


def keeps_original(original: Bound, sharpened: Bound, *, maximize: bool) -> bool:
    """Whether the original strategy proves strictly more than the sharpened one: its proven
    ``guaranteed`` bound lies beyond the sharpened one's whole interval (above it for a maximiser,
    below it for a minimiser). Otherwise the two agree within the checks' precision and the
    sharpened, readable strategy is reported. An unproven sharpened number never replaces a
    proven one."""
    if original.sound and not sharpened.sound:
        return True
    return original.lower > sharpened.upper if maximize else original.upper < sharpened.lower
