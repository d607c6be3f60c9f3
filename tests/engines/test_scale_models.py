"""The array-built scale models of benchmarks/engine_bench.py against Storm's values.

Storm 2.0's values are quoted in tests/data/benchmarks/scale/README.md: ``two_robots`` Pmax at
N=10: 0.9230346812, N=20: 0.8444445269; ``pursuit`` at N=6: 0.0559493256, N=16: 0.0025775352.
Storm's default value iteration stops early (it is not sound), so its value lies within about 1e-6
of ours; we check that our proven interval is within that distance of it.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from posgmc.engines import objectives as obj

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "engine_bench.py"


def _bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location("engine_bench", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _check(res, init: int, storm: float) -> None:  # type: ignore[no-untyped-def]
    assert res.converged and res.sound
    assert res.upper[init] - res.lower[init] <= 2e-6
    assert res.lower[init] - 1e-6 <= storm <= res.upper[init] + 1e-6


def test_two_robots_n10_matches_storm() -> None:
    model, goal = _bench().robots(10)
    # all 2 N^4 position pairs with and without the fault flag (Storm counts 19,899 reachable)
    assert model.num_states == 2 * 10**4
    res = obj.reach_probability(model, goal, maximize=np.ones(model.num_states, bool))
    _check(res, int(model.initial_states[0]), 0.9230346812)


def test_pursuit_n6_matches_storm() -> None:
    model, escaped = _bench().pursuit(6)
    assert model.num_states == 2 * 6**4  # Storm: 2,556 reachable of these
    res = obj.reach_probability(model, escaped, maximize=model.state_players == 0)
    _check(res, int(model.initial_states[0]), 0.0559493256)


@pytest.mark.slow
def test_pursuit_n16_matches_storm() -> None:
    model, escaped = _bench().pursuit(16)
    res = obj.reach_probability(model, escaped, maximize=model.state_players == 0)
    _check(res, int(model.initial_states[0]), 0.0025775352)


@pytest.mark.slow
def test_two_robots_n20_matches_storm() -> None:
    model, goal = _bench().robots(20)
    res = obj.reach_probability(model, goal, maximize=np.ones(model.num_states, bool))
    _check(res, int(model.initial_states[0]), 0.8444445269)
