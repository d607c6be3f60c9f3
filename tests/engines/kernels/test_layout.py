"""The compiled layout passes of ``build_system`` (:mod:`posgmc.engines.kernels.layout`) build the
very same system as the numpy path (arrays compared element for element)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import kernels
from posgmc.engines.graph import structure_of
from posgmc.engines.system import System, build_system
from posgmc.model.explicit import ExplicitModel
from tests.engines.engine_models import small_models

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")

FIELDS = ("states", "rows", "row_state", "offset", "stays", "slots", "blocks")


def _build(model: ExplicitModel, compiled: bool, **kwargs: object) -> System:
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels.STATE, "use", compiled)
        return build_system(structure_of(model), **kwargs)  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(small_models(max_states=8), st.data())
def test_compiled_layout_is_the_numpy_layout(model: ExplicitModel, data: st.DataObject) -> None:
    S, C = model.num_states, model.num_choices
    g = structure_of(model)
    unknown = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    allowed = np.array(data.draw(st.lists(st.booleans(), min_size=C, max_size=C)))
    # every unknown state keeps at least its first choice
    allowed[g.row_groups[:-1]] = True
    maximize = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    fixed = np.array(data.draw(st.lists(st.sampled_from([0.0, 0.5, 1.0, 3.0]), min_size=S,
                                        max_size=S)))
    offset = np.array(data.draw(st.lists(st.sampled_from([0.0, 1.0, 0.25]), min_size=C,
                                         max_size=C)))
    kwargs = dict(
        unknown=unknown,
        maximize=maximize,
        allowed=allowed if data.draw(st.booleans()) else None,
        choice_offset=offset if data.draw(st.booleans()) else None,
        fixed=fixed if data.draw(st.booleans()) else None,
    )
    ours = _build(model, True, **kwargs)
    theirs = _build(model, False, **kwargs)
    assert (ours.n, ours.m) == (theirs.n, theirs.m) == (int(unknown.sum()), ours.rows.size)
    for name in FIELDS:
        assert np.array_equal(getattr(ours, name), getattr(theirs, name)), name
    for name in ("indptr", "indices", "data"):
        a, b = getattr(ours.matrix, name), getattr(theirs.matrix, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
