"""What a synthesis run returns: the best defence, its verified numbers, and how it was found."""

from __future__ import annotations

from dataclasses import dataclass, field

from posgmc.checking.results import Bound
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.synthesis.deterministic import DeterministicResult

__all__ = ["MemoryRound", "SynthesisResult"]


@dataclass(frozen=True)
class MemoryRound:
    """The best defence with at most ``memory`` nodes after that round, and its value by policy
    iteration on its product (exact linear solves: a ranking, not a proof)."""

    memory: int
    guaranteed: Bound
    deterministic: bool
    evaluations: int
    seconds: float


@dataclass(frozen=True)
class SynthesisResult:
    """The best defence found and its verified numbers. ``guaranteed``: proven bounds on what the
    strategy ensures against every adversary; ``full_observation``: the value when the decision
    maker sees everything, which no partially observing defence exceeds (for Pmax; for Pmin no
    defence gets below it); ``partial``: something cut the work budget short, ``cut`` says what
    ("timeout": the wall-clock cap, "interrupt"; None when the budget ran to its end);
    ``method``: how ``guaranteed`` was checked."""

    strategy: FiniteStateStrategy
    guaranteed: Bound
    full_observation: Bound
    rounds: tuple[MemoryRound, ...]
    partial: bool
    phases: dict[str, float] = field(default_factory=dict)
    method: str = "interval"
    deterministic: tuple[DeterministicResult, ...] = ()
    """The deterministic search's best defence per memory size
    (:mod:`posgmc.synthesis.deterministic`)."""
    cut: str | None = None
