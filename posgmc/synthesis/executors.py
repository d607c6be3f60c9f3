"""The job boundary of synthesis: executors that run a batch of independent evaluations (the
jobs of :mod:`posgmc.synthesis.tasks`) on one problem — in this process, in a local process
pool, or on a Ray cluster (:mod:`posgmc.synthesis.ray_pool`).

A :class:`~posgmc.synthesis.problem.Problem` holds everything an evaluation needs (the model, the
property, the objective's arrays, who decides); a job is a frozen dataclass whose ``run(problem)``
returns numbers and strategies and depends on nothing else (no warm start carried between jobs, no
clock except the job's own ``deadline``). So a batch gives the same results in any order and in any
process: ``--jobs N`` (and ``--executor ray``) is bit-identical to ``--jobs 1`` for a given
``--seed``: every job's extent is counted in its own units (:mod:`posgmc.synthesis.budget`); only
a binding ``--timeout`` (a deadline) or Ctrl-C cuts one short. :class:`ProcessPool` ships the
problem to each worker once (the pool's initializer) and then only the small job descriptions;
the Ray executor puts the problem in Ray's object store once and long-lived actors hold it. Every
executor keeps a :class:`~posgmc.synthesis.tasks.TaskLedger` of the jobs it ran, by phase.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Protocol

from posgmc.resources import usable_cpus
from posgmc.synthesis.problem import Problem
from posgmc.synthesis.tasks import Job, Placement, TaskLedger, phase_of, record_here, timed

__all__ = ["Job", "Executor", "InProcess", "ProcessPool", "executor_for", "run_job"]


class Executor(Protocol):
    """Runs a batch of jobs on one problem; results in the jobs' order. ``kind``: "local" or
    "ray"; ``workers``: how many workers run jobs; ``ledger``: what ran."""

    problem: Problem
    kind: str
    workers: int
    ledger: TaskLedger

    def map(self, jobs: Sequence[Job]) -> list[Any]: ...

    def close(self) -> None: ...


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


def local_pool(workers: int, initializer: Callable[..., None],
               initargs: tuple[Any, ...] = ()) -> ProcessPoolExecutor:
    """A pool of ``workers`` local processes, forked where the platform allows (a fork shares the
    parent's imports and compiled kernels instead of starting them again), each set up by
    ``initializer(*initargs)``."""
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else None)
    return ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=initializer, initargs=initargs)


class ProcessPool:
    """A local pool of ``workers`` processes (forked where the platform allows), each given the
    problem once; a batch of one job runs in this process (no pickling)."""

    kind = "local"

    def __init__(self, problem: Problem, workers: int) -> None:
        self.problem = problem
        self.workers = workers
        self.ledger = TaskLedger()
        self._pool = local_pool(workers, _install, (problem,))

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


def executor_for(problem: Problem, jobs: int | Placement) -> Executor:
    """Where ``problem``'s jobs run: ``jobs`` = 1 (or a local :class:`Placement` of one worker):
    in this process; more: a local process pool of that many workers (at most one per usable
    processor, :func:`~posgmc.resources.usable_cpus`); a Ray placement: actors
    on the Ray cluster (:mod:`posgmc.synthesis.ray_pool`).

    Raises:
        UnsupportedError: Ray asked for and not installed.
        InputError: the Ray cluster's address cannot be reached.
    """
    placement = jobs if isinstance(jobs, Placement) else Placement(workers=jobs)
    if placement.executor == "ray":
        from posgmc.synthesis.ray_pool import RayPool  # imports ray: only when asked for

        return RayPool(problem, placement)
    # a local pool: at most one worker per usable processor (more only compete for them, and
    # each costs a process start)
    workers = min(placement.workers, usable_cpus())
    if workers <= 1:
        return InProcess(problem)
    return ProcessPool(problem, workers)
