"""How a synthesis run is configured: memory sizes, budget, seed, adversary phases, workers."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

from posgmc.errors import InputError
from posgmc.synthesis.budget import Effort
from posgmc.synthesis.tasks import Placement

__all__ = ["AUTO_MEMORY", "MAX_MEMORY", "Gap", "SynthesisOptions", "memory_sizes"]

AUTO_MEMORY = (1, 2, 3)
"""The memory sizes of memory ``auto`` (the default)."""

MAX_MEMORY = 10_000
"""The largest memory size accepted: a strategy with k nodes has k^2 x observations x actions
memory updates, so far larger sizes are typing mistakes (and ``--memory 1..10**20`` would list
10**20 sizes)."""


def _positive_finite(value: object, name: str, what: str) -> None:
    """Refuse a value that is not a positive finite real (nan would mean no deadline at all)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not (math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be {what}, got {value!r}")


def memory_sizes(value: object, what: str) -> tuple[int, ...]:
    """Memory sizes as a tuple: one size or a sequence of them, each an int in 1..MAX_MEMORY,
    ascending (the search tries them in order and escalates).

    Raises:
        InputError: anything else, naming ``what``.
    """
    sizes: tuple[object, ...]
    if isinstance(value, int) and not isinstance(value, bool):
        sizes = (value,)
    elif isinstance(value, (tuple, list, range)):
        sizes = tuple(value)
    else:
        raise InputError(f"{what} must be a memory size (an int) or a sequence of them, got "
                         f"{value!r}")
    if not sizes or any(isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= MAX_MEMORY
                        for k in sizes):
        raise InputError(f"{what} must be ints from 1 to {MAX_MEMORY}, got {value!r}")
    ints = tuple(int(k) for k in sizes)  # type: ignore[call-overload]
    if list(ints) != sorted(set(ints)):
        raise InputError(f"{what} must ascend without repeats (the search escalates through "
                         f"them), got {value!r}", hint=f"e.g. {tuple(sorted(set(ints)))}")
    return ints


@dataclass(frozen=True)
class Gap:
    """A requested bracket width: ``value`` absolute, or relative (a fraction of the larger
    magnitude of the two sides) when ``relative``."""

    value: float
    relative: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.value) and self.value >= 0):
            raise InputError(f"the gap must be a finite number >= 0, got {self.value!r}")

    @staticmethod
    def parse(text: str) -> Gap:
        """``"0.05"`` (absolute) or ``"5%"`` (relative).

        Raises:
            InputError: anything else.
        """
        t = text.strip()
        relative = t.endswith("%")
        try:
            v = float(t[:-1] if relative else t)
        except ValueError:
            raise InputError(f"the gap is a number or a percentage (0.05, 5%), not {text!r}",
                             hint="write --gap 0.01 or --gap 1%") from None
        return Gap(v / 100.0 if relative else v, relative)

    def width(self, a: float, b: float) -> float:
        """The allowed width for a bracket with sides ``a`` and ``b``."""
        if not self.relative:
            return self.value
        scale = max(abs(a), abs(b))
        return self.value * scale if math.isfinite(scale) else 0.0

    def met(self, lower: float, upper: float) -> bool:
        return upper - lower <= self.width(lower, upper) if math.isfinite(upper - lower) \
            else lower == upper


@dataclass(frozen=True)
class SynthesisOptions:
    """``memory``: the memory sizes to try in order; ``timeout``: a wall-clock cap in seconds on
    the whole synthesis of a property (None: none); ``effort``: the multiplier of every phase's
    work budget (:class:`~posgmc.synthesis.budget.Effort`; the counts below are at effort 1);
    ``restarts``: random starts per memory size; ``iterations``: gradient steps per start;
    ``verify``: how many of the best candidates (by float value) the sound engines verify;
    ``adversaries``: M, how many of the strongest enumerated adversary strategies (deterministic,
    ``adversary_memory`` nodes; :mod:`posgmc.synthesis.adversaries`) the defence is composed
    against (0: no adversary phases); ``enumeration_limit``: how many are enumerated and ranked
    at most; ``compose_restarts``: random starts of the composition besides the search's defence;
    ``oracle_rounds``: double-oracle rounds at most (:mod:`posgmc.synthesis.double_oracle`).
    ``belief``: on a pomdp, also build a belief-based controller over the search's best
    defence (:mod:`posgmc.synthesis.belief`), which has more memory nodes than ``memory``; None
    (memory auto): when ``memory`` is the default and ``player_memory`` does not name the
    decision maker.
    ``player_memory``: memory sizes by player name (``--memory rover=1..3 --memory
    attacker=2``); the decision maker's entry replaces ``memory``, the adversary's (its largest
    size) ``adversary_memory``. ``jobs``: workers for independent evaluations
    (:mod:`posgmc.synthesis.executors`; results do not depend on it); ``executor``: where they
    run, "local" (this process or a local process pool) or "ray" (actors on the Ray cluster at
    ``ray_address``: HOST:PORT, None: Ray's ``RAY_ADDRESS`` or a Ray started for the run;
    :mod:`posgmc.synthesis.ray_pool`). ``started``: the
    ``time.perf_counter()`` value from which the first synthesised property's ``timeout`` counts
    (the CLI and :func:`posgmc.api.check` set it where the run starts, so that loading and
    building the model are inside the budget); None: from the start of its synthesis.
    ``bracket``: also prove the other side of the optimum (:mod:`posgmc.synthesis.bracket`);
    ``gap``: refine the bracket until it is this narrow (the budget is then shared between the
    two sides; None: the bound side gets a small extra share, ``bracket.DEFAULT_SHARE``)."""

    memory: tuple[int, ...] = AUTO_MEMORY
    timeout: float | None = None
    effort: float = 1.0
    seed: int = 0
    restarts: int = 0
    iterations: int = 30
    learning_rate: float = 0.3
    verify: int = 3
    adversaries: int = 10
    adversary_memory: int = 1
    player_memory: tuple[tuple[str, tuple[int, ...]], ...] = ()
    jobs: int = 1
    executor: Literal["local", "ray"] = "local"
    ray_address: str | None = None
    enumeration_limit: int = 100
    compose_restarts: int = 0
    oracle_rounds: int = 1
    started: float | None = None
    belief: bool | None = None
    bracket: bool = True
    gap: Gap | None = None

    def __post_init__(self) -> None:
        """Each field checked, so that a bad value is an :class:`InputError` naming it (and the
        API argument of the same name) rather than a raw error deep in the search.

        Raises:
            InputError: a field of the wrong type or out of range.
        """
        object.__setattr__(self, "memory", memory_sizes(self.memory, "memory"))
        named = self.player_memory
        if not isinstance(named, tuple) or not all(
                isinstance(e, tuple) and len(e) == 2 and isinstance(e[0], str) for e in named):
            raise InputError(f"player_memory must be (player name, sizes) pairs, got {named!r}")
        object.__setattr__(self, "player_memory", tuple(
            (p, memory_sizes(k, f"memory of {p!r}")) for p, k in named))
        if self.timeout is not None:
            _positive_finite(self.timeout, "timeout", "a positive finite number of seconds or None")
        _positive_finite(self.effort, "effort", "a positive finite number")
        _positive_finite(self.learning_rate, "learning_rate", "a positive finite number")
        for name, least in (("seed", 0), ("restarts", 0), ("iterations", 0), ("verify", 1),
                            ("adversaries", 0), ("adversary_memory", 1), ("jobs", 1),
                            ("enumeration_limit", 1), ("compose_restarts", 0),
                            ("oracle_rounds", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise InputError(f"{name} must be an int of at least {least}, got {value!r}")
        if self.adversary_memory > MAX_MEMORY:
            raise InputError(f"adversary_memory must be at most {MAX_MEMORY}, got "
                             f"{self.adversary_memory}")
        if self.started is not None and (isinstance(self.started, bool) or not isinstance(
                self.started, (int, float)) or not math.isfinite(self.started)):
            raise InputError(f"started must be a time.perf_counter() value, got {self.started!r}")
        if self.belief is not None and not isinstance(self.belief, bool):
            raise InputError(f"belief must be True, False or None, got {self.belief!r}")
        if self.executor not in ("local", "ray"):
            raise InputError(f"executor must be 'local' or 'ray', got {self.executor!r}")
        if self.ray_address is not None and (not isinstance(self.ray_address, str)
                                             or self.executor != "ray"):
            raise InputError(f"ray_address must be a HOST:PORT string with executor 'ray', got "
                             f"{self.ray_address!r} with executor {self.executor!r}")

    @property
    def placement(self) -> Placement:
        """Where the independent evaluations run."""
        return Placement(self.executor, self.jobs, self.ray_address)
        if not isinstance(self.bracket, bool):
            raise InputError(f"bracket must be True or False, got {self.bracket!r}")
        if self.gap is not None and not isinstance(self.gap, Gap):
            raise InputError(f"gap must be a Gap (or None), got {self.gap!r}")

    def for_players(self, decision_maker: str, adversary: str | None,
                    players: tuple[str, ...]) -> SynthesisOptions:
        """These options with ``player_memory`` resolved for a property's players.

        Raises:
            InputError: a name that is not a player of the model.
        """
        named = dict(self.player_memory)
        unknown = sorted(set(named) - set(players))
        if unknown:
            raise InputError(
                f"--memory names {', '.join(repr(u) for u in unknown)}, which is not a player of "
                f"the model", hint=f"the players are {', '.join(players) or '(none)'}")
        memory = named.get(decision_maker, self.memory)
        adversary_memory = max(named[adversary]) if adversary in named else self.adversary_memory
        with_belief = self.belief if self.belief is not None else (
            decision_maker not in named and self.memory == AUTO_MEMORY)
        return replace(self, memory=memory, adversary_memory=adversary_memory, player_memory=(),
                       belief=with_belief)

    @property
    def budget(self) -> Effort:
        """The work budget's multiplier."""
        return Effort(self.effort)
