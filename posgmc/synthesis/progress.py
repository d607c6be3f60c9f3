"""Progress of a synthesis run, as events a front end may show (the CLI's live status line, its
``--progress`` lines and ``--json-lines`` events): the phase, the memory size, the best value so
far, and how much of the phase's work budget is done.

The search reports to whatever sinks are installed (:func:`reporting`); without one a report costs
a function call. Only the process that drives the search reports (jobs run elsewhere do not).
The best value of a phase is a ranking (policy iteration's float value of the best candidate),
labelled as such: the proven ``guaranteed`` is the verification's, reported last.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from posgmc.checking.decimals import plain, shortest_in
from posgmc.checking.results import Bound

__all__ = ["Status", "report", "reporting", "current", "begin", "point_done", "silence"]


@dataclass(frozen=True)
class Status:
    """What the search is doing: ``phase`` (as the result's ``phases`` name it), ``memory`` (the
    memory size searched, if any), ``best`` (the best value so far: a ranking, not a proof),
    ``proven`` (True once ``best`` is the verified ``guaranteed``), ``done``/``total`` (``unit``s of
    the phase's work budget, when counted), ``property`` (the property's text), ``elapsed``
    (seconds since the property's synthesis started), ``bound`` (when ``best`` is proven: the
    proven number it comes from, printed as a result prints it, the shortest decimal inside its
    bounds)."""

    phase: str
    memory: int | None = None
    best: float | None = None
    proven: bool = False
    done: int | None = None
    total: int | None = None
    property: str | None = None
    elapsed: float = 0.0
    unit: str | None = None
    at: float = field(default_factory=time.perf_counter, compare=False)
    bound: Bound | None = None

    def text(self) -> str:
        """One line: phase, memory, best so far, budget done, elapsed."""
        parts = [self.phase + (f" k={self.memory}" if self.memory is not None else "")]
        if self.best is not None:
            parts.append(("guaranteed " if self.proven else "best so far ~") + self.best_text())
        if self.done is not None and self.total is not None:
            parts.append(f"{self.unit or 'step'} {self.done}/{self.total}")
        parts.append(f"{self.elapsed:.1f} s")
        return " | ".join(parts)

    def best_text(self) -> str:
        """``best`` as printed: a proven number as the result prints it (the shortest decimal
        inside its proven bounds, so a sweep's progress line and its table agree), a ranking with
        ten significant digits."""
        if self.proven and self.bound is not None:
            b = self.bound
            return shortest_in(b.value, b.lower, b.upper)
        return "" if self.best is None else plain(self.best)

    def as_json(self) -> dict[str, object]:
        out: dict[str, object] = {"phase": self.phase, "memory": self.memory, "best": self.best,
                                  "proven": self.proven, "done": self.done, "total": self.total,
                                  "unit": self.unit, "property": self.property,
                                  "elapsed": round(self.elapsed, 3)}
        if self.bound is not None:
            out["bound"] = self.bound.to_json()
        return out


Sink = Callable[[Status], None]

_SINKS: list[Sink] = []
_STATE: dict[str, object] = {}


def current() -> Status | None:
    """The last status reported, or None."""
    last = _STATE.get("last")
    return last if isinstance(last, Status) else None


def begin(prop: str | None) -> None:
    """A property's synthesis starts: its text, and the clock of ``elapsed``."""
    _STATE["property"] = prop
    _STATE["started"] = time.perf_counter()
    _STATE.pop("best", None)
    _STATE.pop("bound", None)


def report(phase: str, *, memory: int | None = None, best: float | None = None,
           proven: bool = False, done: int | None = None, total: int | None = None,
           unit: str | None = None, bound: Bound | None = None) -> None:
    """Tell the sinks what the search does now; ``best``: a better value than before (kept for
    later reports of the same property); ``bound``: the proven number ``best`` comes from."""
    if not _SINKS:
        return
    if best is not None:
        _STATE["best"] = best
        _STATE["bound"] = bound
    kept = _STATE.get("best")
    kept_bound = _STATE.get("bound")
    started = _STATE.get("started")
    elapsed = time.perf_counter() - started if isinstance(started, float) else 0.0
    prop = _STATE.get("property")
    status = Status(phase, memory, kept if isinstance(kept, float) else None, proven, done, total,
                    prop if isinstance(prop, str) else None, elapsed, unit=unit,
                    bound=kept_bound if isinstance(kept_bound, Bound) else None)
    _STATE["last"] = status
    for sink in list(_SINKS):
        sink(status)


@contextmanager
def reporting(sink: Sink) -> Iterator[None]:
    """Send the search's progress to ``sink`` inside the context."""
    _SINKS.append(sink)
    try:
        yield
    finally:
        _SINKS.remove(sink)
        _STATE.clear()


def silence() -> None:
    """This process reports nothing from now on: a worker forked to run whole computations (the
    points of a sweep) for a process that shows its own progress."""
    _SINKS.clear()
    _STATE.clear()


def point_done(label: str, value: Bound | None, done: int, total: int) -> None:
    """A point of a sweep or front is complete: its label (``B=1``, ``w=5``), its headline
    number (proven, with its bounds: printed as the sweep's table prints it), and how many of the
    points are done."""
    begin(None)
    report(f"point {label} done", best=None if value is None else float(value.value),
           proven=value is not None, done=done, total=total, unit="point", bound=value)
