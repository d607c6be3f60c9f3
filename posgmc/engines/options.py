"""Solver configuration for the numerical engines: which method, how precise, what to return."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from posgmc.errors import InputError

__all__ = ["Method", "SolverOptions"]


class Method(enum.Enum):
    """How an unbounded objective is solved.

    ``INTERVAL`` (default) returns proven bounds ``lower <= value <= upper`` whose gap is below the
    requested precision: the lower bound by value iteration from below, the upper bound guessed and
    then verified (optimistic value iteration), with end components handled (see
    :mod:`posgmc.engines.iteration`). ``VALUE`` is plain value iteration from below with the usual
    unsound stopping rule (``lower = upper = values``, ``sound = False``). ``POLICY`` is policy
    iteration with an exact linear solve per evaluation (mdp/smg; dtmc as ``EXACT``). ``EXACT`` is a
    direct sparse LU solve for a dtmc and policy iteration to optimality for an mdp/smg. Both
    report bounds proven by :func:`~posgmc.engines.certify.certify`, or by interval iteration
    where no certificate is found; ``INTERVAL`` tries that certificate too once its iteration
    turns out stiff (:mod:`posgmc.engines.solving`).
    """

    INTERVAL = "interval"
    VALUE = "value"
    POLICY = "policy"
    EXACT = "exact"


@dataclass(frozen=True)
class SolverOptions:
    """``precision``: the half-width of the reported interval (absolute, or relative to the value
    when ``relative``); ``max_iterations`` caps the iterations of an iterative method (the result
    then says ``converged=False`` but its bounds stay proven); ``want_strategy``: compute a
    strategy. ``initial_strategy``: for ``POLICY``/``EXACT``, a starting choice per state
    (global choice index, -1 where none): policy iteration warm-started from a nearby optimum
    (e.g. the previous step of a strategy search) needs one or two linear solves."""

    method: Method = Method.INTERVAL
    precision: float = 1e-6
    relative: bool = False
    max_iterations: int = 1_000_000
    want_strategy: bool = True
    initial_strategy: np.ndarray | None = field(default=None, compare=False, repr=False)
    prove: bool = True
    """``POLICY``/``EXACT``: prove the bounds (a certificate, else interval iteration). False
    returns policy iteration's float values as they are (``sound=False``): for searches that
    only rank candidates and verify the winner afterwards."""
    deadline: float | None = field(default=None, compare=False, repr=False)
    """A ``time.perf_counter()`` value after which interval and value iteration stop as if
    ``max_iterations`` were reached (``converged=False``; interval bounds stay proven): for
    callers with a time budget (synthesis)."""
    stiff_certificate: bool = True
    """``INTERVAL``: when the iteration turns out stiff, try policy iteration with a certificate
    (:mod:`posgmc.engines.solving`). Policy iteration has no deadline (its sparse LU solves run to
    the end), so callers that must keep to ``deadline`` on large systems turn this off and get
    interval iteration's bounds as far as it got."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.precision) and self.precision > 0):
            raise InputError(
                f"the precision must be a positive finite number, got {self.precision!r}"
            )
        if self.max_iterations < 1:
            raise InputError(f"max_iterations must be at least 1, got {self.max_iterations}")
