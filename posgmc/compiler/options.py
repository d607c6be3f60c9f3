"""The options of a build and the record it returns."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from posgmc.model.explicit import ExplicitModel

__all__ = ["BuildOptions", "BuildResult", "ProgressMode", "ValidationMode"]


class ProgressMode(enum.Enum):
    """When to report exploration progress on stderr."""

    AUTO = "auto"  # only when stderr is a terminal
    ALWAYS = "always"
    NEVER = "never"


class ValidationMode(enum.Enum):
    """When to run :meth:`ExplicitModel.validate` on the result (it re-checks every row sum)."""

    AUTO = "auto"  # models with at most ``BuildOptions.validate_limit`` transitions
    ALWAYS = "always"
    NEVER = "never"


@dataclass(frozen=True, kw_only=True)
class BuildOptions:
    """How to build.

    ``state_limit``: stop with a :class:`~posgmc.errors.LimitError` once more states are found.
    ``fix_deadlocks``: give states without any enabled choice a self-loop (PRISM/Storm default);
    otherwise such a state is a :class:`~posgmc.errors.BuildError`. ``build_observations``: compute
    the observation functions (pomdp/posg/smg with observables). ``probability_tolerance``: how far
    the update probabilities of a command may sum from 1. ``initial_state_limit``: the largest
    number of candidate valuations enumerated for an ``init ... endinit`` predicate (after fixing
    the variables it pins to one value). ``exact``: explore in rational arithmetic (PRISM's
    ``-exact``, :mod:`posgmc.compiler.exact_explore`): the model carries its exact transition
    probabilities.
    ``memory_guard``: stop with a :class:`~posgmc.errors.LimitError` once the memory still
    available (:mod:`posgmc.resources`: the kernel's available memory and ``RLIMIT_AS``) is less
    than what exploring has taken so far, so that assembling the model still fits (the CLI turns
    it off when the user gives ``--state-limit``). ``deadline``: a ``time.perf_counter()`` value
    at which exploring stops with a :class:`~posgmc.errors.LimitError` (None: no deadline).
    """

    state_limit: int = 50_000_000
    fix_deadlocks: bool = True
    progress: ProgressMode = ProgressMode.AUTO
    build_observations: bool = True
    validation: ValidationMode = ValidationMode.AUTO
    validate_limit: int = 1_000_000
    probability_tolerance: float = 1e-9
    initial_state_limit: int = 1 << 28
    exact: bool = False
    memory_guard: bool = True
    deadline: float | None = None


@dataclass(frozen=True, eq=False)
class BuildResult:
    """The built model, the wall time of the build, and warnings such as fixed deadlocks."""

    model: ExplicitModel
    seconds: float
    warnings: tuple[str, ...] = ()
