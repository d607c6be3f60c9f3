"""The mixture of two finite-state strategies (posgmc.strategies.mixture): its arrays are valid
strategies, and its value is the mixture of the two values (by hand on a one-step pomdp)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError
from posgmc.strategies.mixture import mix

ONE_STEP = """pomdp
observables s endobservables
module m
  s : [0..2] init 0;
  [a] s=0 -> 0.9:(s'=1) + 0.1:(s'=2);
  [b] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [e] s>0 -> true;
endmodule
label "goal" = s=1;
"""


def _memoryless(action: str) -> FiniteStateStrategy:
    # observations s=0, 1, 2; actions a, b, e
    act = np.zeros((1, 3, 3))
    act[0, 0, "abe".index(action)] = 1.0
    act[0, 1:, 2] = 1.0
    return FiniteStateStrategy.from_arrays(
        player="", observables=("s",), observation_values=np.array([[0], [1], [2]]),
        actions=("a", "b", "e"), action=act, update=np.ones((1, 3, 3, 1)))


@pytest.mark.parametrize("alpha", [0.0, 0.25, 4 / 9, 1.0])
def test_the_mixture_is_worth_the_mixture_of_the_values(tmp_path: Path, alpha: float) -> None:
    path = tmp_path / "one.pomdp"
    path.write_text(ONE_STEP)
    fss = mix(_memoryless("a"), _memoryless("b"), alpha)
    assert fss.memory_size == 3 and fss.initial_memory == 0
    result = api.check(api.load(path), properties=['P=? [ F "goal" ]'],
                       strategies={"": fss}).results[0]
    want = alpha * 0.9 + (1 - alpha) * 0.5  # by hand: a reaches goal w.p. 0.9, b w.p. 0.5
    assert result.guaranteed.lower - 1e-9 <= want <= result.guaranteed.upper + 1e-9


@settings(max_examples=30, deadline=None)
@given(alpha=st.floats(0, 1), k1=st.integers(1, 3), k2=st.integers(1, 3), seed=st.integers(0, 99))
def test_mixtures_of_random_strategies_are_strategies(
    alpha: float, k1: int, k2: int, seed: int
) -> None:
    rng = np.random.default_rng(seed)

    def random(k: int, rows: list[int], actions: tuple[str, ...]) -> FiniteStateStrategy:
        act = rng.random((k, len(rows), len(actions)))
        upd = rng.random((k, len(rows), len(actions), k))
        return FiniteStateStrategy.from_arrays(
            player="p",
            initial_memory=int(rng.integers(k)),
            observables=("x",),
            observation_values=np.array([[r] for r in rows], dtype=np.int64),
            actions=actions,
            action=act / act.sum(axis=2, keepdims=True),
            update=upd / upd.sum(axis=3, keepdims=True),
        )

    f1, f2 = random(k1, [0, 1], ("a", "b")), random(k2, [1, 2], ("b", "c"))
    m = mix(f1, f2, alpha)  # validated on construction
    assert m.memory_size == 1 + k1 + k2 and m.actions == ("a", "b", "c")
    assert m.observation_values[:, 0].tolist() == [0, 1, 2]
    # observation 1 (ruled by both): the first action is the mixture of the two first actions
    want = alpha * np.array([*f1.action[f1.initial_memory, 1], 0]) \
        + (1 - alpha) * np.array([0, *f2.action[f2.initial_memory, 0]])
    assert np.allclose(m.action[0, 1], want)
    # observation 0 is ruled by f1 only: f1 is played there
    assert np.allclose(m.action[0, 0, :2], f1.action[f1.initial_memory, 0])


def test_only_strategies_of_one_player_mix() -> None:
    f = _memoryless("a")
    other = FiniteStateStrategy.from_arrays(
        player="q", observables=("s",), observation_values=f.observation_values, actions=f.actions,
        action=f.action, update=f.update)
    with pytest.raises(StrategyError, match="same player"):
        mix(f, other, 0.5)
    with pytest.raises(StrategyError, match=r"in \[0, 1\]"):
        mix(f, f, 1.5)
