"""Synthesis jobs on a Ray cluster (``--executor ray``; ``pip install 'posgmc[ray]'``).

The problem (the objective's arrays, and the model: when it was built from text here, the recipe
that builds it, :func:`shipped`) goes into Ray's object store once; one long-lived actor per
worker (one CPU each) receives it when it starts, builds the model from the recipe once (before
its first job) and keeps it, and then
receives only the jobs — plain data: candidate strategies, adversaries, memory sizes, logits,
deadlines (:mod:`posgmc.synthesis.tasks`); a value several jobs of a batch share (the defence
evaluated against each adversary) goes into the object store once for the batch and each actor
fetches it once (:func:`shared_fields`). Jobs go to whichever actor is free and the results come
back in the jobs' order, so a run gives ``--jobs 1``'s numbers on any cluster.

Where the cluster is: ``--ray-address HOST:PORT`` (a ``ray start --head``), else Ray's own
``RAY_ADDRESS``, else a Ray started on this machine for the run. The workers import the driver's
copy of posgmc (shipped as a runtime-environment module), so the cluster only needs Ray and
posgmc's dependencies.

Independent calls (the points of a sweep or front, the runs of ``posgmc test``) run as Ray
tasks of one CPU each (:func:`ray_results`, for :mod:`posgmc.synthesis.fanout`).

Failure: an actor that dies (killed, out of memory, its node lost) is restarted with the problem
and its job retried, :data:`RETRIES` times; then the run stops with a :class:`WorkerError` naming
the job. Ctrl-C (or any error) cancels the jobs still queued and ends the actors. A Ray started
on this machine for the run is shut down when the process exits, and the helper processes
``ray.shutdown()`` leaves behind are ended with it (:func:`release`).
"""

from __future__ import annotations

import atexit
import dataclasses
import os
import socket
import sys
import time
from collections import Counter
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import posgmc
from posgmc.errors import InputError, UnsupportedError, WorkerError
from posgmc.model.origin import Recipe, recipe_of
from posgmc.processes import Process, descendants, end
from posgmc.synthesis.budget import interrupted
from posgmc.synthesis.problem import Problem
from posgmc.synthesis.tasks import (
    Job,
    Placement,
    TaskLedger,
    phase_of,
    rebased,
    record_here,
    timed,
)

__all__ = ["RayPool", "RETRIES", "SAME_CLOCK", "START_SECONDS", "shared_fields", "ray_results",
           "release", "shipped"]

RETRIES = 2
"""How often a dead actor is restarted and its job retried before the run fails."""

SAME_CLOCK = 1e-3
"""A measured clock offset below this many seconds is the same clock (the worker runs on this
machine, where ``time.perf_counter()`` is one clock): the jobs are then sent unchanged."""

START_SECONDS = 120.0
"""How long the actors may take to start (a CPU free for each, the problem fetched) before the
run stops with an error rather than waiting for CPUs that other work holds."""

_POLL_SECONDS = 0.5
"""How often a wait for Ray tasks looks whether Ctrl-C asked to stop."""

_CONNECT_SECONDS = 5.0
"""How long reaching a given cluster address may take before the run stops with an error
(Ray itself would keep retrying for minutes)."""


@dataclass(frozen=True)
class _Shared:
    """In a job sent to a worker: the value of a field that several jobs of the batch share (a
    defence evaluated against every adversary), put in the object store once for the batch."""

    ref: Any


_PLAIN = (type(None), bool, int, float, str, bytes)


def shared_fields(jobs: Sequence[Job], store: Callable[[Any], Any]) -> list[Job]:
    """``jobs`` with each field value that two or more of them share (the same object, not a
    plain number or string) replaced by ``_Shared(store(value))``, ``store`` called once per
    value."""
    seen: Counter[int] = Counter()
    for job in jobs:
        if dataclasses.is_dataclass(job):
            seen.update(id(getattr(job, f.name)) for f in dataclasses.fields(job)
                        if not isinstance(getattr(job, f.name), _PLAIN))
    tokens: dict[int, _Shared] = {}
    out: list[Job] = []
    for job in jobs:
        if not dataclasses.is_dataclass(job):
            out.append(job)
            continue
        changes = {}
        for f in dataclasses.fields(job):
            value = getattr(job, f.name)
            if not isinstance(value, _PLAIN) and seen[id(value)] > 1:
                if id(value) not in tokens:
                    tokens[id(value)] = _Shared(store(value))
                changes[f.name] = tokens[id(value)]
        out.append(dataclasses.replace(job, **changes) if changes else job)
    return out


_CACHED = 8
"""How many shared values an actor keeps (the latest batches')."""


def shipped(problem: Problem) -> tuple[Problem, Recipe | None]:
    """What goes to each worker for ``problem``: when its model was built from text here
    (:mod:`posgmc.model.origin`), the problem without the model and the recipe that builds it
    (the text, constants and build options: kilobytes, however large the model); else the
    problem as it is."""
    recipe = recipe_of(problem.model)
    if recipe is None:
        return problem, None
    return dataclasses.replace(problem, model=None), recipe  # type: ignore[arg-type]


class _Worker:
    """The actor: holds the problem (its model built here from the recipe, when one came, before
    the first job), runs jobs on it."""

    def __init__(self, problem: Problem, recipe: Recipe | None = None) -> None:
        self._given = problem
        self._recipe = recipe
        self._problem = problem if recipe is None else None
        self._shared: dict[Any, Any] = {}

    @property
    def problem(self) -> Problem:
        if self._problem is None:
            assert self._recipe is not None  # noqa: S101 - no problem yet: a recipe came
            self._problem = dataclasses.replace(self._given, model=self._recipe())
        return self._problem

    def _resolved(self, job: Job) -> Job:
        """``job`` with its shared fields fetched (once per value and actor)."""
        if not dataclasses.is_dataclass(job):
            return job
        changes = {}
        for f in dataclasses.fields(job):
            value = getattr(job, f.name)
            if isinstance(value, _Shared):
                if value.ref not in self._shared:
                    import ray

                    if len(self._shared) >= _CACHED:
                        del self._shared[next(iter(self._shared))]
                    self._shared[value.ref] = ray.get(value.ref)
                changes[f.name] = self._shared[value.ref]
        return dataclasses.replace(job, **changes) if changes else job

    def ready(self) -> bool:
        return True

    def run(self, job: Job, sent_clock: float, sent_wall: float) -> tuple[Any, float]:
        """``job``'s result and the seconds it took here; ``sent_clock``/``sent_wall``: the
        sender's ``perf_counter()`` and ``time()`` when it sent the job, from which the job's
        deadlines are moved into this process's clock (the wall clocks of a cluster's machines
        agree far better than their monotonic clocks, which count from each machine's boot)."""
        offset = (time.perf_counter() - sent_clock) - (time.time() - sent_wall)
        job = self._resolved(job)
        if abs(offset) >= SAME_CLOCK:
            job = rebased(job, offset)
        return timed(job, self.problem)


def _ray() -> Any:
    """The ray module, or a clear error when it is not installed."""
    try:
        import ray
    except ImportError:
        raise UnsupportedError("--executor ray needs Ray, which is not installed",
                               hint="pip install 'posgmc[ray]'") from None
    return ray


def _reachable(address: str) -> None:
    """Raises InputError when nothing listens at ``address`` (HOST:PORT)."""
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        raise InputError(f"--ray-address {address!r}: give HOST:PORT of the cluster's head",
                         hint="the address `ray start --head` printed, e.g. 10.0.0.5:6379")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=_CONNECT_SECONDS):
            pass
    except OSError as e:
        raise InputError(f"--ray-address {address}: no Ray cluster answers there ({e})",
                         hint="start one with `ray start --head --port=PORT`, or leave the "
                              "address out for a Ray on this machine") from None


def _connect(ray: Any, address: str | None) -> None:
    """Connect this process to the cluster at ``address`` (None: ``RAY_ADDRESS``, else a Ray
    started here for this process, never a cluster found lying around) unless it is connected
    already."""
    if ray.is_initialized():
        return
    given = address or os.environ.get("RAY_ADDRESS") or "local"
    if given not in ("auto", "local") and "://" not in given:
        _reachable(given)
    package = str(Path(posgmc.__file__).resolve().parent)
    before = descendants() if given == "local" else set()
    ray.init(address=given, include_dashboard=False, log_to_driver=False,
             logging_level="WARNING", runtime_env={"py_modules": [package]})
    if given == "local":
        # a Ray started here for this process: ended with it, helpers and all
        _STARTED.update(descendants() - before)
        _note_helpers()
        atexit.register(release)


_STARTED: set[Process] = set()
"""The processes ``ray.init()`` started here (its GCS server, raylet, ...); empty when this
process connected to a cluster that was already running."""

_HELPERS: set[Process] = set()
"""Every process seen below :data:`_STARTED` (agents, workers), kept because the terminal's
Ctrl-C may end a raylet before this process does, leaving its children without a parent to
find them by."""


def _note_helpers() -> None:
    """Add the processes now below :data:`_STARTED` to :data:`_HELPERS`."""
    for pid, _ in list(_STARTED):
        _HELPERS.update(descendants(pid))


def release() -> None:
    """Disconnect from Ray; when the Ray was started by this process, end every process it
    started that ``ray.shutdown()`` leaves running (its dashboard and runtime-environment agents
    do, and a Ctrl-C that reached the raylet first leaves more). Run at exit; harmless twice."""
    ray = sys.modules.get("ray")
    if ray is None:
        return
    _note_helpers()
    if ray.is_initialized():
        ray.shutdown()
    leftovers = _STARTED | _HELPERS
    _STARTED.clear()
    _HELPERS.clear()
    end(leftovers)


def _cluster_cpus(ray: Any) -> int:
    """The cluster's CPUs (those other work holds included: a worker waits for one to be
    freed, up to :data:`START_SECONDS`)."""
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


class RayPool:
    """``placement.workers`` actors on the Ray cluster (1: one per CPU of the cluster; at most
    as many as it has CPUs), each holding ``problem``; a batch of one job runs in this
    process, as :class:`~posgmc.synthesis.executors.ProcessPool` does.

    Raises:
        WorkerError: the actors did not start within :data:`START_SECONDS`.
    """

    kind = "ray"

    def __init__(self, problem: Problem, placement: Placement) -> None:
        ray = self._ray = _ray()
        self.problem = problem
        self.ledger = TaskLedger()
        _connect(ray, placement.address)
        cpus = _cluster_cpus(ray)
        self.workers = cpus if placement.workers <= 1 else min(placement.workers, cpus)
        actor = ray.remote(num_cpus=1, max_restarts=RETRIES, max_task_retries=RETRIES)(_Worker)
        light, recipe = shipped(problem)
        self._problem_ref = ray.put(light)
        self._actors = [actor.remote(self._problem_ref, recipe) for _ in range(self.workers)]
        started = [a.ready.remote() for a in self._actors]
        ready, _ = ray.wait(started, num_returns=len(started), timeout=START_SECONDS)
        _note_helpers()
        if len(ready) < len(started):
            self.close()
            raise WorkerError(
                f"{len(started) - len(ready)} of {len(started)} Ray workers did not start within "
                f"{START_SECONDS:.0f} s (each needs a free CPU on the cluster)",
                hint="see `ray status`: other work may hold the cluster's CPUs")

    def map(self, jobs: Sequence[Job]) -> list[Any]:
        if len(jobs) <= 1:
            return record_here(self.problem, self.ledger, jobs)
        ray = self._ray
        results: list[Any] = [None] * len(jobs)
        sent = shared_fields(jobs, ray.put)
        pending: dict[Any, tuple[int, Any]] = {}
        free = list(self._actors)
        queued = iter(range(len(jobs)))
        try:
            while True:
                for actor in list(free):
                    i = next(queued, None)
                    if i is None:
                        break
                    free.remove(actor)
                    ref = actor.run.remote(sent[i], time.perf_counter(), time.time())
                    pending[ref] = (i, actor)
                if not pending:
                    break
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    i, actor = pending.pop(ref)
                    results[i] = self._collect(ref, i, jobs)
                    free.append(actor)
        except BaseException:
            for ref in pending:
                ray.cancel(ref)
            raise
        return results

    def _collect(self, ref: Any, i: int, jobs: Sequence[Job]) -> Any:
        """Job ``i``'s result (recorded in the ledger), the job's own error re-raised, or a
        WorkerError naming the job when its worker died for good."""
        ray = self._ray
        try:
            result, seconds = ray.get(ref)
        except ray.exceptions.RayTaskError as e:
            raise e.cause from None  # the job's own exception, raised in the worker
        except (ray.exceptions.RayActorError, ray.exceptions.WorkerCrashedError,
                ray.exceptions.ObjectLostError, ray.exceptions.OutOfMemoryError) as e:
            raise WorkerError(
                f"job {i + 1} of {len(jobs)} ({phase_of(jobs[i])}) failed: its Ray worker died "
                f"{RETRIES + 1} times ({type(e).__name__})",
                hint="see `ray status` and the cluster's logs; a worker out of memory needs "
                     "nodes with more memory or a smaller model") from None
        self.ledger.record(phase_of(jobs[i]), seconds)
        return result

    def close(self) -> None:
        for actor in self._actors:
            self._ray.kill(actor, no_restart=True)
        self._actors = []
        self._problem_ref = None


def _call(function: Callable[..., Any], arguments: tuple[Any, ...]) -> Any:
    """A fanned-out call, run in a Ray worker (:mod:`posgmc.synthesis.fanout`)."""
    return function(*arguments)


def ray_results(function: Callable[..., Any], arguments: Sequence[tuple[Any, ...]],
                placement: Placement, names: Sequence[str], spread: Any = None,
                ) -> Generator[Any, None, None]:
    """``function(*args)`` for each of ``arguments`` as Ray tasks of one CPU each, at most
    ``placement.workers`` at a time (1: as many as the cluster has CPUs), yielded in their order;
    a task whose worker dies is retried :data:`RETRIES` times, then a :class:`WorkerError` names
    it (``names``). An early stop (an error, Ctrl-C, the caller done reading) cancels the tasks
    still running or queued. ``spread``: a :class:`~posgmc.synthesis.fanout.Spread` whose
    ``workers`` is set to the tasks run at once."""
    ray = _ray()
    _connect(ray, placement.address)
    cpus = _cluster_cpus(ray)
    limit = min(cpus if placement.workers <= 1 else min(placement.workers, cpus), len(arguments))
    if spread is not None:
        spread.workers = limit
    _note_helpers()
    remote = ray.remote(num_cpus=1, max_retries=RETRIES)(_call)
    refs: list[Any] = []
    running: set[Any] = set()

    def fill() -> None:
        while len(refs) < len(arguments) and len(running) < limit:
            refs.append(remote.remote(function, arguments[len(refs)]))
            running.add(refs[-1])

    try:
        for i in range(len(arguments)):
            fill()
            while refs[i] in running:
                ready, _ = ray.wait(list(running), num_returns=1, timeout=_POLL_SECONDS)
                if not ready and interrupted():
                    # Ctrl-C: the cluster's tasks cannot wind down as this process's phases
                    # do (they do not see the stop); they are cancelled
                    raise KeyboardInterrupt
                running.difference_update(ready)
                fill()
            yield _value(ray, refs[i], names[i])
            refs[i] = None  # the result is the caller's now; Ray may free it
    finally:
        for ref in running:
            ray.cancel(ref, force=True)


def _value(ray: Any, ref: Any, name: str) -> Any:
    """A finished task's result, its own exception re-raised, or a WorkerError naming it."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as e:
        raise e.cause from None
    except (ray.exceptions.WorkerCrashedError, ray.exceptions.ObjectLostError,
            ray.exceptions.OutOfMemoryError, ray.exceptions.TaskCancelledError) as e:
        raise WorkerError(
            f"{name} failed: its Ray worker died {RETRIES + 1} times ({type(e).__name__})",
            hint="see `ray status` and the cluster's logs; a worker out of memory needs "
                 "nodes with more memory or a smaller model") from None
