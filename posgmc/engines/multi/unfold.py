"""Step-bounded objectives by unfolding: the MDP in layers ``t = 0..K`` of steps taken.

Choice ``c`` of state ``s`` in layer ``t < K`` leads to the successors in layer ``t + 1``; layer
``K`` ("``K`` or more steps") loops on itself. A cumulative reward ``[C<=k]`` (``k <= K``) is the
total reward of the choices of layers ``t < k``, so step-bounded and unbounded objectives share
one occupation LP; strategies of the unfolded MDP are the step-counting strategies that bounded
objectives need. States are numbered layer-major: state ``s`` of layer ``t`` is ``t * S + s``,
choice ``c`` of layer ``t`` is ``t * C + c``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["unfold_steps", "layer_rewards"]


def unfold_steps(
    transitions: sp.csr_matrix, row_groups: np.ndarray, last: int
) -> tuple[sp.csr_matrix, np.ndarray]:
    """The unfolded matrix and row groups, layers ``0..last``."""
    layers = last + 1
    shift = sp.diags([np.ones(last)], [1], shape=(layers, layers), format="csr")
    shift = shift + sp.csr_matrix(([1.0], ([last], [last])), shape=(layers, layers))
    unfolded = sp.kron(shift, transitions, format="csr")
    unfolded.sort_indices()
    num_choices = int(row_groups[-1])
    groups = np.concatenate(
        [t * num_choices + row_groups[:-1] for t in range(layers)] + [[layers * num_choices]]
    ).astype(np.int64)
    return unfolded, groups


def layer_rewards(choice_rewards: np.ndarray, last: int, bound: int | None) -> np.ndarray:
    """Choice rewards of the unfolded MDP: in layers ``t < bound`` (all layers for None)."""
    layers = last + 1
    tiled = np.tile(choice_rewards, layers)
    if bound is not None:
        tiled[bound * choice_rewards.size:] = 0.0
    return tiled
