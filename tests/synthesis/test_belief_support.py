"""The belief support as a deterministic memory (posgmc.synthesis.belief_support): its frame on
PAYNT's dodge game, and on random games that every (node, observation) pair the product reaches
has a rule (the product of the frame's FSS builds) and every node's update names a node."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.strategies.binding import bind
from posgmc.strategies.product import strategy_product
from posgmc.synthesis import belief_support
from tests.random_games import random_pomdp, random_posg

ROOT = Path(__file__).resolve().parents[2]
DODGE = ROOT / "tests" / "data" / "benchmarks" / "posmg" / "dodge-6-lines-position"


def test_dodge_frame_size() -> None:
    """PAYNT's dodge-6-lines-position (tests/data/benchmarks/posmg, a DRN): the runner's
    supports reachable from the start; sizes computed by this construction, pinned so that a
    change of the update rule shows."""
    model = api.build(api.load(DODGE / "sketch.templ")).model
    assert (model.num_states, model.num_choices) == (639, 2487)
    frame = belief_support.support_frame(model, 0)
    assert frame is not None
    assert (frame.memory_size, frame.rule_node.size, frame.num_entries) == (354, 772, 2866)
    # caps: too few nodes allowed gives up rather than truncating the memory
    assert belief_support.support_frame(model, 0, max_nodes=100) is None
    assert belief_support.support_frame(model, 0, max_pairs=1000) is None


def _frame_is_closed(model, player: int) -> None:  # type: ignore[no-untyped-def]
    frame = belief_support.support_frame(model, player)
    assert frame is not None
    k = frame.memory_size
    assert frame.initial == 0
    assert np.all((frame.entry_next >= 0) & (frame.entry_next < k))
    keys = frame.rule_node * 10_000 + frame.rule_obs
    assert np.all(np.diff(keys) > 0)  # sorted, no pair twice
    assert np.all(np.diff(frame.entry_rule) >= 0)
    starts = np.searchsorted(frame.entry_rule, np.arange(frame.rule_node.size + 1))
    assert np.all(np.diff(starts) >= 1)  # every rule plays something
    uniform = 1.0 / np.diff(starts)[frame.entry_rule]
    # the product raises when a reached (node, observation) pair has no rule
    prod = strategy_product(model, [bind(model, frame.strategy(model, player, uniform))])
    assert prod.model.num_states >= 1


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000))
def test_random_game_frames_are_closed(seed: int) -> None:
    _frame_is_closed(random_posg(seed), 0)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000))
def test_random_pomdp_frames_are_closed(seed: int) -> None:
    _frame_is_closed(random_pomdp(seed), 0)
