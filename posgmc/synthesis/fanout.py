"""Independent calls fanned out on an executor: the points of a ``--const`` sweep, the points of a
``pareto`` sweep and a defender front, the runs of ``posgmc test``; each call one task.

A call is a module-level function and plain-data arguments (model texts, constant values, option
records), so that it runs the same in this process, in a local process pool (forked where the
platform allows) and on a Ray cluster (a Ray task of one CPU; the workers import the driver's
posgmc, :mod:`posgmc.synthesis.ray_pool`). :func:`each_result` yields the results in the calls'
order, each as soon as it and every call before it is done: a caller that prints as results come
prints exactly what one process would, in the same order, whatever the number of workers.

Failure: an exception a call raises is re-raised here (the calls after it are cancelled); a worker
that dies (killed, out of memory) has its call retried on Ray (:data:`~posgmc.synthesis.ray_pool.
RETRIES` times), and the run stops with a :class:`~posgmc.errors.WorkerError` naming the call;
closing the generator early (an error, an interrupt the caller saw) cancels the calls not yet
started and ends the pool's processes.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

from posgmc.errors import WorkerError
from posgmc.resources import usable_cpus
from posgmc.synthesis import progress
from posgmc.synthesis.executors import local_pool
from posgmc.synthesis.tasks import Placement, TaskLedger, timed_call

__all__ = ["each_result", "workers_for", "Spread"]


@dataclass
class Spread:
    """Where :func:`each_result` ran its calls: ``executor`` ("local" or "ray"), ``workers``
    (processes or Ray CPUs the calls could run on at once; 1: this process) and the ``ledger``
    of the calls by phase, with the seconds each took where it ran."""

    executor: str = "local"
    workers: int = 1
    ledger: TaskLedger = field(default_factory=TaskLedger)

    def to_json(self) -> dict[str, Any]:
        """The shape of a synthesis's ``"synthesis"`` placement: executor, workers, tasks."""
        return {"executor": self.executor, "workers": self.workers,
                "tasks": self.ledger.to_json()}


def workers_for(placement: Placement, calls: int) -> int:
    """How many workers a local placement runs ``calls`` calls on: at most one per call and one
    per usable processor (:func:`~posgmc.resources.usable_cpus`); 1 means this process."""
    return max(1, min(placement.workers, usable_cpus(), calls))


def each_result(function: Callable[..., Any], arguments: Sequence[tuple[Any, ...]],
                placement: Placement, *, labels: Sequence[str] | None = None,
                spread: Spread | None = None, phase: str = "call",
                ) -> Generator[Any, None, None]:
    """``function(*args)`` for each of ``arguments``, yielded in their order, where
    ``placement`` says (one call: always in this process, nothing shipped). ``labels`` name the
    calls in errors (default: ``call i of n``); ``spread``, when given, is filled in with where
    they ran and each call's seconds under ``phase``.

    Raises:
        WorkerError: a worker died running a call (after Ray's retries).
        UnsupportedError, InputError: Ray asked for and not installed or not reachable.
        Any exception a call raises.
    """
    names = list(labels) if labels is not None else [
        f"call {i + 1} of {len(arguments)}" for i in range(len(arguments))]
    record = spread if spread is not None else Spread()
    timed = [(function, args) for args in arguments]
    if placement.executor == "ray" and len(arguments) > 1:
        from posgmc.synthesis.ray_pool import ray_results  # imports ray: only when asked for

        record.executor = "ray"
        results = ray_results(timed_call, timed, placement, names, record)
    else:
        record.executor = "local"
        record.workers = workers_for(placement, len(arguments))
        results = (_pool_results(timed_call, timed, record.workers, names)
                   if record.workers > 1 else (timed_call(*call) for call in timed))
    try:
        for result, seconds in results:
            record.ledger.record(phase, seconds)
            yield result
    finally:
        results.close()


def _pool_results(function: Callable[..., Any], arguments: Sequence[tuple[Any, ...]],
                  workers: int, names: Sequence[str]) -> Generator[Any, None, None]:
    """The calls on a local pool of ``workers`` processes (the pool starts them as workers free
    up; the results are taken in order)."""
    # a forked worker inherits the progress sinks of this process, which shows its own
    pool = local_pool(workers, progress.silence)
    done = False
    try:
        futures = [pool.submit(function, *args) for args in arguments]
        for name, future in zip(names, futures):
            try:
                result = future.result()
            except BrokenProcessPool:
                raise WorkerError(
                    f"{name} failed: its worker process died (killed, or out of memory)",
                    hint="rerun with fewer --jobs, or on a machine with more memory") from None
            yield result
        done = True
    finally:
        if not done:
            # an early stop (an error, an interrupt, the caller done reading) ends the workers
            # now rather than after the calls they are running
            for process in list((getattr(pool, "_processes", None) or {}).values()):
                process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
