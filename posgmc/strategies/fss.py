"""Finite-state strategies (FSS) of one player, stored as the rules that define them.

A finite-state strategy of player i is (N, n_I, γ, δ) ("Partially Observable Games for Secure
Autonomy", Ahmadi et al.): memory nodes N = {0..k-1}, an initial node n_I, an action map
γ(n, z) ∈ Distr(Act) and a memory update δ(n, z, a) ∈ Distr(N), where z is the player's
observation of the current state. The player consults and updates its memory only in the states
it owns (turn-based games): in a state s with observation z it picks a ~ γ(n, z), then
n' ~ δ(n, z, a), then the successor s' ~ P(s, a).

The strategy is stored in its *own* numbering of observations and actions (those its rules
mention), so it is independent of any compiled model; :mod:`posgmc.strategies.binding` maps it
onto a model. Notation: ``k`` memory nodes, ``Z`` observations, ``A`` actions, ``R`` rules (the
(n, z) pairs that have one), ``E`` played actions (pairs (rule, a) with γ(n, z)(a) > 0), ``U``
memory updates (pairs (played action, n') with δ(n, z, a)(n') > 0).

Only what is written is stored: memory grows with R + E + U, never with k²·Z·A, so a strategy with
20,000 memory nodes costs what its rules cost. The three levels are compressed rows (CSR):

==================  =========================  ==================================================
field               shape, dtype               invariant
==================  =========================  ==================================================
player              str                        the player's name ("" for a pomdp's agent)
memory_size         int                        1 <= k <= MAX_MEMORY_SIZE
initial_memory      int                        in [0, k)
observables         tuple[str, ...]            the player's observables, in declaration order
observation_values  int64[Z, len(observables)] distinct rows; row z is observation z
actions             tuple[str, ...]            distinct action labels ("" = unlabelled choice)
rule_memory         int64[R]                   n of rule r, in [0, k)
rule_observation    int64[R]                   z of rule r, in [0, Z); rules sorted by (n, z),
                                               no pair twice
choice_start        int64[R + 1]               rule r plays the entries
                                               choice_start[r]:choice_start[r + 1] (at least one)
choice_action       int64[E]                   a, in [0, A); increasing within a rule
choice_probability  float64[E]                 γ(n, z)(a) in (0, 1]; sums to 1 per rule
update_start        int64[E + 1]               entry e moves memory by the updates
                                               update_start[e]:update_start[e + 1] (at least one)
update_node         int64[U]                   n', in [0, k); increasing within an entry
update_probability  float64[U]                 δ(n, z, a)(n') in (0, 1]; sums to 1 per entry
==================  =========================  ==================================================

:attr:`FiniteStateStrategy.action` (float64[k, Z, A]) and :attr:`~FiniteStateStrategy.update`
(float64[k, Z, A, k]) give the dense arrays for the algorithms that work on them (synthesis over
small memories); they are computed on first use, after checking that they fit in memory, and a
strategy made from dense arrays (:meth:`FiniteStateStrategy.from_arrays`) keeps the ones it was
given. Lookups of many (n, z, a) at once (:meth:`~FiniteStateStrategy.rule_of`,
:meth:`~FiniteStateStrategy.entry_of`) are binary searches over the sorted rules.

Observations of a DRN model have no observables (``observables == ()``); their rules then name
the observation by its id in the file, kept as the single column of ``observation_values``.

``boolean`` marks the observables that are Boolean (written ``true``/``false`` in files; stored as
1/0); empty means none is. ``source`` and ``rule_source`` (int64[R], the index of each rule in the
file's ``rules`` list) remember where each rule came from, so that errors found when the strategy
meets a model name the file and the rule's JSON path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from posgmc.errors import InputError
from posgmc.resources import check_allocation

__all__ = ["FiniteStateStrategy", "StrategyError", "PROBABILITY_TOLERANCE", "MAX_MEMORY_SIZE"]

PROBABILITY_TOLERANCE = 1e-9
"""How far a distribution's sum may be from 1."""

MAX_MEMORY_SIZE = (1 << 31) - 1
"""The largest memory size: a memory node, and the product of a model state with one, must be
addressable by 64-bit integers."""


_TABLE_ENTRIES = 1 << 22
"""Up to this many (n, z, a) triples, :meth:`FiniteStateStrategy.entry_at` uses a direct table
(32 MB at most)."""


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


def _starts(owner: np.ndarray, num_owners: int) -> np.ndarray:
    """int64[num_owners + 1]: CSR starts of elements sorted by ``owner``."""
    counts = np.bincount(owner, minlength=num_owners) if owner.size else np.zeros(num_owners, int)
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)


def _segment_ids(starts: np.ndarray) -> np.ndarray:
    """int64[starts[-1]]: the segment of each element of a CSR layout."""
    return np.repeat(np.arange(starts.size - 1, dtype=np.int64), np.diff(starts))


@dataclass(frozen=True, eq=False)
class FiniteStateStrategy:
    """See the module docstring for every field's shape, dtype and invariant."""

    player: str
    memory_size: int
    initial_memory: int
    observables: tuple[str, ...]
    observation_values: np.ndarray
    actions: tuple[str, ...]
    rule_memory: np.ndarray
    rule_observation: np.ndarray
    choice_start: np.ndarray
    choice_action: np.ndarray
    choice_probability: np.ndarray
    update_start: np.ndarray
    update_node: np.ndarray
    update_probability: np.ndarray
    boolean: tuple[bool, ...] = ()
    source: str | None = None
    rule_source: np.ndarray | None = None
    _dense: dict[str, np.ndarray] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.validate()
        for a in (self.observation_values, self.rule_memory, self.rule_observation,
                  self.choice_start, self.choice_action, self.choice_probability,
                  self.update_start, self.update_node, self.update_probability):
            a.setflags(write=False)

    # -- sizes ------------------------------------------------------------------------------------

    @property
    def num_observations(self) -> int:
        return int(self.observation_values.shape[0])

    @property
    def num_actions(self) -> int:
        return len(self.actions)

    @property
    def num_rules(self) -> int:
        return int(self.rule_memory.size)

    # -- lookups ----------------------------------------------------------------------------------

    def _rule_keys(self) -> np.ndarray:
        return np.asarray(self.rule_memory * max(self.num_observations, 1) + self.rule_observation)

    def rule_of(self, memory: np.ndarray, observation: np.ndarray) -> np.ndarray:
        """int64[...]: the rule for each (memory n, observation z) pair, -1 where there is none
        (also where z is -1)."""
        memory = np.asarray(memory, dtype=np.int64)
        observation = np.asarray(observation, dtype=np.int64)
        keys = self._rule_keys()
        want = memory * max(self.num_observations, 1) + observation
        if not keys.size:
            return np.full(np.shape(want), -1, dtype=np.int64)
        pos = np.minimum(np.searchsorted(keys, want), keys.size - 1)
        return np.where((keys[pos] == want) & (observation >= 0), pos, -1).astype(np.int64)

    def entry_of(self, rule: np.ndarray, action: np.ndarray) -> np.ndarray:
        """int64[...]: the played-action entry of each (rule r, action a) pair, -1 where the rule
        does not play a (also where r or a is -1)."""
        rule = np.asarray(rule, dtype=np.int64)
        action = np.asarray(action, dtype=np.int64)
        A = max(self.num_actions, 1)
        keys = _segment_ids(self.choice_start) * A + self.choice_action
        want = rule * A + action
        if not keys.size:
            return np.full(np.shape(want), -1, dtype=np.int64)
        pos = np.minimum(np.searchsorted(keys, want), keys.size - 1)
        ok = (keys[pos] == want) & (rule >= 0) & (action >= 0)
        return np.where(ok, pos, -1).astype(np.int64)

    def entry_at(self, memory: np.ndarray, observation: np.ndarray,
                 action: np.ndarray) -> np.ndarray:
        """int64[...]: the played-action entry of each (n, z, a), -1 where the strategy does not
        play a there (also where z or a is -1). A direct table when k·Z·A is small (the
        strategies synthesis makes), binary searches over the rules otherwise."""
        memory = np.asarray(memory, dtype=np.int64)
        observation = np.asarray(observation, dtype=np.int64)
        action = np.asarray(action, dtype=np.int64)
        Z, A = self.num_observations, self.num_actions
        if self.memory_size * Z * A > _TABLE_ENTRIES:
            return self.entry_of(self.rule_of(memory, observation), action)
        if "entry" not in self._dense:
            table = np.full(self.memory_size * Z * A, -1, dtype=np.int64)
            rule = _segment_ids(self.choice_start)
            table[(self.rule_memory[rule] * Z + self.rule_observation[rule]) * A
                  + self.choice_action] = np.arange(self.choice_action.size)
            table.setflags(write=False)
            self._dense["entry"] = table
        ok = (observation >= 0) & (action >= 0)
        flat = np.where(ok, (memory * Z + observation) * A + action, 0)
        return np.where(ok, self._dense["entry"][flat], -1) if flat.size and Z * A else \
            np.full(np.shape(flat), -1, dtype=np.int64)

    def rule_path(self, n: int, z: int) -> str | None:
        """The JSON path of the rule for memory n under observation z, if read from a file."""
        r = int(self.rule_of(np.array(n), np.array(z)))
        if self.rule_source is None or r < 0 or self.rule_source[r] < 0:
            return None
        return f"rules[{int(self.rule_source[r])}]"

    def describe_observation(self, z: int) -> str:
        """Observation z as a user wrote it: ``{pos=0}``, or its id for a DRN model."""
        row = self.observation_values[z].tolist()
        if not self.observables:
            return f"observation {row[0]}"
        return "{" + ", ".join(f"{n}={v}" for n, v in zip(self.observables, row)) + "}"

    @property
    def is_deterministic(self) -> bool:
        """Every rule picks one action and one next memory node with probability 1."""
        return bool(
            np.all(np.diff(self.choice_start) == 1) and np.all(np.diff(self.update_start) == 1)
            and np.allclose(self.choice_probability, 1.0)
            and np.allclose(self.update_probability, 1.0)
        )

    # -- dense arrays -----------------------------------------------------------------------------

    def _check_dense(self, what: str, shape: tuple[int, ...]) -> None:
        size = 8.0
        for d in shape:
            size *= d
        check_allocation(
            size, f"the dense {what} array {shape} of the strategy of player {self.player!r}",
            hint="this algorithm works on dense strategies; use a strategy with fewer memory "
            "nodes, observations or actions",
        )

    @property
    def has_rule(self) -> np.ndarray:
        """bool[k, Z]: whether the strategy says what to do in memory n under observation z."""
        shape = (self.memory_size, self.num_observations)
        self._check_dense("has_rule", shape)
        out = np.zeros(shape, dtype=bool)
        out[self.rule_memory, self.rule_observation] = True
        return out

    @property
    def action(self) -> np.ndarray:
        """float64[k, Z, A]: γ, each (n, z) row summing to 1, or all 0 where there is no rule."""
        if "action" not in self._dense:
            shape = (self.memory_size, self.num_observations, self.num_actions)
            self._check_dense("action", shape)
            gamma = np.zeros(shape)
            rule = _segment_ids(self.choice_start)
            gamma[self.rule_memory[rule], self.rule_observation[rule], self.choice_action] = \
                self.choice_probability
            gamma.setflags(write=False)
            self._dense["action"] = gamma
        return self._dense["action"]

    @property
    def update(self) -> np.ndarray:
        """float64[k, Z, A, k]: δ, summing to 1 over the last axis wherever action > 0."""
        if "update" not in self._dense:
            k = self.memory_size
            shape = (k, self.num_observations, self.num_actions, k)
            self._check_dense("update", shape)
            delta = np.zeros(shape)
            entry = _segment_ids(self.update_start)
            rule = _segment_ids(self.choice_start)[entry]
            delta[self.rule_memory[rule], self.rule_observation[rule], self.choice_action[entry],
                  self.update_node] = self.update_probability
            delta.setflags(write=False)
            self._dense["update"] = delta
        return self._dense["update"]

    # -- validation -------------------------------------------------------------------------------

    def validate(self) -> None:
        """Check every invariant of the module docstring.

        Raises:
            StrategyError: the first invariant that does not hold.
        """
        k, Z, A, R = self.memory_size, self.num_observations, self.num_actions, self.num_rules
        if k < 1:
            raise StrategyError(f"memory_size must be at least 1, got {k}")
        if k > MAX_MEMORY_SIZE:
            raise StrategyError(
                f"memory_size {k} is more than the largest supported, {MAX_MEMORY_SIZE}"
            )
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
        if Z and np.unique(self.observation_values, axis=0).shape[0] != Z:
            raise StrategyError("observation_values must be distinct rows")
        arrays = (self.rule_memory, self.rule_observation, self.choice_start, self.choice_action,
                  self.update_start, self.update_node)
        if any(a.dtype != np.int64 or a.ndim != 1 for a in arrays) or any(
            a.dtype != np.float64 or a.ndim != 1
            for a in (self.choice_probability, self.update_probability)
        ):
            raise StrategyError("the rule arrays must be one-dimensional int64 (float64 for "
                                "probabilities)")
        E, U = self.choice_action.size, self.update_node.size
        if (self.rule_observation.size != R or self.choice_start.size != R + 1
                or self.choice_probability.size != E or self.update_start.size != E + 1
                or self.update_probability.size != U):
            raise StrategyError("the rule arrays have inconsistent lengths")
        for start, total, what in ((self.choice_start, E, "rule"),
                                   (self.update_start, U, "played action")):
            if start[0] != 0 or start[-1] != total or np.any(np.diff(start) < 1):
                raise StrategyError(f"every {what} needs at least one entry (starts must increase "
                                    "from 0 to the number of entries)")
        if R and (np.any((self.rule_memory < 0) | (self.rule_memory >= k))
                  or np.any((self.rule_observation < 0) | (self.rule_observation >= Z))):
            raise StrategyError("a rule's memory node or observation is out of range")
        if np.any((self.choice_action < 0) | (self.choice_action >= A)) or np.any(
            (self.update_node < 0) | (self.update_node >= k)
        ):
            raise StrategyError("an action or a next memory node is out of range")
        if R > 1 and np.any(np.diff(self._rule_keys()) <= 0):
            raise StrategyError("rules must be sorted by (memory, observation), each pair once")
        rule = _segment_ids(self.choice_start)
        entry = _segment_ids(self.update_start)
        if np.any((np.diff(self.choice_action) <= 0) & (np.diff(rule) == 0)) or np.any(
            (np.diff(self.update_node) <= 0) & (np.diff(entry) == 0)
        ):
            raise StrategyError("a rule names an action twice, or an update a node twice")
        for p in (self.choice_probability, self.update_probability):
            if not np.all(np.isfinite(p)) or np.any(p <= 0) \
                    or np.any(p > 1 + PROBABILITY_TOLERANCE):
                raise StrategyError("probabilities must be finite and in (0, 1]")
        sums = np.bincount(rule, weights=self.choice_probability, minlength=R)
        bad = np.abs(sums - 1.0) > PROBABILITY_TOLERANCE
        if np.any(bad):
            r = int(np.argmax(bad))
            raise StrategyError(
                f"the action distribution of memory {int(self.rule_memory[r])}, observation "
                f"{int(self.rule_observation[r])} sums to {float(sums[r])!r}, not 1"
            )
        usums = np.bincount(entry, weights=self.update_probability, minlength=E)
        bad = np.abs(usums - 1.0) > PROBABILITY_TOLERANCE
        if np.any(bad):
            e = int(np.argmax(bad))
            r = int(rule[e])
            raise StrategyError(
                f"the memory update of memory {int(self.rule_memory[r])}, observation "
                f"{int(self.rule_observation[r])}, action {self.actions[self.choice_action[e]]!r} "
                f"sums to {float(usums[e])!r}, not 1"
            )
        if self.rule_source is not None and (
            self.rule_source.shape != (R,) or self.rule_source.dtype != np.int64
        ):
            raise StrategyError("rule_source must be int64[R]")

    # -- construction -----------------------------------------------------------------------------

    @staticmethod
    def from_entries(
        *,
        player: str,
        memory_size: int,
        initial_memory: int,
        observables: tuple[str, ...],
        observation_values: np.ndarray,
        actions: tuple[str, ...],
        rule_memory: np.ndarray,
        rule_observation: np.ndarray,
        entry_rule: np.ndarray,
        entry_action: np.ndarray,
        entry_probability: np.ndarray,
        update_entry: np.ndarray,
        update_node: np.ndarray,
        update_probability: np.ndarray,
        boolean: tuple[bool, ...] = (),
        source: str | None = None,
        rule_source: np.ndarray | None = None,
    ) -> FiniteStateStrategy:
        """A strategy from its rules in any order: each played action names its rule
        (``entry_rule``), each memory update its played action (``update_entry``). Entries and
        updates of probability 0 are dropped (they say nothing); the rest is sorted into the
        layout of the module docstring.

        Raises:
            StrategyError: an invariant does not hold (see :meth:`validate`).
        """
        i64 = np.int64
        rule_memory = np.asarray(rule_memory, dtype=i64).reshape(-1)
        rule_observation = np.asarray(rule_observation, dtype=i64).reshape(-1)
        entry_rule = np.asarray(entry_rule, dtype=i64).reshape(-1)
        entry_action = np.asarray(entry_action, dtype=i64).reshape(-1)
        entry_probability = np.asarray(entry_probability, dtype=np.float64).reshape(-1)
        update_entry = np.asarray(update_entry, dtype=i64).reshape(-1)
        update_node = np.asarray(update_node, dtype=i64).reshape(-1)
        update_probability = np.asarray(update_probability, dtype=np.float64).reshape(-1)
        # rules sorted by (n, z)
        r_order = np.lexsort((rule_observation, rule_memory))
        r_rank = np.empty_like(r_order)
        r_rank[r_order] = np.arange(r_order.size)
        # entries: drop zeros, sort by (rule rank, action)
        kept = np.flatnonzero(entry_probability > 0)
        e_rule = r_rank[entry_rule[kept]]
        e_order = kept[np.lexsort((entry_action[kept], e_rule))]
        e_rank = np.full(entry_rule.size, -1, dtype=i64)
        e_rank[e_order] = np.arange(e_order.size)
        # updates: of kept entries only, non-zero, sorted by (entry rank, node)
        u_keep = np.flatnonzero((update_probability > 0) & (e_rank[update_entry] >= 0)) \
            if update_entry.size else np.zeros(0, dtype=i64)
        u_entry = e_rank[update_entry[u_keep]]
        u_order = u_keep[np.lexsort((update_node[u_keep], u_entry))]
        source_sorted = None if rule_source is None else \
            np.asarray(rule_source, dtype=i64).reshape(-1)[r_order]
        return FiniteStateStrategy(
            player=player,
            memory_size=memory_size,
            initial_memory=initial_memory,
            observables=tuple(observables),
            observation_values=np.asarray(observation_values, dtype=i64),
            actions=tuple(actions),
            rule_memory=rule_memory[r_order],
            rule_observation=rule_observation[r_order],
            choice_start=_starts(r_rank[entry_rule[e_order]], r_order.size),
            choice_action=entry_action[e_order],
            choice_probability=entry_probability[e_order],
            update_start=_starts(e_rank[update_entry[u_order]], e_order.size),
            update_node=update_node[u_order],
            update_probability=update_probability[u_order],
            boolean=boolean,
            source=source,
            rule_source=source_sorted,
        )

    @staticmethod
    def from_arrays(
        *,
        player: str,
        observables: tuple[str, ...],
        observation_values: Any,
        actions: tuple[str, ...],
        action: Any,
        update: Any = None,
        initial_memory: int = 0,
        boolean: tuple[bool, ...] = (),
    ) -> FiniteStateStrategy:
        """A strategy from dense arrays γ (float64[k, Z, A]) and δ (float64[k, Z, A, k]; None
        keeps the memory, δ(n, z, a) = n). The memory size is ``action.shape[0]``; an all-zero
        (n, z) row of γ means no rule. The given arrays are kept for :attr:`action` and
        :attr:`update`.

        Raises:
            StrategyError: the arrays have the wrong shapes or are not distributions.
        """
        action = np.asarray(action, dtype=np.float64)
        if action.ndim != 3:
            raise StrategyError(f"action must be a [k, Z, A] array, got shape {action.shape}")
        k, Z, A = action.shape
        values = np.asarray(observation_values, dtype=np.int64).reshape(Z, -1)
        if update is not None:
            update = np.asarray(update, dtype=np.float64)
            if update.shape != (k, Z, A, k):
                raise StrategyError(
                    f"action must have shape {(k, Z, A)} and update {(k, Z, A, k)}; got "
                    f"{action.shape} and {update.shape}"
                )
        if len(actions) != A:
            raise StrategyError(f"{len(actions)} action labels for {A} actions")
        if not (np.all(np.isfinite(action)) and np.all(action >= 0)) or (
            update is not None and not (np.all(np.isfinite(update)) and np.all(update >= 0))
        ):
            raise StrategyError("probabilities must be finite and non-negative")
        sums = action.sum(axis=2)
        bad = ~((sums == 0.0) | (np.abs(sums - 1.0) <= PROBABILITY_TOLERANCE))
        if np.any(bad):
            n, z = map(int, np.argwhere(bad)[0])
            raise StrategyError(f"the action distribution of memory {n}, observation {z} sums to "
                                f"{float(sums[n, z])!r}, not 1")
        ruled = np.argwhere(sums > 0)
        rule_of = np.full((k, Z), -1, dtype=np.int64)
        rule_of[ruled[:, 0], ruled[:, 1]] = np.arange(ruled.shape[0])
        en, ez, ea = np.nonzero(action > 0)
        if update is None:
            u_entry = np.arange(en.size, dtype=np.int64)
            u_node, u_prob = en, np.ones(en.size)
        else:
            rows = update[en, ez, ea]  # [E, k]
            usums = rows.sum(axis=1)
            bad_u = np.abs(usums - 1.0) > PROBABILITY_TOLERANCE
            if np.any(bad_u):
                e = int(np.argmax(bad_u))
                raise StrategyError(
                    f"the memory update of memory {int(en[e])}, observation {int(ez[e])}, action "
                    f"{actions[int(ea[e])]!r} sums to {float(usums[e])!r}, not 1"
                )
            u_entry, u_node = np.nonzero(rows > 0)
            u_prob = rows[u_entry, u_node]
        fss = FiniteStateStrategy.from_entries(
            player=player, memory_size=k, initial_memory=initial_memory,
            observables=tuple(observables), observation_values=values, actions=tuple(actions),
            rule_memory=ruled[:, 0], rule_observation=ruled[:, 1],
            entry_rule=rule_of[en, ez], entry_action=ea, entry_probability=action[en, ez, ea],
            update_entry=u_entry, update_node=u_node, update_probability=u_prob,
            boolean=boolean,
        )
        # kept as given (read-only from now on): the dense algorithms that made them read them back
        action.setflags(write=False)
        fss._dense["action"] = action
        if update is not None:
            update.setflags(write=False)
            fss._dense["update"] = update
        return fss
