"""How a synthesis run is configured: memory sizes, budget, seed, adversary phases, workers."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from posgmc.errors import InputError

__all__ = ["AUTO_MEMORY", "Gap", "SynthesisOptions"]

AUTO_MEMORY = (1, 2, 3)
"""The memory sizes of memory ``auto`` (the default)."""


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
    """``memory``: the memory sizes to try in order; ``timeout``: seconds for the whole search;
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
    size) ``adversary_memory``. ``jobs``: worker processes for independent evaluations
    (:mod:`posgmc.synthesis.executors`; results do not depend on it). ``started``: the
    ``time.perf_counter()`` value from which the first synthesised property's ``timeout`` counts
    (the CLI and :func:`posgmc.api.check` set it where the run starts, so that loading and
    building the model are inside the budget); None: from the start of its synthesis.
    ``bracket``: also prove the other side of the optimum (:mod:`posgmc.synthesis.bracket`);
    ``gap``: refine the bracket until it is this narrow (the budget is then shared between the
    two sides; None: the bound side gets a small extra share, ``bracket.DEFAULT_SHARE``)."""

    memory: tuple[int, ...] = AUTO_MEMORY
    timeout: float = 30.0
    seed: int = 0
    restarts: int = 3
    iterations: int = 60
    learning_rate: float = 0.3
    verify: int = 3
    adversaries: int = 10
    adversary_memory: int = 1
    player_memory: tuple[tuple[str, tuple[int, ...]], ...] = ()
    jobs: int = 1
    enumeration_limit: int = 1000
    compose_restarts: int = 1
    oracle_rounds: int = 8
    started: float | None = None
    belief: bool | None = None
    bracket: bool = True
    gap: Gap | None = None

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
