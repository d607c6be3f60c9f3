"""Adam on a randomised FSS's logits: the one ascent loop every search of posgmc's synthesis uses
(against the omniscient adversary, against a set of adversary strategies, and the adversary's
best response against a fixed defence)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from posgmc.synthesis.budget import expired

__all__ = ["LOGIT", "ascend"]

LOGIT = 4.0
"""Logits stay in [-LOGIT, LOGIT]: every probability stays above ~e^-2L, so the sound check of the
result converges (near-deterministic loops make interval iteration crawl)."""

Step = Callable[[np.ndarray, np.ndarray], tuple[float, np.ndarray, np.ndarray]]
"""(logits of γ, logits of δ) -> (objective, its gradient in both), the objective to maximise."""


def ascend(step: Step, la: np.ndarray, ld: np.ndarray, *, iterations: int, learning_rate: float,
           deadline: float | None) -> tuple[tuple[np.ndarray, np.ndarray], float, int]:
    """``iterations`` Adam steps that maximise ``step``'s objective from (la, ld), fewer when
    ``deadline`` (a ``time.perf_counter()`` value: the wall-clock cap) passes first. Returns the
    best iterate seen, its objective and the number of evaluations."""
    best_val, best = -np.inf, (la.copy(), ld.copy())
    ma, va = np.zeros_like(la), np.zeros_like(la)
    md, vd = np.zeros_like(ld), np.zeros_like(ld)
    b1, b2, eps = 0.9, 0.999, 1e-8
    n = 0
    for t in range(1, iterations + 1):
        if expired(deadline):
            break
        value, ga, gd = step(la, ld)
        n += 1
        if value > best_val:
            best_val, best = value, (la.copy(), ld.copy())
        ma = b1 * ma + (1 - b1) * ga
        va = b2 * va + (1 - b2) * ga * ga
        md = b1 * md + (1 - b1) * gd
        vd = b2 * vd + (1 - b2) * gd * gd
        rate = learning_rate * np.sqrt(1 - b2**t) / (1 - b1**t)
        la = np.clip(la + rate * ma / (np.sqrt(va) + eps), -LOGIT, LOGIT)
        ld = np.clip(ld + rate * md / (np.sqrt(vd) + eps), -LOGIT, LOGIT)
    return best, best_val, n
