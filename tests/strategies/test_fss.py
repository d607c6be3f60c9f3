"""The rule-based storage of finite-state strategies: memory grows with the rules written, lookups
agree with the dense arrays, and the dense arrays are refused (not attempted) when they cannot
fit in the memory available."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import resources
from posgmc.errors import LimitError
from posgmc.strategies.files import dump_strategy, parse_strategy
from posgmc.strategies.fss import FiniteStateStrategy, StrategyError


def _ring(k: int, num_obs: int) -> str:
    """A k-node strategy over observations x=0..num_obs-1: node n plays "go" and moves to n+1."""
    rules = [{"memory": n, "observation": {"x": x}, "action": {"go": 1.0},
              "update": {"go": {str((n + 1) % k): 1.0}}}
             for n in range(k) for x in range(num_obs)]
    return json.dumps({"format": "posgmc-fss/1", "player": "p", "memory_size": k,
                       "initial_memory": 0, "observables": ["x"], "rules": rules})


def test_memory_grows_with_the_rules_not_with_k_squared() -> None:
    f = parse_strategy(_ring(20_000, 3))
    assert (f.memory_size, f.num_observations, f.num_actions, f.num_rules) == (20_000, 3, 1, 60_000)
    held = sum(a.nbytes for a in (f.rule_memory, f.rule_observation, f.choice_start,
                                  f.choice_action, f.choice_probability, f.update_start,
                                  f.update_node, f.update_probability))
    # 60,000 rules x (2 + 2 + 2 + 2 + 1 + ...) words: a few MB; the dense δ would be 9.6 GB
    assert held < 8 * 10 * 60_001
    assert f.is_deterministic
    # what node 19,999 does under x=2: go, to node 0
    r = int(f.rule_of(np.array(19_999), np.array(2)))
    e = int(f.entry_of(np.array(r), np.array(0)))
    lo = int(f.update_start[e])
    assert f.update_node[lo] == 0 and f.update_probability[lo] == 1.0


def test_a_memory_size_far_above_the_rules_costs_nothing() -> None:
    doc = json.loads(_ring(1, 2))
    doc["memory_size"] = 1_000_000
    f = parse_strategy(json.dumps(doc))
    assert f.memory_size == 1_000_000 and f.num_rules == 2
    assert "999999" not in dump_strategy(f)  # nodes no rule names are not written


def test_dense_arrays_that_cannot_fit_are_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    f = parse_strategy(_ring(20_000, 3))
    monkeypatch.setattr(resources, "available_bytes", lambda: 4 << 30)
    with pytest.raises(LimitError) as info:
        _ = f.update
    # k x Z x A x k doubles: 20,000 * 3 * 1 * 20,000 * 8 bytes
    assert "the dense update array (20000, 3, 1, 20000)" in info.value.message
    assert "9.6 GB" in info.value.message and "4.3 GB of memory is available" in info.value.message


@st.composite
def dense(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    k, Z, A = draw(st.integers(1, 3)), draw(st.integers(1, 3)), draw(st.integers(1, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    action = rng.random((k, Z, A)) * (rng.random((k, Z, A)) < 0.6)
    action[..., 0] += 1e-3
    action /= action.sum(axis=2, keepdims=True)
    action[rng.random((k, Z)) < 0.3] = 0.0
    update = rng.random((k, Z, A, k)) * (rng.random((k, Z, A, k)) < 0.5)
    update[..., 0] += 1e-3
    update /= update.sum(axis=3, keepdims=True)
    return action, update * (action[..., None] > 0)


@settings(max_examples=60, deadline=None)
@given(dense())
def test_rules_give_back_the_dense_arrays(arrays: tuple[np.ndarray, np.ndarray]) -> None:
    action, update = arrays
    k, Z, A = action.shape
    f = FiniteStateStrategy.from_arrays(
        player="p", observables=("x",), observation_values=np.arange(Z)[:, None],
        actions=tuple(f"a{i}" for i in range(A)), action=action, update=update)
    g = FiniteStateStrategy.from_entries(  # the same rules, without the dense arrays kept
        player="p", memory_size=k, initial_memory=0, observables=("x",),
        observation_values=f.observation_values, actions=f.actions,
        rule_memory=f.rule_memory, rule_observation=f.rule_observation,
        entry_rule=np.repeat(np.arange(f.num_rules), np.diff(f.choice_start)),
        entry_action=f.choice_action, entry_probability=f.choice_probability,
        update_entry=np.repeat(np.arange(f.choice_action.size), np.diff(f.update_start)),
        update_node=f.update_node, update_probability=f.update_probability)
    assert np.array_equal(g.action, action) and np.array_equal(g.update, update)
    assert np.array_equal(g.has_rule, action.sum(axis=2) > 0)
    n, z, a = np.meshgrid(np.arange(k), np.arange(Z), np.arange(A), indexing="ij")
    e = g.entry_of(g.rule_of(n, z), a)
    assert np.array_equal(e >= 0, action > 0)
    assert np.array_equal(g.entry_at(n, z, a), e)  # the direct table agrees with the search
    gamma = np.zeros(action.shape)
    gamma[e >= 0] = g.choice_probability[e[e >= 0]]
    assert np.array_equal(gamma, action)


def test_invalid_rules_are_refused() -> None:
    kwargs = dict(player="p", memory_size=2, initial_memory=0, observables=("x",),
                  observation_values=np.array([[0]]), actions=("a",),
                  rule_memory=np.array([0]), rule_observation=np.array([0]),
                  entry_rule=np.array([0]), entry_action=np.array([0]),
                  entry_probability=np.array([0.5]), update_entry=np.array([0]),
                  update_node=np.array([1]), update_probability=np.array([1.0]))
    with pytest.raises(StrategyError, match="sums to 0.5, not 1"):
        FiniteStateStrategy.from_entries(**kwargs)  # type: ignore[arg-type]
    kwargs["entry_probability"] = np.array([1.0])
    kwargs["update_node"] = np.array([2])
    with pytest.raises(StrategyError, match="next memory node is out of range"):
        FiniteStateStrategy.from_entries(**kwargs)  # type: ignore[arg-type]
