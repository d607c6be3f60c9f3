"""Long-run behaviour of a dtmc: steady-state probabilities (PRISM's ``S``) and long-run average
rewards (``R[S]``), with bounds that hold.

In the long run a dtmc is in one of its bottom strongly connected components (BSCCs), and inside
BSCC ``B`` it spends the fraction ``pi_B(t)`` of time in state ``t``, where ``pi_B`` is the
stationary distribution of ``B`` (``pi_B P_B = pi_B``, ``sum pi_B = 1``; unique since ``B`` is
irreducible). The long-run average of a per-state weight ``w`` (an indicator for ``S``, the reward
per step for ``R[S]``) from state ``s`` is therefore

    sum over B of  P_s(F B) * g_B,   g_B = sum_{t in B} pi_B(t) w(t)

(Baier & Katoen, *Principles of Model Checking*, 10.5; PRISM's ``DTMCModelChecker``).

Bounds: a model of at most ``EXACT_LIMIT`` states is solved entirely over the rationals (the
probabilities read as the decimals the model was written with, as :mod:`posgmc.engines.rational`
does) and the value rounded outward. On larger models ``pi_B`` is solved exactly for BSCCs of at
most ``EXACT_LIMIT`` states (larger BSCCs in floating point, and the result is then reported as not
sound), ``P_s(F B)`` comes with proven bounds from the reachability engine, and the combination
uses interval arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from posgmc.engines import objectives as obj
from posgmc.engines.options import SolverOptions
from posgmc.engines.rational import exact_rational_reach, solve_dense
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["EXACT_LIMIT", "LongRun", "as_fractions", "bsccs", "long_run_average", "long_run_exact"]

EXACT_LIMIT = 200
"""BSCCs up to this many states get their stationary distribution in exact arithmetic."""

_DENOMINATOR = 10**12  # recovers the decimals a model's probabilities were written with


@dataclass(frozen=True)
class LongRun:
    """Per-state long-run averages: ``values``, proven ``lower``/``upper`` when ``sound``."""

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    sound: bool
    iterations: int
    converged: bool


def _state_matrix(model: ExplicitModel) -> sp.csr_matrix:
    if model.model_type is not ModelType.DTMC:
        raise UnsupportedError(
            "steady-state probabilities (S) and long-run average rewards (R[S]) are computed for "
            f"dtmcs only (the model is {_article(model.model_type.value)})",
            hint="PRISM computes them for dtmcs and ctmcs; on an mdp ask for reachability or "
            "total rewards instead")
    return model.transitions  # csr; one choice per state: rows are states


def _article(name: str) -> str:
    return f"an {name}" if name[0] in "aeiou" else f"a {name}"


def bsccs(model: ExplicitModel) -> list[np.ndarray]:
    """The bottom strongly connected components of a dtmc, each as a sorted array of states."""
    p = _state_matrix(model)
    n, labels = connected_components(p, directed=True, connection="strong")
    source = np.repeat(np.arange(model.num_states), np.diff(p.indptr))
    leaving = labels[source] != labels[p.indices]
    not_bottom = np.zeros(n, dtype=bool)
    not_bottom[labels[source[leaving]]] = True
    order = np.argsort(labels, kind="stable")
    groups = np.split(order, np.cumsum(np.bincount(labels, minlength=n))[:-1])
    return [np.sort(g) for c, g in enumerate(groups) if not not_bottom[c]]


def _stationary_exact(p: sp.csr_matrix, states: np.ndarray,
                      exact: np.ndarray | None = None) -> list[Fraction]:
    """pi with pi P_B = pi, sum pi = 1, over the rationals (one balance equation replaced by the
    normalisation)."""
    k = states.size
    index = {int(s): i for i, s in enumerate(states)}
    # A = (P_B^T - I) with the last row replaced by ones
    a = [[Fraction(0)] * k for _ in range(k)]
    for i, s in enumerate(states):
        row = slice(p.indptr[s], p.indptr[s + 1])
        probs = (exact[row] if exact is not None
                 else [Fraction(float(x)).limit_denominator(_DENOMINATOR) for x in p.data[row]])
        for t, prob in zip(p.indices[row], probs):
            j = index.get(int(t))
            if j is not None:
                a[j][i] += prob
        a[i][i] -= 1
    a[k - 1] = [Fraction(1)] * k
    rhs = [Fraction(0)] * (k - 1) + [Fraction(1)]
    return solve_dense(a, rhs)


def _stationary_float(p: sp.csr_matrix, states: np.ndarray) -> np.ndarray:
    sub = p[states][:, states].tocsc()
    k = states.size
    a = (sub.T - sp.identity(k, format="csc")).tolil()
    a[k - 1, :] = np.ones(k)
    rhs = np.zeros(k)
    rhs[-1] = 1.0
    pi = spla.spsolve(a.tocsc(), rhs)
    return np.clip(np.asarray(pi, dtype=np.float64), 0.0, 1.0)


def _outward(values: list[Fraction]) -> tuple[np.ndarray, np.ndarray]:
    near = np.array([float(v) for v in values])
    below = np.array([Fraction(float(v)) > v for v in values], dtype=bool)
    above = np.array([Fraction(float(v)) < v for v in values], dtype=bool)
    return (np.where(below, np.nextafter(near, -np.inf), near),
            np.where(above, np.nextafter(near, np.inf), near))


def long_run_exact(model: ExplicitModel, weight: list[Fraction]) -> list[Fraction]:
    """The long-run average of ``weight`` from every state, over the rationals (a small dtmc;
    a model built in exact mode is read exactly).

    Raises:
        UnsupportedError: the model is not a dtmc.
    """
    p = _state_matrix(model)
    S = model.num_states
    total = [Fraction(0)] * S
    nobody = np.zeros(S, dtype=bool)
    for states in bsccs(model):
        pi = _stationary_exact(p, states, model.exact_probabilities)
        g = sum((q * weight[int(t)] for q, t in zip(pi, states)), Fraction(0))
        if g == 0:
            continue
        target = np.zeros(S, dtype=bool)
        target[states] = True
        reach = exact_rational_reach(model, target, maximize=nobody, limit_denominator=_DENOMINATOR)
        total = [a + r * g for a, r in zip(total, reach)]
    return total


def as_fractions(weight: np.ndarray) -> list[Fraction]:
    """Per-state weights as the decimals they were written as."""
    return [Fraction(float(w)).limit_denominator(_DENOMINATOR) for w in weight]


def _long_run_exact(model: ExplicitModel, weight: np.ndarray) -> LongRun:
    """Everything over the rationals (a small model): the bounds are the value rounded outward."""
    lower, upper = _outward(long_run_exact(model, as_fractions(weight)))
    return LongRun((lower + upper) / 2, lower, upper, True, 0, True)


def long_run_average(model: ExplicitModel, weight: np.ndarray, *,
                     options: SolverOptions | None = None) -> LongRun:
    """The long-run average of ``weight`` (float64[S], any sign) from every state of a dtmc.

    Raises:
        UnsupportedError: the model is not a dtmc.
    """
    options = options or SolverOptions()
    p = _state_matrix(model)
    S = model.num_states
    if S <= EXACT_LIMIT:
        return _long_run_exact(model, weight)
    lower = np.zeros(S)
    upper = np.zeros(S)
    values = np.zeros(S)
    sound, converged, iterations = True, True, 0
    everyone = np.zeros(S, dtype=bool)  # a dtmc: nobody maximises
    for states in bsccs(model):
        w = weight[states].astype(np.float64)
        if states.size <= EXACT_LIMIT:
            pi_lo, pi_hi = _outward(_stationary_exact(p, states, model.exact_probabilities))
            pi = (pi_lo + pi_hi) / 2
        else:
            pi = _stationary_float(p, states)
            pi_lo = pi_hi = pi
            sound = False
        g = float(pi @ w)
        g_lo = float(np.sum(np.minimum(pi_lo * w, pi_hi * w)))
        g_hi = float(np.sum(np.maximum(pi_lo * w, pi_hi * w)))
        g_lo, g_hi = np.nextafter(g_lo, -np.inf), np.nextafter(g_hi, np.inf)  # the sums' rounding
        target = np.zeros(S, dtype=bool)
        target[states] = True
        if states.size == S:
            reach_lo = reach_hi = reach = np.ones(S)
        else:
            r = obj.reach_probability(
                model, target, remain=None, maximize=everyone, options=options
            )
            reach, reach_lo, reach_hi = r.values, r.lower, r.upper
            sound &= r.sound
            converged &= r.converged
            iterations += r.iterations
        values += reach * g
        corners = np.stack([reach_lo * g_lo, reach_lo * g_hi, reach_hi * g_lo, reach_hi * g_hi])
        lower += corners.min(axis=0)
        upper += corners.max(axis=0)
    slack = (
        4 * np.finfo(np.float64).eps * (np.abs(lower) + np.abs(upper)) * max(1, len(bsccs(model)))
    )
    return LongRun(values, lower - slack, upper + slack, sound, iterations, converged)
