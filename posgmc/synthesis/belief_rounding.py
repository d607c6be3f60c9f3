"""The float rounding bounds of the grid abstraction (:mod:`posgmc.synthesis.belief_grid`),
and the scaling that keeps a minimiser's choices below the exact belief successors.

The abstraction's transition probabilities are computed in float64 (posterior beliefs, the
weights λ). Each computed quantity gets an a-priori bound on its distance from the exact one
(:func:`rounding`, :func:`entry_rounding`, :func:`weight_errors`: Higham's bounds for sums of
nonnegative products); stop masses, rewards and cut-off values are moved to the optimistic side
with them (:func:`outward` for either sign, :func:`up`), and a minimiser's choices are scaled
below the exact belief successors (:func:`dominate`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from posgmc.synthesis.freudenthal import SNAP

__all__ = ["UNIT", "chunks", "dominate", "entry_rounding", "outward", "reward_magnitude",
           "rounding", "up", "weight_errors"]


_BATCH_ELEMENTS = 2_000_000
"""A vectorised triangulation lays out parts × m × m counts; kept below this many."""


def chunks(sizes: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(support size m, indices of the parts of that size) in chunks of at most
    :data:`_BATCH_ELEMENTS` counts."""
    out: list[tuple[int, np.ndarray]] = []
    for m in np.unique(sizes).tolist():
        sel = np.flatnonzero(sizes == m)
        step = max(1, _BATCH_ELEMENTS // (m * m))
        out.extend((m, sel[i:i + step]) for i in range(0, sel.size, step))
    return out


UNIT = 2.0 ** -53
"""float64's unit roundoff u: an operation's result is the exact one times (1 + e), |e| <= u."""


def rounding(terms: np.ndarray | int) -> np.ndarray:
    """A bound, relative to the computed value, on the rounding error of a float64 sum of at
    most ``terms`` products of nonnegative rounded numbers: 2 (k + 2) u, twice the classic
    γ_{k+2} = (k + 2) u / (1 - (k + 2) u) (Higham, "Accuracy and Stability of Numerical
    Algorithms", §3.1; with nonnegative terms the error is relative to the sum itself)."""
    return 2.0 * (np.asarray(terms, dtype=np.float64) + 2.0) * UNIT


def up(v: np.ndarray) -> np.ndarray:
    """``v`` rounded up to the next float, zeros kept (a zero is exact: a structural zero
    must not become an edge)."""
    return np.where(v > 0, np.nextafter(v, np.inf), v)


def outward(v: np.ndarray, err: np.ndarray, up: bool) -> np.ndarray:
    """``v + err`` rounded up (``up``) or ``v - err`` rounded down, for values of either sign
    (``err`` >= 0); exact where ``err`` is 0 (a structural zero stays one)."""
    moved = v + err if up else v - err
    out: np.ndarray = np.where(err > 0, np.nextafter(moved, np.inf if up else -np.inf), moved)
    return out


def reward_magnitude(rew: np.ndarray, rewards: np.ndarray) -> np.ndarray:
    """What the rounding of a belief's reward (a float sum of belief mass times reward) is
    relative to: the computed sum's magnitude when the model's rewards have one sign (the
    products then share it), else the largest |reward| (the products' magnitudes sum to at
    most that, the masses summing to at most one, rounding aside)."""
    mag = np.abs(rew)
    if rewards.size and bool((rewards < 0).any()) and bool((rewards > 0).any()):
        mag = np.maximum(mag, up(np.asarray(float(np.max(np.abs(rewards))) * (1.0 + 4.0 * UNIT))))
    return np.asarray(mag, dtype=np.float64)


def entry_rounding(terms: np.ndarray, input_rel: float) -> np.ndarray:
    """A bound, relative to the computed value, on how far a continuing successor entry (or a
    stop mass, or a reward) of the exact model lies from its float: the float sum's own
    rounding (:func:`rounding`, doubled for the adversary's rules: a product more, and the
    exact rule's distance to the stored one,
    :func:`~posgmc.synthesis.belief_exact._rational_rule`), the stored rows' distance to the exact
    ones (``input_rel``), and the vertex belief's (counts/N is exact for N a power of two, one
    rounding otherwise)."""
    return 2.0 * rounding(terms) + input_rel + 2.0 * UNIT


def weight_errors(P: np.ndarray, lam: np.ndarray, rel: np.ndarray, resolution: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far the exact decomposition of each part may lie from the float one.

    ``P``: float64[n, m], the parts' float posteriors (as triangulated by
    :func:`~posgmc.synthesis.freudenthal.freudenthal_batch`, weights ``lam``); ``rel``:
    float64[n], the relative bound on each part's continuing entries (:func:`entry_rounding`).
    The exact posterior's cumulative coordinates x*_i = N Σ_{j>=i} y*_j / Σ_j y*_j lie within
    Δ_i = N (3 rel + 4 (m + 4) u) of the float ones (a ratio of sums of nonnegative terms, each
    within ``rel``, and the float division and cumulative sum), plus the snap's displacement;
    the barycentric weight of each vertex of the float simplex is a difference of two sorted
    fractional parts (one rounding), so the exact weights in that simplex are within
    ε = 2 max Δ + 2u of ``lam``.

    Returns:
        (float64[n, m] η, bool[n] ambiguous, float64[n] Δ'): where every weight exceeds ε the
        exact posterior lies in the float simplex with the same vertices and each exact vertex
        weight e* = w* λ* is at most (1 + η) times the float one (w* the exact part mass);
        elsewhere the part is *ambiguous* (near a face: the exact simplex may differ). Δ' bounds
        |x* - x̃| for the exact combination x̃ of the float weights (for the leak).
    """
    n, m = P.shape
    u = UNIT
    if m == 1:
        return np.full((n, 1), (rel[:, None] + 4.0 * u) * 1.02), np.zeros(n, dtype=bool), \
            np.zeros(n)
    N = float(resolution)
    x = N * np.cumsum(P[:, ::-1], axis=1)[:, ::-1]
    x[:, 0] = N
    dist = np.abs(x - np.rint(x))
    snap = np.where(dist <= SNAP * N, dist, 0.0)
    delta = N * (3.0 * rel[:, None] + 4.0 * (m + 4) * u) + snap
    dmax = delta.max(axis=1) + (m + 2) * u * N
    eps = 2.0 * dmax + 2.0 * u
    ambiguous = (lam <= eps[:, None]).any(axis=1)
    with np.errstate(divide="ignore"):
        eta = (rel[:, None] + (m + 3) * u + eps[:, None] / np.where(lam > 0, lam, 0.0)) * 1.02 \
            + 4.0 * u
    return eta, ambiguous, dmax


def dominate(E: sp.csr_matrix, G: sp.csr_matrix, Y: sp.csr_matrix,
             terms: np.ndarray) -> sp.csr_matrix:
    """The vertex weights of a minimiser's choices, scaled so that they stay below the exact
    belief successors despite floating point.

    Row i of ``E`` (float64[n, V]) weighs grid vertices (``G``: float64[V, S], vertex j's belief
    counts/N) so that x_i = E_i G approximates y_i, the exact continuing successor vector of the
    choice (computed as ``Y``'s row with at most ``terms[i]`` products per entry). Rounding, the
    snapping of near-integer coordinates and the weights' own rounding make x_i differ from y_i.
    With V* the optimum as a function of an unnormalised belief — nonnegative, monotone,
    positively homogeneous and, for a minimiser, superlinear (an infimum of linear functions:
    one per strategy) — any κ_i <= 1 with κ_i x_i <= y_i entry by entry gives
    V*(y) >= V*(κx) + V*(y - κx) >= κ V*(x) >= κ Σ_j E_ij V*(u_j). κ_i is the minimum over
    x_i's support of a lower bound of y over an upper bound of x (the a-priori bounds of
    :func:`rounding`), rounded down; the mass given up goes to the sink (probability) or the
    target (reward), both worth 0 to the minimiser.

    Returns:
        κ E.
    """
    n = E.shape[0]
    if not n:
        return E
    X = sp.csr_matrix(E @ G)
    X.sum_duplicates()
    ax = rounding(np.diff(E.indptr) + 1)  # the products E_ij G_js, G one rounding off counts/N
    ay = rounding(terms)
    Xc = X.tocoo()
    rows = Xc.row.astype(np.int64)
    y_at = np.asarray(Y[rows, Xc.col]).ravel() if rows.size else np.zeros(0)
    ratio = (y_at * (1.0 - ay[rows])) / (Xc.data * (1.0 + ax[rows])) * (1.0 - 4.0 * UNIT)
    kappa = np.ones(n)
    np.minimum.at(kappa, rows, np.maximum(ratio, 0.0))
    return sp.csr_matrix(sp.diags(kappa) @ E)
