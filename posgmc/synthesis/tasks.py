"""What an executor of :mod:`posgmc.synthesis.executors` runs and records: a job (a picklable
description of one independent evaluation, run on a :class:`~posgmc.synthesis.problem.Problem`),
its phase, its clock fields, the ledger of what ran and where the jobs are to run.

A job's phase is its class's ``PHASE`` (the names of a synthesised result's ``"phases"``
timings). A job's clock fields (:data:`CLOCK_FIELDS`) are ``time.perf_counter()`` values of the
process that made it; an executor whose workers may run on other machines moves them into each
worker's clock (:func:`rebased`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

from posgmc.synthesis.problem import Problem

__all__ = ["Job", "CLOCK_FIELDS", "phase_of", "rebased", "timed", "timed_call", "record_here",
           "TaskLedger", "Placement"]


class Job(Protocol):
    """An independent evaluation: ``run(problem)`` -> numbers and strategies."""

    def run(self, problem: Problem) -> Any: ...


CLOCK_FIELDS = ("deadline", "deadlines")
"""The fields of a job that hold ``time.perf_counter()`` values (a float, None, or a tuple of
them) of the process that made the job."""


def phase_of(job: Job) -> str:
    """The phase ``job`` belongs to: its class's ``PHASE``, else the class name."""
    return str(getattr(type(job), "PHASE", type(job).__name__))


def rebased(job: Job, offset: float) -> Job:
    """``job`` with its clock fields moved by ``offset`` seconds (the worker's clock minus the
    clock of the process that made the job); ``job`` itself when it has none or offset is 0."""
    if offset == 0.0 or not dataclasses.is_dataclass(job):
        return job

    def shift(value: Any) -> Any:
        if isinstance(value, tuple):
            return tuple(shift(v) for v in value)
        return None if value is None else float(value) + offset

    changes = {f.name: shift(getattr(job, f.name)) for f in dataclasses.fields(job)
               if f.name in CLOCK_FIELDS}
    return dataclasses.replace(job, **changes) if changes else job


def timed_call(function: Callable[..., Any], arguments: tuple[Any, ...]) -> tuple[Any, float]:
    """``function(*arguments)`` and the seconds it took (measured where it runs)."""
    t0 = time.perf_counter()
    out = function(*arguments)
    return out, time.perf_counter() - t0


def timed(job: Job, problem: Problem) -> tuple[Any, float]:
    """``job.run(problem)`` and the seconds it took."""
    return timed_call(job.run, (problem,))


@dataclass
class TaskLedger:
    """Jobs run and the seconds they took where they ran, by phase (in the order phases first
    ran)."""

    counts: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    def record(self, phase: str, seconds: float) -> None:
        self.counts[phase] = self.counts.get(phase, 0) + 1
        self.seconds[phase] = self.seconds.get(phase, 0.0) + seconds

    def to_json(self) -> dict[str, dict[str, float | int]]:
        return {p: {"count": n, "worker_seconds": round(self.seconds[p], 3)}
                for p, n in self.counts.items()}


def record_here(problem: Problem, ledger: TaskLedger, jobs: Sequence[Job]) -> list[Any]:
    """Run ``jobs`` on ``problem`` in this process, one after the other, recorded in
    ``ledger``."""
    out = []
    for job in jobs:
        result, seconds = timed(job, problem)
        ledger.record(phase_of(job), seconds)
        out.append(result)
    return out


@dataclass(frozen=True)
class Placement:
    """Where the jobs run. ``executor``: "local" (this process, or a local process pool) or
    "ray"; ``workers``: processes (local) or actors (Ray; 1 = one per CPU of the cluster);
    ``address``: the Ray cluster's HOST:PORT (None: Ray's ``RAY_ADDRESS``, else a local Ray
    started for this run)."""

    executor: Literal["local", "ray"] = "local"
    workers: int = 1
    address: str | None = None
