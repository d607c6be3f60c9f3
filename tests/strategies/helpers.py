"""Random small POSGs with both players' finite-state strategies, shared by the strategy and
synthesis tests."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from posgmc.model.explicit import ExplicitModel, Observation, make_model
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.syntax.ast import ModelType


@st.composite
def games(draw: st.DrawFn) -> tuple[ExplicitModel, FiniteStateStrategy, FiniteStateStrategy]:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    S = int(rng.integers(3, 8))
    goal = S - 1
    owner = rng.integers(0, 2, size=S)
    owner[goal] = 1
    obs0 = rng.integers(0, 2, size=S)  # player 0 sees one bit
    labels0 = {
        0: sorted(
            rng.choice(["a", "b", "c"], size=int(rng.integers(1, 4)), replace=False).tolist()
        ),
        1: sorted(
            rng.choice(["a", "b", "c"], size=int(rng.integers(1, 4)), replace=False).tolist()
        ),
    }
    names = ("", "a", "b", "c", "x", "y")
    rows, actions, row_groups = [], [], [0]
    for s in range(S):
        if s == goal:
            acts = ["x"]
        elif owner[s] == 0:
            acts = labels0[int(obs0[s])]
        else:
            acts = ["x", "y"][: int(rng.integers(1, 3))]
        for a in acts:
            row = np.zeros(S)
            if s == goal:
                row[goal] = 1.0
            else:
                succ = rng.choice(S, size=int(rng.integers(1, 3)), replace=False)
                row[succ] = rng.random(succ.size) + 0.1
                row /= row.sum()
            rows.append(row)
            actions.append(names.index(a))
        row_groups.append(len(rows))
    ids = np.where(owner == 0, obs0, 2).astype(np.int32)
    model = make_model(
        ModelType.POSG, row_groups, np.array(rows), choice_actions=actions, action_names=names,
        state_players=owner, player_names=("p0", "p1"),
        observations=(Observation(0, ids, ("o",), np.array([[0], [1], [2]])),),
        labels={"goal": np.arange(S) == goal}, variable_names=("s",),
        state_values=np.arange(S)[:, None],
    )
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
    own1 = np.flatnonzero(owner == 1)
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


def drawn_game(seed: int):  # type: ignore[no-untyped-def]
    """The ``seed``-th game of :func:`games`, drawn reproducibly (no hypothesis database)."""
    from hypothesis import find, settings

    count = {"n": 0}

    def pick(_: object) -> bool:
        count["n"] += 1
        return count["n"] > seed

    return find(
        games(), pick, settings=settings(database=None, derandomize=True, max_examples=1000)
    )
