"""The randomised mixture of two finite-state strategies of one player, as one strategy.

``mix(f1, f2, alpha)`` plays ``f1`` with probability ``alpha`` and ``f2`` otherwise, the coin
tossed once, at the player's first move. As one FSS (memory nodes ``0`` + ``f1``'s + ``f2``'s): node
0 is "not decided yet", the initial node; at the first move under observation ``z`` it plays
``γ(0, z) = alpha γ1(n1, z) + (1 - alpha) γ2(n2, z)`` (``n1``, ``n2`` the two initial nodes) and
moves into ``f1``'s block with probability ``alpha γ1(n1, z)(a) δ1(n1, z, a)(n') / γ(0, z)(a)``
(likewise ``f2``'s), so that the joint law of the first action and the next node is exactly the
mixture's; from then on it is ``f1`` or ``f2``. Every expectation of the game under it (a
reachability probability, an expected, discounted or total reward) is ``alpha`` times ``f1``'s plus
``1 - alpha`` times ``f2``'s against any fixed adversary; against the worst adversary it is at least
that for a maximised objective (at most, for a minimised one): the worst adversary of the mixture is
one adversary for both. This is how a trade-off front's segments between two verified defences are
achieved (:mod:`posgmc.tradeoffs.defence`).
"""

from __future__ import annotations

import numpy as np

from posgmc.strategies.fss import FiniteStateStrategy, StrategyError

__all__ = ["mix"]


def _aligned(f: FiniteStateStrategy, rows: np.ndarray, actions: tuple[str, ...]
             ) -> tuple[np.ndarray, np.ndarray]:
    """``f``'s action and update arrays over the observation rows ``rows`` and ``actions``."""
    k = f.memory_size
    act = np.zeros((k, rows.shape[0], len(actions)))
    upd = np.zeros((k, rows.shape[0], len(actions), k))
    z_of = {tuple(r): i for i, r in enumerate(rows.tolist())}
    zs = np.array([z_of[tuple(r)] for r in f.observation_values.tolist()], dtype=np.int64)
    a_of = {a: i for i, a in enumerate(actions)}
    As = np.array([a_of[a] for a in f.actions], dtype=np.int64)
    if zs.size and As.size:
        act[:, zs[:, None], As[None, :]] = f.action
        upd[:, zs[:, None], As[None, :], :] = f.update
    return act, upd


def mix(f1: FiniteStateStrategy, f2: FiniteStateStrategy, alpha: float) -> FiniteStateStrategy:
    """``f1`` with probability ``alpha``, ``f2`` otherwise (the module docstring says how).

    Raises:
        StrategyError: the strategies are of different players or observables, or alpha is not
            in [0, 1].
    """
    if not 0.0 <= alpha <= 1.0:
        raise StrategyError(f"a mixture's weight is in [0, 1], got {alpha}")
    if f1.player != f2.player or f1.observables != f2.observables:
        raise StrategyError("only strategies of the same player over the same observables mix")
    rows = np.unique(np.vstack([f1.observation_values, f2.observation_values]), axis=0)
    actions = tuple(dict.fromkeys(f1.actions + f2.actions))
    k1, k2 = f1.memory_size, f2.memory_size
    k = 1 + k1 + k2
    Z, A = rows.shape[0], len(actions)
    a1, u1 = _aligned(f1, rows, actions)
    a2, u2 = _aligned(f2, rows, actions)
    action = np.zeros((k, Z, A))
    update = np.zeros((k, Z, A, k))
    action[1:1 + k1], update[1:1 + k1, :, :, 1:1 + k1] = a1, u1
    action[1 + k1:], update[1 + k1:, :, :, 1 + k1:] = a2, u2
    # node 0: where only one strategy has a rule, that one is played (the other never gets there)
    g1, g2 = a1[f1.initial_memory], a2[f2.initial_memory]
    has1, has2 = g1.sum(axis=1) > 0, g2.sum(axis=1) > 0
    w1 = np.where(has1 & has2, alpha, np.where(has1, 1.0, 0.0))[:, None]
    w2 = np.where(has1 & has2, 1.0 - alpha, np.where(has2, 1.0, 0.0))[:, None]
    first = w1 * g1 + w2 * g2
    action[0] = first
    safe = np.where(first > 0, first, 1.0)[:, :, None]
    update[0, :, :, 1:1 + k1] = (w1 * g1)[:, :, None] * u1[f1.initial_memory] / safe
    update[0, :, :, 1 + k1:] = (w2 * g2)[:, :, None] * u2[f2.initial_memory] / safe
    return FiniteStateStrategy.from_arrays(
        player=f1.player, initial_memory=0, observables=f1.observables,
        observation_values=rows.astype(np.int64), actions=actions, action=action, update=update,
        boolean=f1.boolean or f2.boolean,
    )
