"""The belief support as the decision maker's memory: a deterministic memory frame
(:class:`~posgmc.synthesis.fixed_memory.MemoryFrame`) whose node is the set of states the
decision maker may be in, for a randomised action map to be searched over.

A node is a set B of the decision maker's states (where it may be when it next moves). In a
state with observation z it knows B ∩ z; playing a it moves to

    post(B, z, a) = the decision maker's states reached from B ∩ z by a, then by any choices of
                    the other players and any outcomes until the decision maker moves again

— the support of every belief over B ∩ z after a, whatever the adversary does. The update is
deterministic, and the frame is the part reachable from the initial state's support. Unlike a
belief, the support does not depend on the adversary's (unknown, omniscient) strategy, so it is
the same memory against every adversary, and it is finite. It keeps what the decision maker can
infer for sure (in a grid world with deterministic own moves: its own position, by dead
reckoning, and where the adversary can no longer be), which a randomised action map needs to
keep an omniscient adversary guessing.

The frame is built breadth first, one sparse product per node (the successors of all its (z, a)
pairs at once, closed over the other players' states by repeated products); it gives up (None)
beyond a number of nodes or of (state, node) pairs, the size of the product it makes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import concat_ranges
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.binding import player_view
from posgmc.synthesis.fixed_memory import MemoryFrame
from posgmc.synthesis.problem import expired

__all__ = ["support_frame", "MAX_NODES", "MAX_PAIRS"]

MAX_NODES = 20_000
"""The most supports a frame holds."""

MAX_PAIRS = 400_000
"""The most (state, support) pairs a frame holds, summed over its supports: about the size of
the product of the model with its FSSs."""


def support_frame(model: ExplicitModel, player: int, *, max_nodes: int = MAX_NODES,
                  max_pairs: int = MAX_PAIRS, deadline: float | None = None
                  ) -> MemoryFrame | None:
    """The frame of belief supports of ``player`` reachable from the model's one initial state;
    None when there are more than ``max_nodes`` of them, more than ``max_pairs`` (state, support)
    pairs, the deadline passes, or an observation's states in one support offer no common
    action."""
    if model.initial_states.size != 1:
        return None
    S, A = model.num_states, len(model.action_names)
    owned = (model.state_players == player) if model.player_names \
        else np.ones(S, dtype=bool)
    state_obs = player_view(model, player).state_obs
    rg = model.row_groups
    cs, ca = model.choice_states, model.choice_actions
    step = sp.csr_matrix(model.transitions > 0, dtype=np.float64)  # [C, S]
    # the other players' moves, state to state: [S, S]
    theirs = np.flatnonzero(~owned[cs])
    others = sp.csr_matrix((np.ones(theirs.size), (cs[theirs], theirs)),
                           shape=(S, model.num_choices)) @ step

    def closed(reached: sp.csr_matrix) -> sp.csr_matrix:
        """Rows of states, closed under the other players' moves."""
        reached = (reached > 0).astype(np.float64).tocsr()
        while True:
            frontier = reached.multiply(~owned[None, :]).tocsr()
            grown = ((reached + frontier @ others) > 0).astype(np.float64).tocsr()
            if grown.nnz == reached.nnz:
                return reached
            reached = grown

    first = closed(sp.csr_matrix((np.ones(1), ([0], [int(model.initial_states[0])])),
                                 shape=(1, S)))
    start = first.indices[owned[first.indices]]
    supports: list[np.ndarray] = [np.sort(start)]
    index: dict[bytes, int] = {supports[0].tobytes(): 0}
    rule_node: list[np.ndarray] = []
    rule_obs: list[np.ndarray] = []
    entry_rule: list[np.ndarray] = []
    entry_action: list[np.ndarray] = []
    entry_next: list[np.ndarray] = []
    num_rules = 0
    pairs = supports[0].size
    n = 0
    while n < len(supports):
        if expired(deadline):
            return None
        states = supports[n]
        if states.size:
            # every choice of the support's states, keyed by (observation, label)
            c = concat_ranges(rg[states], rg[states + 1])
            z_c = state_obs[cs[c]]
            key = z_c * A + ca[c]
            pair_keys, pair_of_c = np.unique(key, return_inverse=True)
            # a label is offered in (n, z) when every state of z in the support offers it
            zs, per_z = np.unique(state_obs[states], return_counts=True)
            # (counted by states: a state offering one label twice counts once)
            state_label = np.unique(cs[c] * A + ca[c])
            with_label = np.bincount(
                np.searchsorted(pair_keys, state_obs[state_label // A] * A + state_label % A),
                minlength=pair_keys.size)
            pz = pair_keys // A
            offered = with_label == per_z[np.searchsorted(zs, pz)]
            covered = np.zeros(zs.size, dtype=bool)
            covered[np.searchsorted(zs, pz[offered])] = True
            if not covered.all():
                return None
            pick = sp.csr_matrix((np.ones(c.size), (pair_of_c, c)),
                                 shape=(pair_keys.size, model.num_choices))
            after = closed(pick @ step)
            kept = np.flatnonzero(offered)
            nexts = np.empty(kept.size, dtype=np.int64)
            for i, b in enumerate(kept):
                row = after.indices[after.indptr[b]:after.indptr[b + 1]]
                nxt = np.sort(row[owned[row]])
                k = nxt.tobytes()
                found = index.get(k)
                if found is None:
                    found = len(supports)
                    index[k] = found
                    supports.append(nxt)
                    pairs += nxt.size
                    if len(supports) > max_nodes or pairs > max_pairs:
                        return None
                nexts[i] = found
            z_kept = pz[kept]
            r_of = num_rules + np.searchsorted(zs, z_kept)
            rule_node.append(np.full(zs.size, n, dtype=np.int64))
            rule_obs.append(zs.astype(np.int64))
            entry_rule.append(r_of.astype(np.int64))
            entry_action.append((pair_keys[kept] % A).astype(np.int64))
            entry_next.append(nexts)
            num_rules += zs.size
        n += 1

    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)

    return MemoryFrame(len(supports), 0, cat(rule_node), cat(rule_obs), cat(entry_rule),
                       cat(entry_action), cat(entry_next))

