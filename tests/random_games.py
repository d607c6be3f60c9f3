"""Random small games for the tests: two-player POSGs drawn from one parametrised generator, and
POMDPs.

Player 0 sees one bit (observation 0 or 1; player 1's states show observation 2) and has its
labels per observation among "a", "b", "c"; player 1 (the adversary) sees the state and has "x"
and maybe "y"; absorbing states have the one label "x". Each family of games the tests use is a
:class:`GameShape`; the draws are made in a fixed order from one ``numpy`` generator, so a seed
pins a game (tests pin seeds, e.g. the MILP regression at seed 2827, and
``tests/test_random_games.py`` pins the games' fingerprints)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import strategies as st

from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.syntax.ast import ModelType

ACTION_NAMES = ("", "a", "b", "c", "x", "y")


@dataclass(frozen=True)
class GameShape:
    """One family of random games.

    ``states``: the range (numpy's ``integers(low, high)``) of the number of states drawn;
    ``with_sink``: an absorbing sink (owned by player 1) and the goal are added to those (else the
    goal is the last of them); ``first_is_player0``: state 0 belongs to player 0 (else its owner
    is drawn like the others'); ``labels``: the range of player 0's number of labels per
    observation; ``successors``: the range of a choice's number of successors; ``looping``: a
    choice's successors are drawn, half the time, among the non-absorbing states only (so end
    components avoiding goal and sink are common) and the first choice of state 0 reaches the
    sink; ``costs``: reward structure "c", 1-3 per choice outside the goal."""

    states: tuple[int, int]
    with_sink: bool
    first_is_player0: bool
    labels: tuple[int, int]
    successors: tuple[int, int]
    looping: bool = False
    costs: bool = False


REACHING = GameShape(states=(4, 9), with_sink=True, first_is_player0=True, labels=(2, 4),
                     successors=(1, 4))
"""4-8 states besides the goal and the sink; every choice moves to 1-3 random states, so values
are neither all 0 nor all 1 and both players matter."""

LOOPING = GameShape(states=(3, 6), with_sink=True, first_is_player0=True, labels=(2, 4),
                    successors=(1, 3), looping=True, costs=True)
"""3-5 states besides the goal and the sink, end components common, with costs."""

STRATEGY_GAMES = GameShape(states=(3, 8), with_sink=False, first_is_player0=False,
                           labels=(1, 4), successors=(1, 3))
"""3-7 states, the last the goal; player 0 may have one label only."""


def random_game(rng: np.random.Generator, shape: GameShape, *,
                full_observation: bool = False) -> ExplicitModel:
    """The next game of ``shape`` drawn from ``rng`` (``full_observation``: player 0 sees the
    state too, the same draws)."""
    return _drawn(rng, shape, full_observation)[0]


def _drawn(rng: np.random.Generator, shape: GameShape, full_observation: bool,
           ) -> tuple[ExplicitModel, dict[int, list[str]]]:
    """The next game of ``shape`` and player 0's labels per observation (drawn for both bits,
    whether or not a state shows it)."""
    S = int(rng.integers(*shape.states)) + (2 if shape.with_sink else 0)
    goal = S - 2 if shape.with_sink else S - 1
    absorbing = (goal, S - 1) if shape.with_sink else (goal,)
    owner = rng.integers(0, 2, size=S)
    if shape.first_is_player0:
        owner[0] = 0
    owner[list(absorbing)] = 1
    obs0 = rng.integers(0, 2, size=S)
    labels0 = {z: sorted(rng.choice(["a", "b", "c"], size=int(rng.integers(*shape.labels)),
                                    replace=False).tolist()) for z in (0, 1)}
    rows, actions, row_groups, cost = [], [], [0], []
    for s in range(S):
        if s in absorbing:
            acts = ["x"]
        elif owner[s] == 0:
            acts = labels0[int(obs0[s])]
        else:
            acts = ["x", "y"][: int(rng.integers(1, 3))]
        for a in acts:
            row = np.zeros(S)
            if s in absorbing:
                row[s] = 1.0
            else:
                succ = _successors(rng, shape, S, first=s == 0 and not actions)
                row[succ] = rng.random(succ.size) + 0.1
                row /= row.sum()
            rows.append(row)
            actions.append(ACTION_NAMES.index(a))
            if shape.costs:
                cost.append(0.0 if s == goal else float(rng.integers(1, 4)))
        row_groups.append(len(rows))
    ids = np.where(owner == 0, obs0, 2).astype(np.int32)
    observations = () if full_observation else (
        Observation(0, ids, ("o",), np.array([[0], [1], [2]])),)
    model = make_model(
        ModelType.POSG, row_groups, np.array(rows), choice_actions=actions,
        action_names=ACTION_NAMES, state_players=owner, player_names=("p0", "p1"),
        observations=observations, labels={"goal": np.arange(S) == goal},
        variable_names=("s",), state_values=np.arange(S)[:, None],
        reward_models=(RewardModel("c", choice=np.array(cost)),) if shape.costs else (),
    )
    return model, labels0


def _successors(rng: np.random.Generator, shape: GameShape, S: int, *,
                first: bool) -> np.ndarray:
    """A choice's successors (``first``: the first choice of state 0)."""
    if not shape.looping:
        return rng.choice(S, size=int(rng.integers(*shape.successors)), replace=False)
    pool = np.arange(S) if rng.random() < 0.5 else np.arange(S - 2)
    succ = rng.choice(pool, size=min(int(rng.integers(*shape.successors)), pool.size),
                      replace=False)
    if first:  # the adversary's sink is reachable, always
        succ = np.union1d(succ, [S - 1])
    return succ


def random_posg(seed: int) -> ExplicitModel:
    """The ``seed``-th game of :data:`REACHING`."""
    return random_game(np.random.default_rng(seed), REACHING)


def looping_posg(seed: int, *, full_observation: bool = False) -> ExplicitModel:
    """The ``seed``-th game of :data:`LOOPING`: end components avoiding goal and sink are
    common, reward structure "c" costs 1-3 per choice outside the goal (so ``Rmin`` is encoded by
    flows), and the adversary's sink is reachable from state 0 (a game without a reachable
    adversary state is not what the MILP tests are about)."""
    return random_game(np.random.default_rng(seed), LOOPING, full_observation=full_observation)


def game_with_strategies(rng: np.random.Generator,
                         ) -> tuple[ExplicitModel, FiniteStateStrategy, FiniteStateStrategy]:
    """The next game of :data:`STRATEGY_GAMES` and randomised finite-state strategies of both
    players, 1-2 memory nodes each, drawn after it: player 0's over its bit and the labels drawn
    for it, player 1's over the state."""
    model, labels0 = _drawn(rng, STRATEGY_GAMES, False)
    k0, k1 = int(rng.integers(1, 3)), int(rng.integers(1, 3))
    acts0 = ("a", "b", "c")
    g0 = np.zeros((k0, 2, 3))
    for z in (0, 1):
        cols = [acts0.index(a) for a in labels0[z]]
        g0[:, z, cols] = rng.random((k0, len(cols))) + 0.05
    g0 /= g0.sum(axis=2, keepdims=True)
    d0 = rng.random((k0, 2, 3, k0))
    d0 /= d0.sum(axis=3, keepdims=True)
    p0 = FiniteStateStrategy.from_arrays(player="p0", observables=("o",),
                                         observation_values=[[0], [1]], actions=acts0,
                                         action=g0, update=d0 * (g0[..., None] > 0))
    own1 = np.flatnonzero(model.state_players == 1)
    g1 = np.zeros((k1, own1.size, 2))
    for i, s in enumerate(own1.tolist()):
        n_acts = int(model.row_groups[s + 1] - model.row_groups[s])
        g1[:, i, :n_acts] = rng.random((k1, n_acts)) + 0.05
    g1 /= g1.sum(axis=2, keepdims=True)
    d1 = rng.random((k1, own1.size, 2, k1))
    d1 /= d1.sum(axis=3, keepdims=True)
    p1 = FiniteStateStrategy.from_arrays(player="p1", observables=("s",),
                                         observation_values=own1[:, None], actions=("x", "y"),
                                         action=g1, update=d1 * (g1[..., None] > 0))
    return model, p0, p1


@st.composite
def games(draw: st.DrawFn) -> tuple[ExplicitModel, FiniteStateStrategy, FiniteStateStrategy]:
    """Hypothesis: a game of :func:`game_with_strategies` from a drawn seed."""
    return game_with_strategies(np.random.default_rng(draw(st.integers(0, 2**32 - 1))))


def drawn_game(seed: int) -> tuple[ExplicitModel, FiniteStateStrategy, FiniteStateStrategy]:
    """The ``seed``-th game of :func:`games`, drawn reproducibly (no hypothesis database)."""
    from hypothesis import find, settings

    count = {"n": 0}

    def pick(_: object) -> bool:
        count["n"] += 1
        return count["n"] > seed

    return find(
        games(), pick, settings=settings(database=None, derandomize=True, max_examples=1000)
    )


def random_pomdp(seed: int) -> ExplicitModel:
    """A random POMDP: 4-8 states besides an absorbing goal and sink, two observations (goal and
    sink a third), 2-3 labels per observation, each choice to 1-3 random states."""
    rng = np.random.default_rng(seed)
    S = int(rng.integers(4, 9)) + 2
    goal, sink = S - 2, S - 1
    obs = rng.integers(0, 2, size=S)
    obs[[goal, sink]] = 2
    labels = {z: sorted(rng.choice(["a", "b", "c"], size=int(rng.integers(2, 4)),
                                   replace=False).tolist()) for z in (0, 1)}
    labels[2] = ["a"]
    names = ("", "a", "b", "c")
    rows, actions, row_groups = [], [], [0]
    for s in range(S):
        for a in labels[int(obs[s])]:
            row = np.zeros(S)
            if s in (goal, sink):
                row[s] = 1.0
            else:
                succ = rng.choice(S, size=int(rng.integers(1, 4)), replace=False)
                row[succ] = rng.random(succ.size) + 0.1
                row /= row.sum()
            rows.append(row)
            actions.append(names.index(a))
        row_groups.append(len(rows))
    return make_model(
        ModelType.POMDP, row_groups, np.array(rows), choice_actions=actions, action_names=names,
        observations=(Observation(0, obs.astype(np.int32), ("o",), np.array([[0], [1], [2]])),),
        labels={"goal": np.arange(S) == goal}, variable_names=("s",),
        state_values=np.arange(S)[:, None],
    )


def random_signed_pomdp(seed: int) -> ExplicitModel:
    """A random POMDP whose every choice stops with probability 1/10 (to an absorbing goal, as a
    discount of 0.9 written into the model) and pays a reward in [-1, 1] of either sign: 3-6
    states besides the goal, two observations (the goal a third), labels a and b everywhere,
    the continuing 9/10 spread over 1-3 random states. Every strategy reaches the goal almost
    surely, so ``R{"r"}max=? [ F "goal" ]`` is finite."""
    rng = np.random.default_rng(seed)
    S = int(rng.integers(3, 7)) + 1
    goal = S - 1
    obs = rng.integers(0, 2, size=S)
    obs[goal] = 2
    rows, actions, rewards, row_groups = [], [], [], [0]
    for s in range(S):
        for a in (1, 2):
            row = np.zeros(S)
            if s == goal:
                row[s] = 1.0
                rewards.append(0.0)
            else:
                succ = rng.choice(goal, size=int(rng.integers(1, 4)), replace=False)
                row[succ] = rng.random(succ.size) + 0.1
                row *= 0.9 / row.sum()
                row[goal] = 0.1
                rewards.append(float(np.round(rng.uniform(-1.0, 1.0), 2)))
            rows.append(row)
            actions.append(a)
        row_groups.append(len(rows))
    return make_model(
        ModelType.POMDP, row_groups, np.array(rows), choice_actions=actions,
        action_names=("", "a", "b"),
        observations=(Observation(0, obs.astype(np.int32), ("o",), np.array([[0], [1], [2]])),),
        labels={"goal": np.arange(S) == goal}, variable_names=("s",),
        state_values=np.arange(S)[:, None],
        reward_models=(RewardModel("r", choice=np.array(rewards)),),
    )
