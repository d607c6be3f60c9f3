"""The choice of executor for a synthesis problem's jobs: in this process, a local process pool
(:mod:`posgmc.synthesis.jobs`) or actors on a Ray cluster (:mod:`posgmc.synthesis.ray_pool`)."""

from __future__ import annotations

from posgmc.synthesis.jobs import Executor, InProcess, Placement, Problem, ProcessPool

__all__ = ["executor_for"]


def executor_for(problem: Problem, jobs: int | Placement) -> Executor:
    """Where ``problem``'s jobs run: ``jobs`` = 1 (or a local :class:`Placement` of one worker):
    in this process; more: a local process pool of that many workers; a Ray placement: actors
    on the Ray cluster (:mod:`posgmc.synthesis.ray_pool`).

    Raises:
        UnsupportedError: Ray asked for and not installed.
        InputError: the Ray cluster's address cannot be reached.
    """
    placement = jobs if isinstance(jobs, Placement) else Placement(workers=jobs)
    if placement.executor == "ray":
        from posgmc.synthesis.ray_pool import RayPool  # imports ray: only when asked for

        return RayPool(problem, placement)
    if placement.workers <= 1:
        return InProcess(problem)
    return ProcessPool(problem, placement.workers)
