"""Topological (SCC-ordered) solving: :mod:`posgmc.engines.scc` and
:mod:`posgmc.engines.topological`.

Small models never reach the size where the order pays, so the ``forced`` fixture makes every
system with two or more SCCs topological, one band per SCC (the smallest bands the layout makes).
Each path is checked against exact values: the trivial-SCC closed form (self-loops eliminated),
small SCCs, a giant SCC next to trivial ones, games; and the random-model invariants of
``test_engine_random.py`` (exact rationals and brute force) are rerun on the forced path.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine_models import as_floats, chain_reward, game_value
from posgmc.engines import objectives as obj
from posgmc.engines import scc
from posgmc.engines import topological as topo
from posgmc.engines.graph import structure_of
from posgmc.engines.iteration import EndComponents
from posgmc.engines.options import SolverOptions
from posgmc.engines.system import build_system
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType

TOL = 1e-9


@pytest.fixture
def forced(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Every system with two or more SCCs laid out topologically, one SCC per band; returns a
    list that counts the topological solves that finished (so a test knows the path ran)."""
    monkeypatch.setattr(scc, "MIN_BAND_STATES", 1)
    monkeypatch.setattr(scc, "DEFAULT_BANDS", 10**9)
    monkeypatch.setattr(scc, "MAX_GIANT_SHARE", 1.0)
    calls: list[int] = []
    original = topo.solve_topological

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        out = original(*args, **kwargs)
        if out is not None:
            calls.append(int(args[0].bands.size - 1))
        return out

    import posgmc.engines.common as common

    monkeypatch.setattr(common, "solve_topological", counting)
    return calls


@st.composite
def layered_models(draw: st.DrawFn, max_states: int = 7) -> ExplicitModel:
    """A random model whose states come in groups (future SCCs, or trivial ones): every choice
    moves within its group, to an earlier group, or to the last two states (goal, sink; both
    absorbing). Probabilities are multiples of 1/4, so exact rationals apply."""
    mtype = draw(st.sampled_from([ModelType.DTMC, ModelType.MDP, ModelType.SMG]))
    n = draw(st.integers(2, max_states - 2))
    group = sorted(draw(st.lists(st.integers(0, 3), min_size=n, max_size=n)))
    S = n + 2
    counts = [1 if mtype is ModelType.DTMC else draw(st.integers(1, 2)) for _ in range(n)]
    rows = []
    for s in range(n):
        reach = [t for t in range(n) if group[t] <= group[s]] + [n, n + 1]
        for _ in range(counts[s]):
            k = draw(st.integers(1, 3))
            succ = draw(st.lists(st.sampled_from(reach), min_size=k, max_size=k))
            row = np.zeros(S)
            for t in succ:
                row[t] += 0.25
            row[succ[0]] += 1.0 - row.sum()
            rows.append(row)
    for t in (n, n + 1):
        row = np.zeros(S)
        row[t] = 1.0
        rows.append(row)
    rg = np.concatenate([[0], np.cumsum(counts + [1, 1])])
    players = [draw(st.integers(0, 1)) for _ in range(S)] if mtype is ModelType.SMG else None
    return make_model(
        mtype,
        rg,
        np.array(rows),
        state_players=players,
        player_names=("p0", "p1") if mtype is ModelType.SMG else (),
    )


def _maximize(model: ExplicitModel, flip: bool) -> np.ndarray:
    if model.model_type is ModelType.SMG:
        return (model.state_players == 0) ^ flip
    return np.full(model.num_states, flip)


SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def test_random_reach_bounds_enclose_exact_rationals(forced: list[int]) -> None:
    @SETTINGS
    @given(layered_models(), st.booleans(), st.booleans())
    def check(model: ExplicitModel, flip: bool, relative: bool) -> None:
        S = model.num_states
        target = np.zeros(S, dtype=bool)
        target[S - 2] = True
        maximize = _maximize(model, flip)
        ref = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
        res = obj.reach_probability(
            model, target, maximize=maximize, options=SolverOptions(relative=relative)
        )
        assert res.sound and res.converged
        assert np.all(res.lower <= ref + TOL) and np.all(ref <= res.upper + TOL)
        if relative:
            assert np.all(res.upper - res.lower <= 1e-6 * (res.upper + res.lower) + TOL)
        else:
            assert np.all(res.upper - res.lower <= 2e-6 + TOL)

    check()
    assert len(forced) >= 10, "the topological path rarely ran"


def test_random_reward_bounds_enclose_brute_force(forced: list[int]) -> None:
    @SETTINGS
    @given(layered_models(max_states=6), st.booleans(), st.data())
    def check(model: ExplicitModel, flip: bool, data: st.DataObject) -> None:
        S = model.num_states
        target = np.zeros(S, dtype=bool)
        target[S - 2] = True
        maximize = _maximize(model, flip)
        rewards = np.array(
            data.draw(
                st.lists(
                    st.sampled_from([0.0, 1.0, 2.0, 0.5]),
                    min_size=model.num_choices,
                    max_size=model.num_choices,
                )
            )
        )
        ref = game_value(
            model, maximize, lambda rows: chain_reward(model, rows, rewards, target, "inf")
        )
        res = obj.expected_reach_reward(
            model, rewards, target, maximize=maximize, mode=obj.ReachRewardMode.INFINITY
        )
        assert res.sound and res.converged
        inf = np.isinf(ref)
        assert np.array_equal(np.isinf(res.values), inf)
        fin = ~inf
        assert np.all(res.lower[fin] <= ref[fin] + 1e-7) and np.all(ref[fin] <= res.upper[fin] + 1e-7)
        assert np.all(res.upper[fin] - res.lower[fin] <= 2e-6 + 1e-9)

    check()
    assert len(forced) >= 10, "the topological path rarely ran"
