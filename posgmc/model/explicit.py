"""The compiled game: one frozen array record for every model type (dtmc, mdp, pomdp, smg, posg).

This module needs nothing but numpy and scipy, so engines can be tested on hand-built models.
The layout follows Storm's sparse models and PRISM's explicit engine: the choices of all states
are the rows of one matrix, grouped by state.

Every array of the record is read-only (numpy's ``writeable`` flag is cleared at construction):
nothing mutates a compiled game, engines derive new arrays. :meth:`ExplicitModel.validate`
checks every invariant below; :func:`make_model` normalises and validates hand-built input.

Notation: ``S`` = ``num_states``, ``C`` = ``num_choices``, ``V`` = number of state variables.

==================  ===========================  ==================================================
field               shape, dtype                 invariant
==================  ===========================  ==================================================
model_type          ModelType                    dtmc: one choice per state
initial_states      int64[k], k >= 1             sorted, distinct, each in [0, S)
row_groups          int64[S + 1]                 row_groups[0] = 0, row_groups[S] = C, strictly
                                                 increasing (every state has >= 1 choice); the
                                                 choices of state s are rows
                                                 row_groups[s]:row_groups[s+1]
transitions         csr_matrix float64 [C, S]    every row sums to 1 (within 1e-9), entries > 0,
                                                 sorted column indices, no duplicates
choice_actions      int32[C]                     index into ``action_names``
action_names        tuple[str, ...]              action_names[0] == "" (unlabelled choice)
state_players       int32[S]                     games: index into ``player_names`` of the owner;
                                                 other types: all 0
player_names        tuple[str, ...]              games: declared players in order; else ()
observations        tuple[Observation, ...]      one per partially observing player (pomdp: the
                                                 single agent, player index 0)
labels              Mapping[str, bool[S]]        includes "init" and "deadlock"
reward_models       tuple[RewardModel, ...]      in declaration order
variable_names      tuple[str, ...]              length V
boolean_variables   frozenset[str]               the Boolean ones among variable_names
state_values        int64[S, V]                  the valuation of each state; bools as 0/1
deadlocks           int64[d]                     states that had no choice and got a self-loop
exact_probabilities object[nnz] or None          exact mode (PRISM's ``-exact``): the Fraction of
                                                 each entry of ``transitions.data``; every row
                                                 sums to exactly 1, and ``transitions`` holds
                                                 the nearest doubles
==================  ===========================  ==================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.sparse as sp

from posgmc.errors import PosgmcError
from posgmc.model.types import ModelType

__all__ = ["ExplicitModel", "Observation", "RewardModel", "ModelInvariantError"]


class ModelInvariantError(PosgmcError):
    """A hand-built or imported model violates an invariant of :class:`ExplicitModel`."""


def _freeze(*arrays: np.ndarray | None) -> None:
    """Make the arrays of a compiled model read-only: nothing mutates a model after assembly
    (engines derive new arrays), and numpy now enforces it."""
    for a in arrays:
        if a is not None:
            a.flags.writeable = False


@dataclass(frozen=True, eq=False)
class Observation:
    """What one player observes.

    ``player``: index into ``player_names`` (0 for a pomdp's agent).
    ``state_ids``: int32[S], the observation id of every state, in [0, num_observations).
    ``names``: the observables (one per column of ``values``).
    ``values``: int64[num_observations, len(names)], the observed values of each id.
    """

    player: int
    state_ids: np.ndarray
    names: tuple[str, ...]
    values: np.ndarray

    def __post_init__(self) -> None:
        _freeze(self.state_ids, self.values)

    @property
    def num_observations(self) -> int:
        return int(self.values.shape[0])


@dataclass(frozen=True, eq=False)
class RewardModel:
    """``state``: float64[S] or None; ``choice``: float64[C] or None (action rewards and, folded in,
    transition rewards). A reward model with both None is all zeros."""

    name: str | None
    state: np.ndarray | None = None
    choice: np.ndarray | None = None

    def __post_init__(self) -> None:
        _freeze(self.state, self.choice)

    def choice_rewards(self, row_groups: np.ndarray) -> np.ndarray:
        """Reward collected when choice c is taken in its state: state reward + action reward."""
        num_choices = int(row_groups[-1])
        total = np.zeros(num_choices)
        if self.state is not None:
            total += np.repeat(self.state, np.diff(row_groups))
        if self.choice is not None:
            total += self.choice
        return total


def _unpickled_model(values: dict[str, Any]) -> ExplicitModel:
    """The model pickled by :meth:`ExplicitModel.__reduce__`."""
    return ExplicitModel(**{**values, "labels": MappingProxyType(values["labels"])})


@dataclass(frozen=True, eq=False)
class ExplicitModel:
    """See the module docstring for every field's shape, dtype and invariant."""

    model_type: ModelType
    initial_states: np.ndarray
    row_groups: np.ndarray
    transitions: sp.csr_matrix
    choice_actions: np.ndarray
    action_names: tuple[str, ...]
    state_players: np.ndarray
    player_names: tuple[str, ...] = ()
    observations: tuple[Observation, ...] = ()
    labels: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    reward_models: tuple[RewardModel, ...] = ()
    variable_names: tuple[str, ...] = ()
    state_values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.int64))
    deadlocks: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    boolean_variables: frozenset[str] = frozenset()
    exact_probabilities: np.ndarray | None = None

    def __post_init__(self) -> None:
        T = self.transitions
        _freeze(
            self.initial_states, self.row_groups, T.data, T.indices, T.indptr,
            self.choice_actions, self.state_players, self.state_values, self.deadlocks,
            self.exact_probabilities, *self.labels.values(),
        )

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled by its fields, the labels as a plain dict (a read-only mapping view does not
        pickle; derived arrays cached on the model are recomputed where it is unpickled): how a
        built model reaches a worker on another machine (:mod:`posgmc.synthesis.ray_pool`)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values["labels"] = dict(self.labels)
        return (_unpickled_model, (values,))

    # -- sizes, counted as Storm counts them ----------------------------------------------------

    @property
    def num_states(self) -> int:
        return int(self.row_groups.shape[0] - 1)

    @property
    def num_choices(self) -> int:
        return int(self.row_groups[-1])

    @property
    def num_transitions(self) -> int:
        return int(self.transitions.nnz)

    @property
    def choice_states(self) -> np.ndarray:
        """int64[C]: the state each choice belongs to."""
        return np.repeat(np.arange(self.num_states, dtype=np.int64), np.diff(self.row_groups))

    def label(self, name: str) -> np.ndarray:
        try:
            return self.labels[name]
        except KeyError:
            raise PosgmcError(f'the model has no label "{name}"') from None

    def reward_model(self, name: str | int | None) -> RewardModel:
        """By name, by 1-based index, or the first one for None."""
        if not self.reward_models:
            raise PosgmcError("the model has no reward structure")
        if name is None:
            return self.reward_models[0]
        if isinstance(name, int):
            if not 1 <= name <= len(self.reward_models):
                raise PosgmcError(f"the model has no reward structure number {name}")
            return self.reward_models[name - 1]
        for rm in self.reward_models:
            if rm.name == name:
                return rm
        raise PosgmcError(f'the model has no reward structure "{name}"')

    def describe_state(self, s: int) -> str:
        """State ``s`` as PRISM prints it, ``(x=1, b=true)``, or its number without variables."""
        if not self.variable_names:
            return f"state {s}"
        row = self.state_values[s].tolist()
        parts = [
            f"{n}={'true' if v else 'false'}" if n in self.boolean_variables else f"{n}={v}"
            for n, v in zip(self.variable_names, row)
        ]
        return "(" + ", ".join(parts) + ")"

    def observation_of(self, player: int) -> Observation | None:
        """The observation function of ``player``, or None if that player sees the whole state."""
        for obs in self.observations:
            if obs.player == player:
                return obs
        return None

    def statistics(self) -> dict[str, Any]:
        """Sizes for reports (``posgmc build``)."""
        stats: dict[str, Any] = {
            "type": self.model_type.value,
            "states": self.num_states,
            "choices": self.num_choices,
            "transitions": self.num_transitions,
            "initial_states": int(self.initial_states.size),
            "deadlocks": int(self.deadlocks.size),
            "labels": sorted(self.labels),
            "reward_models": [rm.name for rm in self.reward_models],
        }
        if self.player_names:
            counts = np.bincount(self.state_players, minlength=len(self.player_names))
            stats["players"] = {n: int(c) for n, c in zip(self.player_names, counts)}
        if self.observations:
            names = self.player_names or ("agent",)
            stats["observations"] = {names[o.player]: o.num_observations for o in self.observations}
        return stats

    # -- validation ----------------------------------------------------------------------------

    def _validate_exact(self) -> None:
        exact = self.exact_probabilities
        assert exact is not None  # noqa: S101 - the caller checked
        T = self.transitions
        if exact.shape != (T.nnz,):
            raise ModelInvariantError("exact_probabilities needs one entry per transition")
        # np.add.reduceat adds the Fractions of each row exactly (object dtype); every row of a
        # model that passed the float checks has at least one entry.
        sums = np.add.reduceat(exact, T.indptr[:-1]) if T.nnz else exact
        bad = np.flatnonzero(sums != 1)
        if bad.size:
            raise ModelInvariantError(
                f"choice {int(bad[0])} has exact probabilities not summing to 1"
            )

    def validate(self, *, tolerance: float = 1e-9) -> ExplicitModel:
        """Check every invariant of the module docstring; raise :class:`ModelInvariantError`."""
        S = self.num_states
        rg = self.row_groups
        if S < 1:
            raise ModelInvariantError("a model needs at least one state")
        if not self.boolean_variables <= set(self.variable_names):
            raise ModelInvariantError("boolean_variables must be among variable_names")
        if rg[0] != 0 or np.any(np.diff(rg) < 1):
            raise ModelInvariantError("row_groups must start at 0 and give every state >= 1 choice")
        C = self.num_choices
        self._validate_transitions(C, S, tolerance)
        init = self.initial_states
        if init.size < 1 or init.min() < 0 or init.max() >= S:
            raise ModelInvariantError("initial states must be non-empty and within [0, num_states)")
        if np.any(np.diff(init) <= 0):
            raise ModelInvariantError("initial states must be sorted and distinct")
        if self.choice_actions.shape != (C,):
            raise ModelInvariantError("choice_actions must have one entry per choice")
        if not self.action_names or self.action_names[0] != "":
            raise ModelInvariantError('action_names[0] must be "" (the unlabelled choice)')
        if C and (
            self.choice_actions.min() < 0 or self.choice_actions.max() >= len(self.action_names)
        ):
            raise ModelInvariantError("choice_actions must index action_names")
        if self.deadlocks.size and (self.deadlocks.min() < 0 or self.deadlocks.max() >= S):
            raise ModelInvariantError("deadlock states must be within [0, num_states)")
        if self.state_values.shape != (S, len(self.variable_names)):
            raise ModelInvariantError(
                f"state_values has shape {self.state_values.shape}, "
                f"expected {(S, len(self.variable_names))}"
            )
        if self.state_players.shape != (S,):
            raise ModelInvariantError("state_players must have one entry per state")
        if self.model_type is ModelType.DTMC and C != S:
            raise ModelInvariantError("a dtmc has exactly one choice per state")
        if self.model_type.is_game and self.player_names:
            if self.state_players.min() < 0 or self.state_players.max() >= len(self.player_names):
                raise ModelInvariantError("state_players must index player_names")
        self._validate_observations(S)
        self._validate_labels(S)
        if self.exact_probabilities is not None:
            self._validate_exact()
        for rm in self.reward_models:
            if rm.state is not None and rm.state.shape != (S,):
                raise ModelInvariantError(
                    f"reward model {rm.name!r}: state rewards need shape ({S},)"
                )
            if rm.choice is not None and rm.choice.shape != (C,):
                raise ModelInvariantError(
                    f"reward model {rm.name!r}: choice rewards need shape ({C},)"
                )
        self._validate_dtypes()
        return self

    def _validate_dtypes(self) -> None:
        expected: list[tuple[str, np.ndarray | None, type]] = [
            ("initial_states", self.initial_states, np.int64),
            ("row_groups", self.row_groups, np.int64),
            ("transitions.data", self.transitions.data, np.float64),
            ("choice_actions", self.choice_actions, np.int32),
            ("state_players", self.state_players, np.int32),
            ("state_values", self.state_values, np.int64),
            ("deadlocks", self.deadlocks, np.int64),
        ]
        for obs in self.observations:
            expected += [("observation state_ids", obs.state_ids, np.int32),
                         ("observation values", obs.values, np.int64)]
        for rm in self.reward_models:
            expected += [(f"reward model {rm.name!r} state", rm.state, np.float64),
                         (f"reward model {rm.name!r} choice", rm.choice, np.float64)]
        for what, array, dtype in expected:
            if array is not None and array.dtype != dtype:
                raise ModelInvariantError(
                    f"{what} has dtype {array.dtype}, expected {np.dtype(dtype).name}"
                )

    def _validate_transitions(self, C: int, S: int, tolerance: float) -> None:
        T = self.transitions
        if T.shape != (C, S):
            raise ModelInvariantError(f"transitions has shape {T.shape}, expected {(C, S)}")
        sums = np.asarray(T.sum(axis=1)).ravel()
        bad = np.flatnonzero(np.abs(sums - 1.0) > tolerance)
        if bad.size:
            raise ModelInvariantError(
                f"choice {int(bad[0])} has probabilities summing to {sums[bad[0]]}"
            )
        if T.nnz and T.data.min() <= 0:
            raise ModelInvariantError("transition probabilities must be positive")
        # Within a row, column indices strictly increase (sorted, no duplicates); a decrease or
        # repeat is allowed only where a new row starts.
        steps = np.diff(T.indices.astype(np.int64))
        row_start = np.zeros(steps.size, dtype=bool)
        starts = T.indptr[1:-1]
        row_start[starts[(starts > 0) & (starts <= steps.size)] - 1] = True
        bad = np.flatnonzero((steps <= 0) & ~row_start)
        if bad.size:
            row = int(np.searchsorted(T.indptr, bad[0], side="right") - 1)
            raise ModelInvariantError(
                f"choice {row} has unsorted or repeated column indices in transitions"
            )

    def _validate_observations(self, S: int) -> None:
        players = len(self.player_names) if self.player_names else 1
        for obs in self.observations:
            if not 0 <= obs.player < players:
                raise ModelInvariantError(
                    f"an observation names player {obs.player}, which does not exist"
                )
            if obs.state_ids.shape != (S,):
                raise ModelInvariantError("an observation needs one id per state")
            if obs.values.ndim != 2 or obs.values.shape[1] != len(obs.names):
                raise ModelInvariantError(
                    f"observation values have shape {obs.values.shape}, expected one column per "
                    f"observable ({len(obs.names)})"
                )
            if obs.state_ids.min() < 0 or obs.state_ids.max() >= obs.num_observations:
                raise ModelInvariantError("observation ids must lie in [0, num_observations)")

    def _validate_labels(self, S: int) -> None:
        for name, lab in self.labels.items():
            if lab.shape != (S,) or lab.dtype != np.bool_:
                raise ModelInvariantError(f'label "{name}" must be bool[num_states]')
        for name in ("init", "deadlock"):
            if name not in self.labels:
                raise ModelInvariantError(f'the label "{name}" is missing')


def make_model(
    model_type: ModelType,
    row_groups: Any,
    transitions: Any,
    *,
    initial_states: Any = (0,),
    choice_actions: Any | None = None,
    action_names: tuple[str, ...] = ("",),
    state_players: Any | None = None,
    player_names: tuple[str, ...] = (),
    observations: tuple[Observation, ...] = (),
    labels: Mapping[str, Any] | None = None,
    reward_models: tuple[RewardModel, ...] = (),
    variable_names: tuple[str, ...] = (),
    state_values: Any | None = None,
    deadlocks: Any | None = None,
    boolean_variables: frozenset[str] = frozenset(),
) -> ExplicitModel:
    """The validating constructor for hand-built models (tests, imports).

    ``transitions`` may be a dense array-like or any scipy sparse matrix of shape [C, S].
    Labels "init" and "deadlock" are added when missing.
    """
    rg = np.asarray(row_groups, dtype=np.int64)
    S = rg.size - 1
    T = sp.csr_matrix(transitions, dtype=np.float64, copy=True)
    T.sum_duplicates()
    T.eliminate_zeros()
    T.sort_indices()
    C = int(rg[-1])
    init = np.unique(np.asarray(initial_states, dtype=np.int64))
    if S < 1:
        raise ModelInvariantError("a model needs at least one state")
    if init.size < 1 or init.min() < 0 or init.max() >= S:
        raise ModelInvariantError("initial states must be non-empty and within [0, num_states)")
    labs = {k: np.asarray(v, dtype=bool) for k, v in (labels or {}).items()}
    if "init" not in labs:
        lab = np.zeros(S, dtype=bool)
        lab[init] = True
        labs["init"] = lab
    dl = np.zeros(0, dtype=np.int64) if deadlocks is None else np.asarray(deadlocks, dtype=np.int64)
    if dl.size and (dl.min() < 0 or dl.max() >= S):
        raise ModelInvariantError("deadlock states must be within [0, num_states)")
    if "deadlock" not in labs:
        lab = np.zeros(S, dtype=bool)
        lab[dl] = True
        labs["deadlock"] = lab
    model = ExplicitModel(
        model_type=model_type,
        initial_states=init,
        row_groups=rg,
        transitions=T,
        choice_actions=(
            np.zeros(C, dtype=np.int32)
            if choice_actions is None
            else np.asarray(choice_actions, dtype=np.int32)
        ),
        action_names=action_names,
        state_players=(
            np.zeros(S, dtype=np.int32)
            if state_players is None
            else np.asarray(state_players, dtype=np.int32)
        ),
        player_names=player_names,
        observations=observations,
        labels=MappingProxyType(labs),
        reward_models=reward_models,
        variable_names=variable_names,
        state_values=(
            np.zeros((S, 0), dtype=np.int64)
            if state_values is None
            else np.asarray(state_values, dtype=np.int64)
        ),
        deadlocks=dl,
        boolean_variables=frozenset(boolean_variables),
    )
    return model.validate()
