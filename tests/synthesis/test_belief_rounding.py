"""The grid abstraction's float rounding helpers (posgmc.synthesis.belief_rounding)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from posgmc.synthesis import belief_rounding


def test_outward_rounding_moves_either_sign_toward_the_bound_side() -> None:
    """v + err rounded up, v - err rounded down, for negative and positive v alike; a zero
    error leaves v exact."""
    v = np.array([-0.3, 0.3, -0.3, 0.0])
    err = np.array([1e-17, 1e-17, 0.0, 0.0])
    up = belief_rounding.outward(v, err, True)
    down = belief_rounding.outward(v, err, False)
    for x, e, u, d in zip(v.tolist(), err.tolist(), up.tolist(), down.tolist(), strict=True):
        assert Fraction(d) <= Fraction(x) - Fraction(e) <= Fraction(x) + Fraction(e) <= Fraction(u)
    assert up[2] == down[2] == -0.3 and up[3] == down[3] == 0.0
