"""The work budget of synthesis and the two things that may cut it short.

**The work budget.** How far every phase of the search goes is counted in the phase's own units
(quotient games solved, improvement rounds, gradient steps per start, random starts, local-search
evaluations, adversary strategies enumerated and ranked, MILP branch-and-bound nodes, double-oracle
rounds, explored belief nodes), never in seconds: a run's numbers depend only on the model, the
property, the options and the seed, not on the machine, its load or ``--jobs``. ``--effort E``
scales every count (:meth:`Effort.units`; the defaults are :data:`DEFAULT_UNITS` at effort 1).

**The wall-clock cap** (``--timeout``): a :class:`Clock` whose deadlines every phase looks at; when
one passes, the phase stops and the result says the timeout cut the budget (``cut``: "timeout"),
which is then the only way two runs of the same command can differ.

**An interrupt** (Ctrl-C, inside :func:`interruptible`): the first SIGINT requests a stop, which
every deadline check sees as an expired deadline, so the phases wind down as at a binding timeout
and the best defence found so far is verified and reported (``cut``: "interrupt"); a second SIGINT
raises :class:`KeyboardInterrupt` as usual. Worker processes forked inside the context inherit the
handler: the terminal's SIGINT reaches them too and their jobs end the same way.
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType

__all__ = ["Effort", "Clock", "DEFAULT_UNITS", "expired", "interruptible", "interrupted",
           "request_stop", "clear_stop"]

DEFAULT_UNITS: dict[str, int] = {
    "families": 300,
    "passes": 2,
    "improvement_rounds": 100,
    "local_steps": 100,
    "belief_nodes": 4096,
    "milp_nodes": 200,
}
"""The per-phase counts at effort 1 that are not :class:`~posgmc.synthesis.search.
SynthesisOptions` fields of their own: ``families``: quotient games the deterministic search
solves over all memory sizes (shared 1 : 3 : 2 ... among the sizes); ``passes``: passes of the
gradient search over the memory sizes (the first from the projections of the full-observation
optimum, further ones from new random points and the best so far, while a pass improves);
``improvement_rounds``: observation-level policy iteration rounds per memory size;
``local_steps``: evaluations of the local search around the best deterministic candidate of a
round; ``belief_nodes``: belief nodes a pomdp's belief exploration expands; ``milp_nodes``:
branch-and-bound nodes of the MILP composition. The options' own counts (``iterations``
gradient steps per start, ``restarts`` random starts, ``enumeration_limit`` adversary
strategies, ``compose_restarts``, ``oracle_rounds``) scale alike."""


@dataclass(frozen=True)
class Effort:
    """A multiplier of every per-phase count (1: the defaults)."""

    scale: float = 1.0

    def units(self, base: int) -> int:
        """``base`` units scaled, rounded up; 0 stays 0 (a phase switched off), any other count
        keeps at least one unit."""
        if base <= 0:
            return 0
        return max(1, math.ceil(base * self.scale))

    def default(self, name: str) -> int:
        """The scaled count of :data:`DEFAULT_UNITS` ``name``."""
        return self.units(DEFAULT_UNITS[name])


_STOP: list[str] = []
"""Why a stop was requested in this process ("interrupt"), empty while none was."""


def request_stop(reason: str = "interrupt") -> None:
    """Ask every running phase to stop as at an expired deadline."""
    if not _STOP:
        _STOP.append(reason)


def clear_stop() -> None:
    """Forget a stop request (a new run starts)."""
    _STOP.clear()


def interrupted() -> bool:
    """Whether a stop was requested (Ctrl-C inside :func:`interruptible`)."""
    return bool(_STOP)


def expired(deadline: float | None) -> bool:
    """Whether ``deadline`` (a ``time.perf_counter()`` value: CLOCK_MONOTONIC on Linux, the same
    clock in every process of the machine) has passed, or a stop was requested."""
    return bool(_STOP) or (deadline is not None and time.perf_counter() > deadline)


@contextmanager
def interruptible() -> Iterator[None]:
    """Inside: the first SIGINT requests a stop (the search winds down and reports its best), a
    second raises :class:`KeyboardInterrupt`. Outside of the main thread it does nothing."""
    clear_stop()
    try:
        previous = signal.getsignal(signal.SIGINT)

        def handler(signum: int, frame: FrameType | None) -> None:
            if _STOP:
                raise KeyboardInterrupt
            request_stop("interrupt")

        signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread: signals cannot be handled here
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@dataclass(frozen=True)
class Clock:
    """The wall-clock cap of one property's synthesis: ``started`` (a ``time.perf_counter()``
    value) and ``timeout`` seconds, or None for no cap."""

    started: float
    timeout: float | None

    def at(self, fraction: float) -> float | None:
        """The deadline ``fraction`` of the way through the cap (None without a cap)."""
        return None if self.timeout is None else self.started + fraction * self.timeout

    @property
    def end(self) -> float | None:
        return self.at(1.0)

    def passed(self, fraction: float = 1.0) -> bool:
        """Whether the deadline at ``fraction`` has passed (or a stop was requested)."""
        return expired(self.at(fraction))

    def cut(self, fraction: float = 1.0) -> str | None:
        """What cut the budget by now: "interrupt", "timeout" (the deadline at ``fraction``
        passed), or None."""
        if _STOP:
            return _STOP[0]
        deadline = self.at(fraction)
        return "timeout" if deadline is not None and time.perf_counter() > deadline else None
