"""Finite-state strategies (FSS) of one player, as numpy arrays.

A finite-state strategy of player i is (N, n_I, γ, δ) ("Partially Observable Games for Secure
Autonomy", Ahmadi et al.): memory nodes N = {0..k-1}, an initial node n_I, an action map
γ(n, z) ∈ Distr(Act) and a memory update δ(n, z, a) ∈ Distr(N), where z is the player's
observation of the current state. The player consults and updates its memory only in the states
it owns (turn-based games): in a state s with observation z it picks a ~ γ(n, z), then
n' ~ δ(n, z, a), then the successor s' ~ P(s, a).

The strategy is stored in its *own* numbering of observations and actions (those its rules
mention), so it is independent of any compiled model; :mod:`posgmc.strategies.binding` maps it
onto a model. Notation: ``k`` memory nodes, ``Z`` observations, ``A`` actions.

==================  =========================  ==================================================
field               shape, dtype               invariant
==================  =========================  ==================================================
player              str                        the player's name ("" for a pomdp's agent)
memory_size         int                        k >= 1
initial_memory      int                        in [0, k)
observables         tuple[str, ...]            the player's observables, in declaration order
observation_values  int64[Z, len(observables)] distinct rows; row z is observation z
actions             tuple[str, ...]            distinct action labels ("" = unlabelled choice)
action              float64[k, Z, A]           γ: each (n, z) row sums to 1, or is all 0 when the
                                               strategy has no rule for (n, z)
update              float64[k, Z, A, k]        δ: sums to 1 over the last axis wherever
                                               action[n, z, a] > 0
==================  =========================  ==================================================

Observations of a DRN model have no observables (``observables == ()``); their rules then name
the observation by its id in the file, kept as the single column of ``observation_values``.

``boolean`` marks the observables that are Boolean (written ``true``/``false`` in files; stored as
1/0); empty means none is. ``source`` and ``rule_index`` (int64[k, Z], -1 where no rule) remember
where each rule came from in a strategy file, so that errors found when the strategy meets a model
name the file and the rule's JSON path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posgmc.errors import InputError

__all__ = ["FiniteStateStrategy", "StrategyError", "PROBABILITY_TOLERANCE"]

PROBABILITY_TOLERANCE = 1e-9
"""How far a distribution's sum may be from 1."""


class StrategyError(InputError):
    """A strategy (file or object) is malformed or does not fit the model.

    ``path`` is the JSON path of the offending part of a strategy file (``rules[3].action.via1``),
    None when the error is not about one place."""

    def __init__(self, message: str, *, path: str | None = None, file: str | None = None,
                 hint: str | None = None) -> None:
        where = ": ".join(p for p in (file, path) if p)
        super().__init__(f"{where}: {message}" if where else message, hint=hint)
        self.path = path
        self.file = file


@dataclass(frozen=True, eq=False)
class FiniteStateStrategy:
    """See the module docstring for every field's shape, dtype and invariant."""

    player: str
    memory_size: int
    initial_memory: int
    observables: tuple[str, ...]
    observation_values: np.ndarray
    actions: tuple[str, ...]
    action: np.ndarray
    update: np.ndarray
    boolean: tuple[bool, ...] = ()
    source: str | None = None
    rule_index: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.validate()
        for a in (self.observation_values, self.action, self.update):
            a.setflags(write=False)

    # -- sizes ------------------------------------------------------------------------------------

    @property
    def num_observations(self) -> int:
        return int(self.observation_values.shape[0])

    @property
    def num_actions(self) -> int:
        return len(self.actions)

    def rule_path(self, n: int, z: int) -> str | None:
        """The JSON path of the rule for memory n under observation z, if read from a file."""
        if self.rule_index is None or self.rule_index[n, z] < 0:
            return None
        return f"rules[{int(self.rule_index[n, z])}]"

    def describe_observation(self, z: int) -> str:
        """Observation z as a user wrote it: ``{pos=0}``, or its id for a DRN model."""
        row = self.observation_values[z].tolist()
        if not self.observables:
            return f"observation {row[0]}"
        return "{" + ", ".join(f"{n}={v}" for n, v in zip(self.observables, row)) + "}"

    @property
    def has_rule(self) -> np.ndarray:
        """bool[k, Z]: whether the strategy says what to do in memory n under observation z."""
        return np.asarray(self.action.sum(axis=2) > 0)

    @property
    def is_deterministic(self) -> bool:
        """Every rule picks one action and one next memory node with probability 1."""
        ruled = self.action[self.has_rule]
        if not np.all(np.isclose(ruled.max(axis=1), 1.0)):
            return False
        used = self.action > 0
        return bool(np.all(np.isclose(self.update[used].max(axis=1), 1.0)))

    def validate(self) -> None:
        """Check every invariant of the module docstring.

        Raises:
            StrategyError: the first invariant that does not hold.
        """
        k, Z, A = self.memory_size, self.num_observations, self.num_actions
        if k < 1:
            raise StrategyError(f"memory_size must be at least 1, got {k}")
        if not 0 <= self.initial_memory < k:
            raise StrategyError(f"initial_memory {self.initial_memory} is not a node in 0..{k - 1}")
        columns = len(self.observables) or 1  # no observables: the observation's id (DRN)
        if self.observation_values.ndim != 2 or self.observation_values.shape[1] != columns:
            raise StrategyError("observation_values must have one column per observable")
        if self.observation_values.dtype != np.int64:
            raise StrategyError("observation_values must be int64")
        if self.boolean and len(self.boolean) != len(self.observables):
            raise StrategyError("boolean must have one entry per observable (or be empty)")
        if len(set(self.actions)) != A:
            raise StrategyError("action labels must be distinct")
        if self.action.shape != (k, Z, A) or self.update.shape != (k, Z, A, k):
            raise StrategyError(
                f"action must have shape {(k, Z, A)} and update {(k, Z, A, k)}; got "
                f"{self.action.shape} and {self.update.shape}"
            )
        if Z and np.unique(self.observation_values, axis=0).shape[0] != Z:
            raise StrategyError("observation_values must be distinct rows")
        if np.any(self.action < 0) or np.any(self.update < 0) or not (
            np.all(np.isfinite(self.action)) and np.all(np.isfinite(self.update))
        ):
            raise StrategyError("probabilities must be finite and non-negative")
        sums = self.action.sum(axis=2)
        bad = ~(np.isclose(sums, 0.0, atol=0) | (np.abs(sums - 1.0) <= PROBABILITY_TOLERANCE))
        if np.any(bad):
            n, z = map(int, np.argwhere(bad)[0])
            raise StrategyError(f"the action distribution of memory {n}, observation {z} sums to "
                                f"{sums[n, z]!r}, not 1")
        used = self.action > 0
        usums = self.update.sum(axis=3)
        bad = used & (np.abs(usums - 1.0) > PROBABILITY_TOLERANCE)
        if np.any(bad):
            n, z, a = map(int, np.argwhere(bad)[0])
            raise StrategyError(f"the memory update of memory {n}, observation {z}, action "
                                f"{self.actions[a]!r} sums to {usums[n, z, a]!r}, not 1")

    # -- construction -----------------------------------------------------------------------------

    @staticmethod
    def from_arrays(
        *,
        player: str,
        observables: tuple[str, ...],
        observation_values: np.ndarray,
        actions: tuple[str, ...],
        action: np.ndarray,
        update: np.ndarray | None = None,
        initial_memory: int = 0,
    ) -> FiniteStateStrategy:
        """A strategy from its arrays; ``update`` None keeps the memory (δ(n, z, a) = n).

        The memory size is ``action.shape[0]``."""
        action = np.asarray(action, dtype=np.float64)
        k = int(action.shape[0])
        if update is None:
            update = np.zeros(action.shape + (k,))
            update[np.arange(k), :, :, np.arange(k)] = 1.0
        return FiniteStateStrategy(
            player=player,
            memory_size=k,
            initial_memory=initial_memory,
            observables=tuple(observables),
            observation_values=np.asarray(observation_values, dtype=np.int64).reshape(
                action.shape[1], -1
            ),
            actions=tuple(actions),
            action=action,
            update=np.asarray(update, dtype=np.float64),
        )
