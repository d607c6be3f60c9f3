"""Exact bounds for deciding a threshold equal to the value (posgmc.checking.decide): they
bracket the value found by brute force over memoryless profiles, and decide() is monotone."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.checking.decide import INFINITY, decide, reward_bounds
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType
from posgmc.syntax.ast import ComparisonOp
from tests.engines.engine_models import chain_reward, game_value, small_models


@pytest.mark.parametrize(
    ("op", "low", "high", "expected"),
    [
        (ComparisonOp.GE, Fraction(1, 3), Fraction(1, 3), True),
        (ComparisonOp.GT, Fraction(1, 3), Fraction(1, 3), False),
        (ComparisonOp.LE, Fraction(1, 3), Fraction(1, 3), True),
        (ComparisonOp.LT, Fraction(1, 3), Fraction(1, 3), False),
        (ComparisonOp.GE, Fraction(1, 4), Fraction(1, 3), None),  # the bracket straddles it
        (ComparisonOp.LE, Fraction(1, 4), Fraction(1, 3), True),
        (ComparisonOp.GT, Fraction(1, 2), INFINITY, True),
        (ComparisonOp.LE, INFINITY, INFINITY, False),
    ],
)
def test_decide(op: ComparisonOp, low: Fraction, high: Fraction, expected: bool | None) -> None:
    assert decide(op, low, high, Fraction(1, 3)) is expected


@settings(max_examples=40, deadline=None)
@given(small_models(ModelType.SMG, max_states=4), st.data())
def test_game_reward_bounds_bracket_the_value(model: ExplicitModel, data: st.DataObject) -> None:
    S, C = model.num_states, model.num_choices
    rewards = np.array(data.draw(st.lists(st.integers(0, 3), min_size=C, max_size=C)), float)
    target = np.zeros(S, dtype=bool)
    target[data.draw(st.integers(0, S - 1))] = True
    maximize = model.state_players == 0
    brute = game_value(model, maximize, lambda rows: chain_reward(model, rows, rewards, target,
                                                                  "inf"))
    bounds = reward_bounds(model, rewards, target, maximize, brute)
    assert bounds is not None
    low, high = bounds
    for s in range(S):
        assert low[s] <= high[s]
        if np.isinf(brute[s]):
            assert high[s] == INFINITY
        else:
            assert float(low[s]) <= brute[s] + 1e-9 and brute[s] - 1e-9 <= float(high[s])
        # strategies read off the exact values are optimal: the bracket closes
        assert low[s] == high[s]
