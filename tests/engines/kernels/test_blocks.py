"""The compiled Gauss-Seidel sweeps over a whole system's blocks
(:mod:`posgmc.engines.kernels.blocks`) compute the numpy path's iterates exactly: the same
bounds, bit for bit, and the same number of iterations, on random models with a blocked layout
(thresholds lowered as in ``tests/engines/test_iteration_blocks.py``), and those bounds enclose
the exact rational value."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.engines import iteration, kernels
from posgmc.engines import objectives as obj
from posgmc.engines import system as sy
from posgmc.engines.graph import positive_reach, structure_of
from posgmc.engines.options import SolverOptions
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import as_floats, small_models

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")


BLOCKED: list[int] = []


def test_compiled_sweeps_equal_numpy_sweeps() -> None:
    BLOCKED.clear()
    _check()
    assert len(BLOCKED) >= 3, "the blocked sweeps rarely ran"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_models(max_states=8), st.booleans(), st.booleans(), st.data())
def _check(model: ExplicitModel, flip: bool, relative: bool, data: st.DataObject) -> None:
    S = model.num_states
    target = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    if model.model_type is ModelType.SMG:
        maximize = (model.state_players == 0) ^ flip
    else:
        maximize = np.full(S, flip)
    g = structure_of(model)
    layer = np.full(S, -1, dtype=np.int64)
    pos = positive_reach(g, target, np.ones(S, bool), existential=maximize, layer=layer)
    unknown = pos & ~target
    if not unknown.any():
        return
    exact = as_floats(obj.exact_rational_reach(model, target, maximize=maximize))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sy, "_MIN_BLOCKED_STATES", 0)
        mp.setattr(sy, "_MAX_BLOCKS", 3)
        sys = sy.build_system(
            g, unknown, maximize=maximize, fixed=target.astype(float), layer=layer
        )
    if sys.num_blocks > 1:
        BLOCKED.append(sys.num_blocks)
    options = SolverOptions(relative=relative, max_iterations=20_000)
    ec = iteration.EndComponents.DEFLATE
    results = []
    for compiled in (True, False):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels.STATE, "use", compiled)
            results.append(iteration.solve(sys, options, cap=1.0, ec=ec, inner=2))
    ours, theirs = results
    assert ours.iterations == theirs.iterations
    assert np.array_equal(ours.lower, theirs.lower) and np.array_equal(ours.upper, theirs.upper)
    if ours.converged:
        values = exact[sys.states]
        assert np.all(ours.lower <= values + 1e-9) and np.all(values <= ours.upper + 1e-9)
