"""The job boundary of synthesis: a picklable description of the problem and of each independent
evaluation, and executors that run a batch of them (in this process, or in a local process pool).

A :class:`Problem` holds everything an evaluation needs (the model, the property, the objective's
arrays, who decides); a job is a frozen dataclass whose ``run(problem)`` returns numbers and
strategies and depends on nothing else (no warm start carried between jobs, no clock except the
job's own ``deadline``). So a batch gives the same results in any order and in any process:
``--jobs N`` is bit-identical to ``--jobs 1`` for a given ``--seed`` (as long as no deadline is
hit). :class:`ProcessPool` ships the problem to each worker once (the pool's initializer) and then
only the small job descriptions; :class:`posgmc.synthesis.ray_pool.RayPool` puts the problem in
Ray's object store once, long-lived actors (one per worker) hold it, and the jobs go to whichever
actor is free, without touching the algorithm.

Every executor keeps a :class:`TaskLedger`: how many jobs of each phase it ran and the time they
took where they ran (the ``"synthesis"`` entry of a synthesised result's JSON). A job's phase is
its class's ``PHASE``. A job's clock fields (:data:`CLOCK_FIELDS`) are ``time.perf_counter()``
values of the process that made it; an executor whose workers may run on other machines shifts
them into each worker's clock (:func:`rebased`).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np

from posgmc.checking.dispatch import CheckOptions
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import Coalition, Direction, ProbQuery, RewardQuery

__all__ = ["Problem", "Job", "Executor", "InProcess", "ProcessPool", "run_job",
           "Placement", "TaskLedger", "phase_of", "rebased", "timed", "record_here", "CLOCK_FIELDS"]

POLICY = CheckOptions(solver=SolverOptions(method=Method.POLICY, prove=False))
"""Exact linear solves (policy iteration): how candidates are ranked, never what is reported."""


@dataclass(frozen=True, eq=False)
class Problem:
    """One synthesis problem. ``query``: the bare query with its direction set; ``player``: the
    decision maker; ``adversary``: the other player (None for a pomdp); ``coalition``: the
    players the query's coalition names; ``target``/``remain``: bool[S] (where ``b`` and ``a`` of
    ``a U b`` hold); ``rewards``: float64[C] per choice (None for a probability); ``discount``:
    1 unless the objective is discounted; ``scalar``: a picklable constant evaluator."""

    model: ExplicitModel
    query: ProbQuery | RewardQuery
    player: int
    adversary: int | None
    coalition: frozenset[int]
    target: np.ndarray
    remain: np.ndarray
    rewards: np.ndarray | None
    discount: float
    scalar: Callable[[Any], Any]

    @property
    def maximize(self) -> bool:
        return self.query.direction is Direction.MAX

    @property
    def sign(self) -> float:
        """+1 when the decision maker maximises, -1 when it minimises."""
        return 1.0 if self.maximize else -1.0

    def coalition_of(self, coalition: Coalition | None) -> frozenset[int] | None:
        """The coalition resolver of this problem's one query."""
        return None if coalition is None else self.coalition


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


def timed(job: Job, problem: Problem) -> tuple[Any, float]:
    """``job.run(problem)`` and the seconds it took."""
    t0 = time.perf_counter()
    out = job.run(problem)
    return out, time.perf_counter() - t0


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


@dataclass(frozen=True)
class Placement:
    """Where the jobs run. ``executor``: "local" (this process, or a local process pool) or
    "ray"; ``workers``: processes (local) or actors (Ray; 1 = one per CPU of the cluster);
    ``address``: the Ray cluster's HOST:PORT (None: Ray's ``RAY_ADDRESS``, else a local Ray
    started for this run)."""

    executor: Literal["local", "ray"] = "local"
    workers: int = 1
    address: str | None = None


class Executor(Protocol):
    """Runs a batch of jobs on one problem; results in the jobs' order. ``kind``: "local" or
    "ray"; ``workers``: how many workers run jobs; ``ledger``: what ran."""

    problem: Problem
    kind: str
    workers: int
    ledger: TaskLedger

    def map(self, jobs: Sequence[Job]) -> list[Any]: ...

    def close(self) -> None: ...


def record_here(problem: Problem, ledger: TaskLedger, jobs: Sequence[Job]) -> list[Any]:
    """Run ``jobs`` on ``problem`` in this process, one after the other, recorded in
    ``ledger``."""
    out = []
    for job in jobs:
        result, seconds = timed(job, problem)
        ledger.record(phase_of(job), seconds)
        out.append(result)
    return out


class InProcess:
    """Runs the jobs one after the other in this process."""

    kind = "local"
    workers = 1

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.ledger = TaskLedger()

    def map(self, jobs: Sequence[Job]) -> list[Any]:
        return record_here(self.problem, self.ledger, jobs)

    def close(self) -> None:
        pass


_INSTALLED: list[Problem] = []
"""The problem of this worker process (set once by the pool's initializer)."""


def _install(problem: Problem) -> None:
    _INSTALLED[:] = [problem]


def run_job(job: Job) -> Any:
    """Run one job on the problem installed in this worker."""
    return job.run(_INSTALLED[0])


def _run_timed(job: Job) -> tuple[Any, float]:
    """Run one job on the problem installed in this worker, with the seconds it took."""
    return timed(job, _INSTALLED[0])


class ProcessPool:
    """A local pool of ``workers`` processes (forked where the platform allows), each given the
    problem once; a batch of one job runs in this process (no pickling)."""

    kind = "local"

    def __init__(self, problem: Problem, workers: int) -> None:
        self.problem = problem
        self.workers = workers
        self.ledger = TaskLedger()
        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("fork" if "fork" in methods else None)
        self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                         initializer=_install, initargs=(problem,))

    def map(self, jobs: Sequence[Job]) -> list[Any]:
        if len(jobs) <= 1:
            return record_here(self.problem, self.ledger, jobs)
        out = []
        for job, (result, seconds) in zip(jobs, self._pool.map(_run_timed, jobs)):
            self.ledger.record(phase_of(job), seconds)
            out.append(result)
        return out

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


def expired(deadline: float | None) -> bool:
    """Whether ``deadline`` (a ``time.perf_counter()`` value: CLOCK_MONOTONIC on Linux, the same
    clock in every process of the machine) has passed."""
    return deadline is not None and time.perf_counter() > deadline
