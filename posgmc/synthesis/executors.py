"""The job boundary of synthesis: each independent evaluation as a picklable job, and executors
that run a batch of them (in this process, or in a local process pool).

A :class:`~posgmc.synthesis.problem.Problem` holds everything an evaluation needs (the model, the
property, the objective's arrays, who decides); a job is a frozen dataclass whose ``run(problem)``
returns numbers and strategies and depends on nothing else (no warm start carried between jobs, no
clock except the job's own ``deadline``). So a batch gives the same results in any order and in any
process: ``--jobs N`` is bit-identical to ``--jobs 1`` for a given ``--seed``: every job's extent
is counted in its own units (:mod:`posgmc.synthesis.budget`); only a binding ``--timeout`` (a
deadline) or Ctrl-C cuts one short. :class:`ProcessPool` ships the problem to each worker once
(the pool's initializer) and then only the small job descriptions; a distributed executor (Ray,
Dask) would put the problem in its object store once and map :func:`run_job` over the jobs,
without touching the algorithm.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Protocol

from posgmc.synthesis.problem import Problem

__all__ = ["Job", "Executor", "InProcess", "ProcessPool", "executor_for", "run_job"]


class Job(Protocol):
    """An independent evaluation: ``run(problem)`` -> numbers and strategies."""

    def run(self, problem: Problem) -> Any: ...


class Executor(Protocol):
    """Runs a batch of jobs on one problem; results in the jobs' order."""

    problem: Problem

    def map(self, jobs: Sequence[Job]) -> list[Any]: ...

    def close(self) -> None: ...


class InProcess:
    """Runs the jobs one after the other in this process."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem

    def map(self, jobs: Sequence[Job]) -> list[Any]:
        return [job.run(self.problem) for job in jobs]

    def close(self) -> None:
        pass


_INSTALLED: list[Problem] = []
"""The problem of this worker process (set once by the pool's initializer)."""


def _install(problem: Problem) -> None:
    _INSTALLED[:] = [problem]


def run_job(job: Job) -> Any:
    """Run one job on the problem installed in this worker."""
    return job.run(_INSTALLED[0])


class ProcessPool:
    """A local pool of ``workers`` processes (forked where the platform allows), each given the
    problem once; a batch of one job runs in this process (no pickling)."""

    def __init__(self, problem: Problem, workers: int) -> None:
        self.problem = problem
        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("fork" if "fork" in methods else None)
        self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                         initializer=_install, initargs=(problem,))

    def map(self, jobs: Sequence[Job]) -> list[Any]:
        if len(jobs) <= 1:
            return [job.run(self.problem) for job in jobs]
        return list(self._pool.map(run_job, jobs))

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


def executor_for(problem: Problem, jobs: int) -> InProcess | ProcessPool:
    """``jobs`` = 1: in this process; more: a local process pool of that many workers."""
    return InProcess(problem) if jobs <= 1 else ProcessPool(problem, jobs)
