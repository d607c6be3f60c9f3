"""The product of a game with the decision maker's FSS, refilled for another FSS of the same
support instead of rebuilt.

A search evaluates thousands of FSSs of one memory size k whose probabilities change from step to
step but whose *support* (which actions γ(n, z, ·) and memory updates δ(n, z, a, ·) are positive)
does not: a softmax never gives 0. The product's reachable states, its rows and the pattern of
its transition matrix depend only on that support, and every transition probability of a row of
the decision maker is linear in the joint weights γδ(n, z, a, n') = γ(n, z, a) δ(n, z, a, n'):

    P((s, n), (s', n')) = Σ_a γδ(n, z(s), a, n') T(c_a(s), s')

(c_a(s) the choice of s labelled a; the other players' rows are the model's, memory unchanged).
So the product is built once per support by :func:`~posgmc.strategies.product.strategy_product`
(which also validates it), the coefficients T(c, s') are laid out as a sparse matrix A from
γδ to the product's stored entries, and another FSS of the same support gets its product's
transition data as ``fixed + A @ γδ`` (vectorised), the rest of the product unchanged. Only the
transition matrix is refilled: the action-reward structures mixed by γ are not, so a template
serves probability objectives only (:meth:`ProductTemplate.refill` is not asked otherwise).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import concat_ranges, row_of_entries
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.product import StrategyProduct

__all__ = ["ProductTemplate", "support_key"]


def support_key(gamma: np.ndarray, delta: np.ndarray) -> bytes:
    """The support of an FSS given as γ[k, Zu, Au] and δ[k, Zu, Au, k] (the updates of actions
    not played do not count): equal keys, equal product structure."""
    played = gamma > 0
    return np.packbits(played).tobytes() + np.packbits((delta > 0) & played[..., None]).tobytes()


@dataclass(frozen=True, eq=False)
class ProductTemplate:
    """A product and the linear map from γδ to its transition data: ``product`` (built for some
    FSS of support ``key``), ``coefficients`` csr float64[nnz, k·Zu·Au·k], ``fixed``
    float64[nnz] (the other players' entries; 0 on the decision maker's rows)."""

    key: bytes
    product: StrategyProduct
    coefficients: sp.csr_matrix
    fixed: np.ndarray

    @staticmethod
    def of(model: ExplicitModel, product: StrategyProduct, key: bytes, *, owned: np.ndarray,
           obs_index: np.ndarray, act_index: np.ndarray, state_obs: np.ndarray,
           shape: tuple[int, int, int]) -> ProductTemplate | None:
        """The template of ``product`` (of ``model`` with one FSS of support ``key`` and memory
        nodes 0..k-1). ``owned``: bool[S], the decision maker's states; ``obs_index``/
        ``act_index``: its observation and label of each model observation/action in the
        layout (-1: none); ``state_obs``: int64[S], its observation of each state; ``shape``:
        (k, Zu, Au). None when an entry of the product is not accounted for (then the product
        is not refillable and is rebuilt for every FSS)."""
        k, Zu, Au = shape
        pm = product.model
        P = pm.num_states
        T = model.transitions
        rg = model.row_groups
        where = np.full(model.num_states * k, -1, dtype=np.int64)
        nodes = product.memory_of[:, 0]
        where[product.state_of * k + nodes] = np.arange(P)
        played = np.frombuffer(key, dtype=np.uint8)
        n_g = k * Zu * Au
        g_pattern = np.unpackbits(played[: (n_g + 7) // 8])[:n_g].astype(bool)
        d_pattern = np.unpackbits(played[(n_g + 7) // 8:])[: n_g * k].astype(bool)
        # every (decision maker's product state, its choice, the choice's transition)
        mine = np.flatnonzero(owned[product.state_of])
        s = product.state_of[mine]
        counts = np.diff(rg)[s]
        c = concat_ranges(rg[s], rg[s + 1])
        of_c = np.repeat(np.arange(mine.size), counts)
        e_counts = np.diff(T.indptr)[c]
        entries = concat_ranges(T.indptr[c], T.indptr[c + 1])
        of_e = np.repeat(np.arange(c.size), e_counts)
        p_e = mine[of_c[of_e]]
        z = obs_index[state_obs[product.state_of[p_e]]]
        a = act_index[model.choice_actions[c[of_e]]]
        gi = (nodes[p_e] * Zu + z) * Au + a
        ok = (z >= 0) & (a >= 0)
        ok[ok] = g_pattern[gi[ok]]
        p_e, gi, s2, q = p_e[ok], gi[ok], T.indices[entries[ok]], T.data[entries[ok]]
        # ... and every next node the update of its action allows
        di = gi[:, None] * k + np.arange(k)[None, :]
        e_i, n2 = np.nonzero(d_pattern[di] & (q[:, None] > 0))
        target = where[s2[e_i] * k + n2]
        if np.any(target < 0):
            return None
        row = pm.row_groups[p_e[e_i]]  # the decision maker's states have one row
        Tp = pm.transitions
        stored = row_of_entries(Tp) * P + Tp.indices
        asked = row * P + target
        pos = np.searchsorted(stored, asked)
        if np.any(pos >= stored.size) or np.any(stored[np.minimum(pos, stored.size - 1)] != asked):
            return None
        ours = np.repeat(owned[product.state_of], np.diff(pm.row_groups))[row_of_entries(Tp)]
        covered = np.zeros(Tp.nnz, dtype=bool)
        covered[pos] = True
        if np.any(ours & ~covered):
            return None
        A = sp.csr_matrix((q[e_i], (pos, di[e_i, n2])), shape=(Tp.nnz, n_g * k))
        fixed = np.where(ours, 0.0, Tp.data)
        return ProductTemplate(key, product, A, fixed)

    def refill(self, gamma: np.ndarray, delta: np.ndarray) -> StrategyProduct:
        """The product with the FSS γ, δ (of this template's support). Its model has no reward
        structures (they would be the template's FSS's mixtures)."""
        joint = (gamma[..., None] * delta).ravel()
        pm = self.product.model
        T = pm.transitions
        data = self.fixed + self.coefficients @ joint
        transitions = sp.csr_matrix((data, T.indices, T.indptr), shape=T.shape)
        transitions.has_sorted_indices = True
        return dataclasses.replace(self.product,
                                   model=dataclasses.replace(pm, transitions=transitions,
                                                             reward_models=()))
