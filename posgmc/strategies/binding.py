"""A finite-state strategy meets a compiled model: observations and actions in the model's numbers.

:func:`player_view` says how one player of an :class:`ExplicitModel` sees it (its observation id
of every state, and what each id means); :func:`bind` checks a :class:`FiniteStateStrategy`
against that view and returns a :class:`BoundStrategy` whose lookups are whole-array operations:
the probability γ(n, z(s), a(c)) of every (memory, choice) pair and the update rows δ.

What binding checks (each a :class:`StrategyError` naming the file and JSON path):

* the strategy's player is a player of the model, and its observables are that player's;
* every action label the strategy plays is a label of the model and is enabled under the rule's
  observation (states a player cannot tell apart offer it the same labels; the PRISM compiler
  checks that, and binding checks it again for DRN input);
* no state of the player offers two choices with one label (a strategy names actions by label;
  :func:`posgmc.api.build` names such choices by their local index, ``#0``, ``#1``, ..., with
  :func:`posgmc.model.actions.choices_by_index`).

Rules for observations the model never produces are not errors; they are returned as warnings.
Whether every (memory, observation) pair *reached* under the strategy has a rule is a question of
the product (:mod:`posgmc.strategies.product`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar
from weakref import WeakKeyDictionary

import numpy as np

from posgmc.errors import InputError
from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError

__all__ = [
    "PlayerView",
    "BoundStrategy",
    "player_view",
    "player_index",
    "bind",
    "memoryless_strategy",
]


@dataclass(frozen=True, eq=False)
class PlayerView:
    """How player ``player`` sees a model.

    ``state_obs``: int64[S], the player's observation id of every state; ``obs_values``:
    int64[Zm, max(d, 1)], what id z means (the observables' values; for observations without
    observables — DRN — the id itself); ``observables``: the d observable names (a player that
    observes everything sees every state variable; without variables, the state's number).
    """

    player: int
    name: str
    observables: tuple[str, ...]
    state_obs: np.ndarray
    obs_values: np.ndarray

    @property
    def who(self) -> str:
        """The player as messages name it (a POMDP's single agent has no name)."""
        return f"player {self.name!r}" if self.name else "the agent"

    @property
    def num_observations(self) -> int:
        return int(self.obs_values.shape[0])

    def describe(self, z: int) -> str:
        row = self.obs_values[z].tolist()
        if not self.observables:
            return f"observation {row[0]}"
        return "{" + ", ".join(f"{n}={v}" for n, v in zip(self.observables, row)) + "}"


def player_index(model: ExplicitModel, name: str) -> int:
    """The index of the player called ``name``; a model without players has one agent, ``""``.

    Raises:
        StrategyError: no such player.
    """
    if not model.player_names:
        if name in ("", None):
            return 0
        raise StrategyError(
            f"the model ({model.model_type.value}) has no players; its single agent is named \"\"",
            path="player",
            hint='write "player": "" in the strategy file',
        )
    if name not in model.player_names:
        raise StrategyError(
            f"the model has no player {name!r} (players: {', '.join(model.player_names)})",
            path="player",
        )
    return model.player_names.index(name)


def player_view(model: ExplicitModel, player: int) -> PlayerView:
    """The observation function of ``player`` (the whole state for a fully observing player)."""
    name = model.player_names[player] if model.player_names else ""
    obs = model.observation_of(player)
    if obs is not None:
        values = (
            obs.values if obs.names else np.arange(obs.num_observations, dtype=np.int64)[:, None]
        )
        return PlayerView(player, name, obs.names, obs.state_ids.astype(np.int64),
                          np.asarray(values, dtype=np.int64))
    S = model.num_states
    if model.variable_names:
        return PlayerView(player, name, model.variable_names, np.arange(S, dtype=np.int64),
                          np.asarray(model.state_values, dtype=np.int64))
    return PlayerView(player, name, (), np.arange(S, dtype=np.int64),
                      np.arange(S, dtype=np.int64)[:, None])


@dataclass(frozen=True, eq=False)
class BoundStrategy:
    """A strategy matched to a model.

    ``obs_map``: int64[Zm], the strategy's observation index of each model observation id (-1:
    the strategy has no rule for it); ``action_map``: int64[len(model.action_names)], the
    strategy's action index of each model action (-1: the strategy never plays it); ``owned``:
    bool[S], the player's states; ``warnings``: rules for observations the model never produces.
    """

    fss: FiniteStateStrategy
    view: PlayerView
    obs_map: np.ndarray
    action_map: np.ndarray
    owned: np.ndarray
    warnings: tuple[str, ...] = ()

    @property
    def player(self) -> int:
        return self.view.player

    @property
    def memory_size(self) -> int:
        return self.fss.memory_size

    def strategy_observation(self, states: np.ndarray) -> np.ndarray:
        """int64[...]: the strategy's observation index of each state (-1: no rule there)."""
        return np.asarray(self.obs_map[self.view.state_obs[states]])

    def entries(self, model: ExplicitModel, memory: np.ndarray, choices: np.ndarray) -> np.ndarray:
        """int64[...]: the strategy's played-action entry for pairs of memory nodes and (global)
        choice indices of its states; -1 where it has no rule or does not play the choice."""
        states = model.choice_states[choices]
        z = self.strategy_observation(states)
        a = self.action_map[model.choice_actions[choices]]
        return self.fss.entry_at(memory, z, a)

    def action_probability(self, model: ExplicitModel, memory: np.ndarray,
                           choices: np.ndarray) -> np.ndarray:
        """γ(n, z(s), a(c)) for pairs of memory nodes and (global) choice indices of its states."""
        e = self.entries(model, memory, choices)
        return np.where(e >= 0, self.fss.choice_probability[np.maximum(e, 0)], 0.0) \
            if self.fss.choice_probability.size else np.zeros(np.shape(e))

    def update_rows(self, model: ExplicitModel, memory: np.ndarray,
                    choices: np.ndarray) -> np.ndarray:
        """float64[..., k]: δ(n, z(s), a(c)) for pairs of memory nodes and choices (rows of zeros
        where the strategy has no rule or never plays the choice's action). Dense in k: for a few
        pairs (simulation); products use :meth:`entries` and the strategy's update lists."""
        e = self.entries(model, memory, choices)
        out = np.zeros(np.shape(e) + (self.memory_size,))
        flat = out.reshape(-1, self.memory_size)
        pair = np.flatnonzero(e.reshape(-1) >= 0)
        ee = e.reshape(-1)[pair]
        start, stop = self.fss.update_start[ee], self.fss.update_start[ee + 1]
        counts = stop - start
        u = np.repeat(start - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))
        flat[np.repeat(pair, counts), self.fss.update_node[u]] = self.fss.update_probability[u]
        return out

    def update_distribution(self, model: ExplicitModel, memory: int, choice: int
                            ) -> tuple[np.ndarray, np.ndarray]:
        """The next memory nodes and their probabilities δ(n, z(s), a(c)) for one memory node and
        choice (both empty where the strategy has no rule or never plays the choice)."""
        e = int(self.entries(model, np.array([memory]), np.array([choice]))[0])
        if e < 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        lo, hi = int(self.fss.update_start[e]), int(self.fss.update_start[e + 1])
        return self.fss.update_node[lo:hi], self.fss.update_probability[lo:hi]

    def missing_rule(self, memory: np.ndarray, states: np.ndarray) -> np.ndarray:
        """bool[...]: the strategy has no rule for (n, z(s))."""
        return np.asarray(self.fss.rule_of(memory, self.strategy_observation(states)) < 0)


_SHOWN_WARNINGS = 3
"""How many rules for unseen observations are named one by one before the rest are counted."""


def _rule_where(fss: FiniteStateStrategy, r: int, tail: str = "") -> str | None:
    """The JSON path of rule r (plus ``tail``), if the strategy was read from a file."""
    if fss.rule_source is None or fss.rule_source[r] < 0:
        return None
    return f"rules[{int(fss.rule_source[r])}]{tail}"


def _unseen_warnings(fss: FiniteStateStrategy, who: str, produced: np.ndarray
                     ) -> tuple[str, ...]:
    """Warnings for the rules about observations the model never shows the player: the first
    few by name, then how many more (linear in the rules)."""
    unseen = np.flatnonzero(~produced[fss.rule_observation])
    if not unseen.size:
        return ()
    if fss.rule_source is not None:  # in the order of the file
        unseen = unseen[np.argsort(fss.rule_source[unseen], kind="stable")]
    file = fss.source or "strategy"
    out = [
        f"{file}: {_rule_where(fss, r) or ''}: the model never shows {who} the "
        f"observation {fss.describe_observation(int(fss.rule_observation[r]))}"
        for r in unseen[:_SHOWN_WARNINGS].tolist()
    ]
    if unseen.size > _SHOWN_WARNINGS:
        out.append(
            f"{file}: {unseen.size - _SHOWN_WARNINGS} more rules ({unseen.size} in all) are for "
            f"observations the model never shows {who}"
        )
    return tuple(out)


_T = TypeVar("_T")

_FACTS: WeakKeyDictionary[ExplicitModel, dict[object, object]] = WeakKeyDictionary()
"""What binding learns about a model and keeps while the model lives: per player the labels each
observation offers (checked once), and the matching of a strategy's observation list to the
model's ids (a search binds thousands of strategies over the same observations; the matching is a
sort of the model's observation values, the dominant cost of binding on a large model)."""

_KEPT_MATCHINGS = 64
"""Observation matchings kept per model (the oldest dropped first)."""


def _remembered(model: ExplicitModel, key: object, make: Callable[[], _T]) -> _T:
    facts = _FACTS.get(model)
    if facts is None:
        facts = _FACTS[model] = {}
    if key not in facts:
        if len(facts) >= _KEPT_MATCHINGS:
            del facts[next(iter(facts))]
        facts[key] = make()
    return facts[key]  # type: ignore[return-value]


def _owned(model: ExplicitModel, p: int) -> tuple[np.ndarray, np.ndarray]:
    """(bool[S] the states of player ``p``, the observation ids of those states)."""
    return _remembered(model, ("owned", p), lambda: _find_owned(model, p))


def _find_owned(model: ExplicitModel, p: int) -> tuple[np.ndarray, np.ndarray]:
    owned = (model.state_players == p) if model.player_names else np.ones(model.num_states, bool)
    owned_obs = np.unique(player_view(model, p).state_obs[owned])
    for a in (owned, owned_obs):
        a.setflags(write=False)
    return owned, owned_obs


def _offered(model: ExplicitModel, p: int) -> np.ndarray:
    """bool[Zm, A]: the labels each observation of player ``p`` offers, once the model is
    checked to be fit for observation-based strategies (each label once per state, one label set
    per observation).

    Raises:
        InputError: a state offers two choices with one label, or states of one observation
            offer different labels.
    """
    return _remembered(model, ("offered", p), lambda: _check_offered(model, p))


def _check_offered(model: ExplicitModel, p: int) -> np.ndarray:
    view = player_view(model, p)
    Zm = view.num_observations
    owned, _ = _owned(model, p)
    rows = np.flatnonzero(owned[model.choice_states])
    acts = model.choice_actions[rows]
    states = model.choice_states[rows]
    A = len(model.action_names)
    pair = states * A + acts
    uniq, counts = np.unique(pair, return_counts=True)
    if np.any(counts > 1):
        s, a = divmod(int(uniq[np.argmax(counts > 1)]), A)
        raise InputError(
            f"{_state_text(model, s)} of {view.who} offers two choices labelled "
            f"{model.action_names[a]!r}; a strategy names actions by label",
            hint="give each command of the player's states a distinct action label (api.build "
            "names such choices by their local index, #0, #1, ...)",
        )
    offered = np.zeros((Zm, A), dtype=bool)
    offered[view.state_obs[states], acts] = True
    count_states = np.bincount(view.state_obs[owned], minlength=Zm)
    count_pairs = np.zeros((Zm, A), dtype=np.int64)
    np.add.at(count_pairs, (view.state_obs[states], acts), 1)
    disagree = offered & (count_pairs != count_states[:, None])
    if np.any(disagree):
        z, a = map(int, np.argwhere(disagree)[0])
        raise InputError(
            f"states of {view.who} with the observation {view.describe(z)} offer "
            f"different actions: {model.action_names[a]!r} is enabled in some of them only",
            hint="states a player cannot tell apart must offer it the same action labels",
        )
    offered.setflags(write=False)
    return offered


def _matched_observations(model: ExplicitModel, p: int, fss: FiniteStateStrategy
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(obs_map int64[Zm]: the strategy's index of each model observation id, -1 where it has
    no rule; model_of int64[Zs]: the model's id of each strategy observation, -1 where the model
    has none; produced bool[Zs]: whether the model shows it to the player in one of its states)."""
    values = np.ascontiguousarray(fss.observation_values, dtype=np.int64)
    key = ("observations", p, values.shape, values.tobytes())
    return _remembered(model, key, lambda: _match_observations(model, p, values))


def _match_observations(model: ExplicitModel, p: int, fss_values: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    view = player_view(model, p)
    _, owned_obs = _owned(model, p)
    Zm, Zs = view.num_observations, fss_values.shape[0]
    both = np.vstack([view.obs_values, fss_values])
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    key_model, key_fss = inverse[:Zm], inverse[Zm:]
    lookup = np.full(int(inverse.max(initial=-1)) + 1, -1, dtype=np.int64)
    lookup[key_fss] = np.arange(Zs)
    obs_map = lookup[key_model]
    model_of = np.full(Zs, -1, dtype=np.int64)  # the model's id of each strategy observation
    model_of[obs_map[obs_map >= 0]] = np.flatnonzero(obs_map >= 0)
    produced = np.zeros(Zs, dtype=bool)
    produced[obs_map[owned_obs][obs_map[owned_obs] >= 0]] = True
    for a in (obs_map, model_of, produced):
        a.setflags(write=False)
    return obs_map, model_of, produced


def bind(model: ExplicitModel, fss: FiniteStateStrategy) -> BoundStrategy:
    """Match ``fss`` to ``model``.

    Raises:
        StrategyError: the strategy does not fit the model (see the module docstring).
        InputError: states of the player with one observation offer different actions, or one
            state offers two choices with the same label.
    """
    file = fss.source
    try:
        p = player_index(model, fss.player)
    except StrategyError as e:
        raise StrategyError(
            e.message.split(": ", 1)[-1], path="player", file=file, hint=e.hint
        ) from None
    view = player_view(model, p)
    if fss.observables != view.observables:
        raise StrategyError(
            f"the observables {list(fss.observables)} are not those of {view.who}: "
            f"{list(view.observables)}",
            path="observables",
            file=file,
            hint="list the player's observables in declaration order (all state variables for a "
            "player that observes everything; [] for a model read from DRN)",
        )
    owned, _ = _owned(model, p)

    # -- observations: the strategy's rows matched to the model's ids (one sort, no dict) -------
    obs_map, model_of, produced = _matched_observations(model, p, fss)
    warnings = _unseen_warnings(fss, view.who, produced)

    # -- actions ---------------------------------------------------------------------------------
    names = {a: i for i, a in enumerate(model.action_names)}
    action_map = np.full(len(model.action_names), -1, dtype=np.int64)
    label_model = np.array([names.get(label, -1) for label in fss.actions], dtype=np.int64)
    action_map[label_model[label_model >= 0]] = np.flatnonzero(label_model >= 0)
    entry_rule = np.repeat(np.arange(fss.num_rules), np.diff(fss.choice_start))
    unknown = np.flatnonzero(label_model[fss.choice_action] < 0) if fss.num_actions else \
        np.zeros(0, dtype=np.int64)
    if unknown.size:
        first = int(unknown[0])
        r, label = int(entry_rule[first]), fss.actions[int(fss.choice_action[first])]
        raise StrategyError(
            f"the model has no action labelled {label!r}",
            path=_rule_where(fss, r, f".action.{label}"),
            file=file,
            hint="actions are named by their label, e.g. [fwd] in the model is \"fwd\"",
        )

    # -- the labels each observation offers (states of one observation must agree) -------------
    offered = _offered(model, p)
    # every played label must be offered under the rule's observation (one test per entry)
    z_entry = fss.rule_observation[entry_rule]
    bad = produced[z_entry]
    bad[bad] = ~offered[model_of[z_entry[bad]], label_model[fss.choice_action[bad]]]
    if np.any(bad):
        first = int(np.argmax(bad))
        r, j, z = int(entry_rule[first]), int(fss.choice_action[first]), int(z_entry[first])
        enabled = [model.action_names[a] for a in np.flatnonzero(offered[model_of[z]])]
        raise StrategyError(
            f"action {fss.actions[j]!r} is not enabled under the observation "
            f"{fss.describe_observation(z)} (enabled: {', '.join(map(repr, enabled)) or 'none'})",
            path=_rule_where(fss, r, f".action.{fss.actions[j]}"),
            file=file,
        )
    return BoundStrategy(fss, view, obs_map, action_map, owned, warnings)


def _state_text(model: ExplicitModel, s: int) -> str:
    """``state 3`` or ``the state (x=1, y=2)``."""
    text = model.describe_state(s)
    return text if text.startswith("state ") else f"the state {text}"


def memoryless_strategy(
    model: ExplicitModel, player: int, choices: np.ndarray
) -> FiniteStateStrategy:
    """The memoryless deterministic strategy that plays the given choice in each state of
    ``player``, as an FSS over the player's observations.

    Args:
        model: the model.
        player: the player's index.
        choices: int64[S], a global choice index per state (-1 where no decision matters: the
            state's first choice is played); only the player's states are read.

    Raises:
        StrategyError: two states the player cannot tell apart get choices with different labels
            (the choice is then not observation-based).
    """
    view = player_view(model, player)
    owned = (
        (model.state_players == player) if model.player_names else np.ones(model.num_states, bool)
    )
    states = np.flatnonzero(owned & (choices >= 0))
    acts = model.choice_actions[choices[states]]
    z = view.state_obs[states]
    zs, first = np.unique(z, return_index=True)
    chosen = np.full(view.num_observations, -1, dtype=np.int64)
    chosen[zs] = acts[first]
    if np.any(chosen[z] != acts):
        s = int(states[np.argmax(chosen[z] != acts)])
        raise StrategyError(
            f"the choices are not observation-based: {_state_text(model, s)} and another "
            f"state with the observation {view.describe(int(view.state_obs[s]))} play different "
            "actions"
        )
    # where no decision matters (-1), the observation's first state plays its first choice
    rest = np.flatnonzero(owned & (choices < 0))
    rest = rest[chosen[view.state_obs[rest]] < 0]
    zr, first_r = np.unique(view.state_obs[rest], return_index=True)
    chosen[zr] = model.choice_actions[model.row_groups[rest[first_r]]]
    zs = np.flatnonzero(chosen >= 0)
    acts = chosen[zs]
    used_actions = np.unique(acts)
    a_index = np.full(len(model.action_names), -1, dtype=np.int64)
    a_index[used_actions] = np.arange(used_actions.size)
    gamma = np.zeros((1, zs.size, used_actions.size))
    gamma[0, np.arange(zs.size), a_index[acts]] = 1.0
    return FiniteStateStrategy.from_arrays(
        player=view.name,
        observables=view.observables,
        observation_values=view.obs_values[zs],
        actions=tuple(model.action_names[a] for a in used_actions.tolist()),
        action=gamma,
    )
