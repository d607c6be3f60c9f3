"""The engine parts of multi(...) on hand-built arrays: settling options, step unfolding, and the
geometry of Pareto fronts (posgmc.engines.multi)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from posgmc.engines.multi.pareto import _corners, _distance_to_under, _hull
from posgmc.engines.multi.settle import Condition, ConditionKind, settling_options
from posgmc.engines.multi.unfold import layer_rewards, unfold_steps


def _loops() -> tuple[sp.csr_matrix, np.ndarray]:
    # s0 -> s1 (choice 0) or s3 (1); s1 stays (2) or goes to s2 (3); s2 -> s1 (4); s3 loops (5)
    rows, cols = [0, 1, 2, 3, 4, 5], [1, 3, 1, 2, 1, 3]
    t = sp.csr_matrix((np.ones(6), (rows, cols)), shape=(6, 4))
    return t, np.array([0, 2, 4, 5, 6])


def test_settling_options_enumerate_sub_components() -> None:
    t, groups = _loops()
    s1 = np.array([False, True, False, False])
    s2 = np.array([False, False, True, False])
    conds = (Condition(ConditionKind.INSIDE, s1), Condition(ConditionKind.MEETS, s2))
    state, sat = settling_options(
        t, groups, conds, allowed=np.ones(6, bool), settle=np.ones(4, bool)
    )
    options = sorted((int(s), tuple(bool(b) for b in row)) for s, row in zip(state, sat))
    # s1: in {s1} (inside s1, does not meet s2) or in {s1, s2} (meets s2, not inside s1);
    # s2 only in {s1, s2}; s3 its own component, neither; s0 in no end component
    assert options == [
        (1, (False, True)),
        (1, (True, False)),
        (2, (False, True)),
        (3, (False, False)),
    ]


def test_settling_respects_allowed_choices() -> None:
    t, groups = _loops()
    allowed = np.ones(6, bool)
    allowed[4] = False  # s2 -> s1 collects reward: the cycle may not be repeated forever
    cond = (Condition(ConditionKind.MEETS, np.array([False, False, True, False])),)
    state, sat = settling_options(t, groups, cond, allowed=allowed, settle=np.ones(4, bool))
    assert sorted(state.tolist()) == [1, 3] and not sat.any()


def test_unfolding_counts_steps() -> None:
    t, groups = _loops()
    u, g = unfold_steps(t, groups, 2)
    assert u.shape == (18, 12) and g.tolist()[:5] == [0, 2, 4, 5, 6] and g[-1] == 18
    # choice 0 of layer 0 leads to s1 of layer 1; layer 2 stays in layer 2
    assert u[0].indices.tolist() == [4 + 1] and u[12].indices.tolist() == [8 + 1]
    r = layer_rewards(np.arange(6.0), 2, 1)
    assert r[:6].tolist() == list(range(6)) and not r[6:].any()


def test_front_geometry() -> None:
    under = _hull(np.array([[0.0, 1.0], [0.5, 0.5], [1.0, 0.0], [0.4, 0.4], [0.6, 0.6]]))
    # (0.5, 0.5) lies on no boundary once (0.6, 0.6) is there; (0.4, 0.4) is inside
    assert under.tolist() == [[1.0, 0.0], [0.6, 0.6], [0.0, 1.0]]
    facets = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    corners = _corners(facets)
    assert corners.tolist() == [[1.0, 1.0]]
    # from (1, 1) to the segment (1,0)-(0.6,0.6) or (0.6,0.6)-(0,1): the nearer
    d = _distance_to_under(corners[0], under)
    assert 0.0 < d < np.hypot(0.4, 0.4) + 1e-12
    assert _distance_to_under(np.array([0.2, 0.2]), under) == 0.0


def test_polygon_operations() -> None:
    from posgmc.engines.multi import polygon

    a = polygon.hull(np.array([[1.0, 0.0], [0.0, 1.0]]))
    b = polygon.point(np.array([0.5, 0.5]))
    # Minkowski sum: 0.5 a + 0.5 b + (1, 0) has the vertices (1.75, 0.25) and (1.25, 0.75)
    s = polygon.weighted_sum([a, b], np.array([0.5, 0.5]), np.array([1.0, 0.0]))
    assert np.allclose(s, [[1.75, 0.25], [1.25, 0.75]])
    # the intersection of "below (1, 0)-(0, 1)" and "below (0.8, 0.8)" is cut at x + y = 1
    c = polygon.intersection([a, polygon.point(np.array([0.8, 0.8]))])
    assert np.allclose(c, [[0.8, 0.2], [0.2, 0.8]])
    assert polygon.contains(c, np.array([0.5, 0.5])) and not polygon.contains(
        c, np.array([0.6, 0.5])
    )
    assert np.allclose(polygon.support(c, np.array([[1.0, 0.0], [0.0, 1.0]])), [0.8, 0.8])
