"""The compiled component-by-component solver (:mod:`posgmc.engines.kernels.sweeps`, driven by
:func:`posgmc.engines.topological.solve_topological`): its bounds and the numpy path's both
enclose the exact rational values, on random models and on the hand-built paths (closed form,
small components, refused order). The paths of ``tests/engines/test_topological.py`` run with the
kernels on and off as well."""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import kernels, scc
from posgmc.engines import objectives as obj
from posgmc.engines import topological as topo
from posgmc.engines.graph import structure_of
from posgmc.engines.iteration import EndComponents
from posgmc.engines.options import SolverOptions
from posgmc.engines.system import build_system
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import as_floats, layered_models

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")

TOL = 1e-9


@pytest.fixture
def small_bands(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every system with two or more SCCs gets the topological layout (one SCC per band)."""
    monkeypatch.setattr(scc, "MIN_BAND_STATES", 1)
    monkeypatch.setattr(scc, "DEFAULT_BANDS", 10**9)
    monkeypatch.setattr(scc, "MAX_GIANT_SHARE", 1.0)


def _maximize(model: ExplicitModel, flip: bool) -> np.ndarray:
    if model.model_type is ModelType.SMG:
        return (model.state_players == 0) ^ flip
    return np.full(model.num_states, flip)


def test_both_paths_enclose_the_exact_value(small_bands: None) -> None:
    """Hypothesis: on random layered models (trivial components, small ones, one holding every
    unknown state; mdps, games and chains) the compiled and the numpy path each give proven bounds
    around the exact rational reachability probability
    (:func:`posgmc.engines.objectives.exact_rational_reach`) within the precision."""
    ran: list[bool] = []
    original = topo._solve_components

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        out = original(*args, **kwargs)
        ran.append(out is not None)
        return out

    @settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(layered_models(), st.booleans(), st.booleans())
    def check(model: ExplicitModel, flip: bool, relative: bool) -> None:
        S = model.num_states
        target = np.zeros(S, dtype=bool)
        target[S - 2] = True
        maximize = _maximize(model, flip)
        exact = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
        options = SolverOptions(relative=relative)
        for compiled in (True, False):
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(kernels.STATE, "use", compiled)
                mp.setattr(topo, "_solve_components", counting)
                res = obj.reach_probability(model, target, maximize=maximize, options=options)
            assert res.sound and res.converged
            assert np.all(res.lower <= exact + TOL) and np.all(exact <= res.upper + TOL)
            gap = res.upper - res.lower
            if relative:
                assert np.all(gap <= 1e-6 * (res.upper + res.lower) + TOL)
            else:
                assert np.all(gap <= 2e-6 + TOL)

    check()
    assert sum(ran) >= 10, "the compiled path rarely ran"


def _chain() -> ExplicitModel:
    """s0 -> {s0: 1/2, s1: 1/4, sink: 1/4}; s1 -> {s1: 1/4, goal: 1/2, sink: 1/4} (goal = 2,
    sink = 3): with the self-loops eliminated x1 = (1/2) / (3/4) = 2/3, x0 = (1/4 x1) / (1/2) =
    1/3 (hand derivation)."""
    rows = [[0.5, 0.25, 0, 0.25], [0, 0.25, 0.5, 0.25], [0, 0, 1, 0], [0, 0, 0, 1]]
    return make_model(ModelType.MDP, np.arange(5), np.array(rows))


def test_trivial_components_take_no_iteration(small_bands: None) -> None:
    """Two one-state components: the closed form gives the value with no sweep, so the bounds are
    only the outward rounding apart."""
    model = _chain()
    assert model.num_states == 4 and model.num_choices == 4
    goal = np.array([False, False, True, False])
    exact = obj.exact_rational_reach(model, goal, maximize=np.ones(4, bool))
    assert exact[:2] == [Fraction(1, 3), Fraction(2, 3)]
    sys = build_system(
        structure_of(model),
        np.array([True, True, False, False]),
        maximize=np.ones(4, bool),
        fixed=goal.astype(float),
        topological=True,
    )
    assert sys.labels is not None
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        res = topo._solve_components(sys, SolverOptions(), cap=1.0, ec=EndComponents.DEFLATE)
    assert res is not None and res.converged and res.sound and res.iterations == 0
    values = as_floats([exact[int(s)] for s in sys.states])
    assert np.all(res.lower <= values) and np.all(values <= res.upper)
    assert np.all(res.upper - res.lower <= 1e-9)


def test_a_wrong_order_is_refused(small_bands: None) -> None:
    """Soundness guard: with the component labels reversed a row reads a later component, so the
    compiled solver declines (and :func:`solve_topological` goes on with the bands)."""
    model = _chain()
    goal = np.array([False, False, True, False])
    sys = build_system(
        structure_of(model),
        np.array([True, True, False, False]),
        maximize=np.ones(4, bool),
        fixed=goal.astype(float),
        topological=True,
    )
    assert sys.labels is not None
    backwards = replace(sys, labels=-sys.labels + int(sys.labels.max()))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        assert topo._solve_components(
            backwards, SolverOptions(), cap=1.0, ec=EndComponents.DEFLATE
        ) is None
        res = topo.solve_topological(backwards, SolverOptions(), cap=1.0, ec=EndComponents.DEFLATE)
    assert res is not None and res.converged
    values = as_floats([Fraction(1, 3), Fraction(2, 3)])[[int(s) for s in sys.states]]
    assert np.all(res.lower <= values + TOL) and np.all(values <= res.upper + TOL)


def test_a_component_out_of_iterations_gives_up() -> None:
    """A 2-state component whose lower iteration converges slowly (x0 = 0.99 x1 + 0.01 goal,
    x1 = x0: value 1) below a trivial one (t -> x0 w.p. 1/2, sink w.p. 1/2: value 1/2). With an
    iteration cap of 5 the compiled solver gives up (None) rather than report unproven bounds;
    without it the bounds enclose the values (hand derivation). States: x0, x1, t, goal, sink."""
    rows = [
        [0, 0.99, 0, 0.01, 0],
        [1, 0, 0, 0, 0],
        [0.5, 0, 0, 0, 0.5],
        [0, 0, 0, 1, 0],
        [0, 0, 0, 0, 1],
    ]
    model = make_model(ModelType.MDP, np.arange(6), np.array(rows))
    sys = build_system(
        structure_of(model),
        np.array([True, True, True, False, False]),
        maximize=np.ones(5, bool),
        fixed=np.array([0, 0, 0, 1.0, 0]),
        topological=True,
        band_states=1,
    )
    assert sys.labels is not None and sys.n == 3
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", True)
        opts = SolverOptions(max_iterations=5)
        assert topo._solve_components(sys, opts, cap=1.0, ec=EndComponents.DEFLATE) is None
        res = topo._solve_components(sys, SolverOptions(), cap=1.0, ec=EndComponents.DEFLATE)
    assert res is not None and res.converged and res.iterations > 5
    values = np.array([1.0, 1.0, 0.5])[sys.states]
    assert np.all(res.lower <= values + TOL) and np.all(values <= res.upper + TOL)
    assert np.all(res.upper - res.lower <= 2e-6)
