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
closing the generator early (an error, the caller done reading) cancels the calls not yet
started and ends the pool's processes.

Interrupt (Ctrl-C, :func:`~posgmc.synthesis.budget.interrupted`): the calls already running wind
down and their results are still yielded where they can (in this process, the call running; in a
local pool, every running call: the workers are stopped by the terminal's Ctrl-C, and by the
driver's stop signal when it alone was interrupted, so that each reports its best so far); on
Ray the running tasks
are cancelled (they do not see the stop). The calls not started are cancelled. Either way the
generator then ends normally and :attr:`Spread.cancelled` names the calls that gave no result, so
that the caller reports which points finished and which did not.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

from posgmc.errors import WorkerError
from posgmc.resources import usable_cpus
from posgmc.synthesis import progress
from posgmc.synthesis.budget import interrupted, request_stop
from posgmc.synthesis.executors import local_pool
from posgmc.synthesis.tasks import Placement, TaskLedger, timed_call

__all__ = ["each_result", "workers_for", "Spread"]


@dataclass
class Spread:
    """Where :func:`each_result` ran its calls: ``executor`` ("local" or "ray"), ``workers``
    (processes or Ray CPUs the calls could run on at once; 1: this process), the ``ledger``
    of the calls by phase, with the seconds each took where it ran, and the labels of the calls
    ``cancelled`` by an interrupt (no result: not started, or cut on Ray)."""

    executor: str = "local"
    workers: int = 1
    ledger: TaskLedger = field(default_factory=TaskLedger)
    cancelled: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """The shape of a synthesis's ``"synthesis"`` placement: executor, workers, tasks (and
        the calls an interrupt cancelled, when it did)."""
        out: dict[str, Any] = {"executor": self.executor, "workers": self.workers,
                               "tasks": self.ledger.to_json()}
        if self.cancelled:
            out["cancelled"] = list(self.cancelled)
        return out


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

    On an interrupt the generator ends early, normally: ``spread.cancelled`` names the calls it
    gave no result for (the module's docstring says which).

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
                   if record.workers > 1 else _here(timed))
    given = 0
    try:
        try:
            for result, seconds in results:
                record.ledger.record(phase, seconds)
                given += 1
                yield result
        except KeyboardInterrupt:
            if not interrupted():
                raise
            # Ray's wait saw the stop and cancelled the running tasks
        # an interrupt ended the calls early: those without a result were cancelled
        record.cancelled[:] = names[given:]
    finally:
        results.close()


def _here(calls: Sequence[tuple[Any, ...]]) -> Generator[Any, None, None]:
    """The calls one after the other in this process; after an interrupt the call running winds
    down and is given, the calls after it are not run."""
    for call in calls:
        if interrupted():
            return
        yield timed_call(*call)


_STOP_SIGNAL = getattr(signal, "SIGUSR1", None)
"""How the driver tells a pool worker to stop (where the platform has it)."""


def _fanned_worker() -> None:
    """A pool worker of a fan-out: no progress of its own; stopped by the driver's stop signal
    as a Ctrl-C would stop this process's synthesis (it winds down and returns its best so far).
    Its SIGINT handler is the driver's, inherited: under ``interruptible`` the terminal's Ctrl-C
    (which the whole process group receives) requests the same stop, and the driver's signal
    after it only repeats the request; elsewhere a Ctrl-C interrupts it as it does the driver."""
    progress.silence()
    if _STOP_SIGNAL is not None:
        signal.signal(_STOP_SIGNAL, _stop_requested)


def _stop_requested(signum: int, frame: Any) -> None:
    request_stop("interrupt")


_POLL_SECONDS = 0.2
"""How often the driver, waiting for a pool's call, looks for an interrupt."""


def _pool_results(function: Callable[..., Any], arguments: Sequence[tuple[Any, ...]],
                  workers: int, names: Sequence[str]) -> Generator[Any, None, None]:
    """The calls on a local pool of ``workers`` processes, the results taken in order. A call is
    submitted only when a worker is free for it (a call the pool has queued cannot be taken
    back), so that on an interrupt the calls not submitted are simply not run (and not given)
    while the workers, told to stop, wind down the running calls, whose results are given."""
    # a forked worker inherits the progress sinks of this process, which shows its own; it
    # inherits the stop signal's handler too, so that a stop that reaches it before its
    # initializer ran does not kill it
    previous = _handle_stop_signal(_stop_requested)
    pool = local_pool(workers, _fanned_worker)
    futures: list[Future[Any]] = []
    done = False
    stopped = False

    def submit() -> None:
        # the stop is read here too: a call that wound down on the interrupt may return before
        # the loop below has seen it, and its freed worker must not take the next call
        while (not stopped and not interrupted() and len(futures) < len(arguments)
               and sum(not f.done() for f in futures) < workers):
            try:
                futures.append(pool.submit(function, *arguments[len(futures)]))
            except BrokenProcessPool:
                return  # a worker died: its call, submitted before, says so in turn

    def stop_workers() -> None:
        if _STOP_SIGNAL is not None:
            for process in list((getattr(pool, "_processes", None) or {}).values()):
                if process.pid is not None and process.is_alive():
                    os.kill(process.pid, _STOP_SIGNAL)

    try:
        for i, name in enumerate(names):
            submit()
            if i >= len(futures) and (stopped or interrupted()):
                break  # an interrupt: this call and those after it are not run
            try:
                if i >= len(futures):  # not submitted: the pool broke
                    raise BrokenProcessPool
                while True:
                    if not stopped and interrupted():
                        stopped = True
                        stop_workers()
                    try:
                        result = futures[i].result(timeout=_POLL_SECONDS)
                        break
                    except FutureTimeout:
                        submit()  # a worker freed by a later call takes the next
            except BrokenProcessPool:
                raise WorkerError(
                    f"{name} failed: its worker process died (killed, or out of memory)",
                    hint="rerun with fewer --jobs, or on a machine with more memory") from None
            yield result
        done = True
    finally:
        if not done:
            # an early stop (an error, the caller done reading) ends the workers now rather
            # than after the calls they are running
            for process in list((getattr(pool, "_processes", None) or {}).values()):
                process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
        _handle_stop_signal(previous)


def _handle_stop_signal(handler: Any) -> Any:
    """Install ``handler`` for the stop signal in this process; the handler it replaces (None
    where there is no such signal or this is not the main thread)."""
    if _STOP_SIGNAL is None or handler is None:
        return None
    try:
        return signal.signal(_STOP_SIGNAL, handler)
    except ValueError:  # not the main thread: the workers are told nothing
        return None
