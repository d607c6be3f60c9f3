"""The record every numerical engine returns: values with proven bounds and provenance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posgmc.engines.options import Method

__all__ = ["EngineResult"]


@dataclass(frozen=True, eq=False)
class EngineResult:
    """The answer of one engine call, for every state of the model.

    ``values``: float64[S], the reported value (the midpoint of the bounds for interval methods; may
    be ``inf``). ``lower``/``upper``: float64[S], proven bounds when ``sound`` (for ``Method.VALUE``
    both equal ``values`` and ``sound`` is False). ``iterations``: iterations (or policy-iteration
    rounds) performed; ``converged``: the requested precision was reached. ``strategy``: int64[S],
    the chosen choice (a global row index of the transition matrix) of each state, -1 where no
    decision matters; None for step-bounded objectives (their optimal strategies need a step
    counter) or when not asked for. For a game the strategy holds both players' choices (a profile).
    """

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    iterations: int
    converged: bool
    method: Method
    seconds: float
    sound: bool
    strategy: np.ndarray | None = None
