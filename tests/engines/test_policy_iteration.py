"""Policy iteration (:mod:`posgmc.engines.policy_iteration`) under rounding noise: a switch that
only the linear solves' rounding makes look better must not cycle for ever nor be kept when it
loses.

Found on PAYNT's attacker-one-defender (issue #9): during the gradient search the nested policy
iteration of a product switched between rows whose values differed by rounding, closing end
components (values dropping from 0.99999 to 0) and switching back, without end.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import posgmc.engines.policy_iteration as ex


def _one_state(maximize: bool) -> ex.Grouped:
    """One unknown state with two rows: row 0 leaves, reaching the target with probability 1/2
    (offset 1/2); row 1 is a self-loop (an end component: value 0 for a least fixpoint)."""
    matrix = sp.csr_matrix(([1.0], ([1], [0])), shape=(2, 1))
    return ex.Grouped(
        matrix=matrix,
        offset=np.array([0.5, 0.0]),
        stays=np.array([False, True]),
        row_groups=np.array([0, 2], dtype=np.int64),
        row_state=np.array([0, 0], dtype=np.int64),
        maximize=np.array([maximize]),
        source=np.array([0, 1], dtype=np.int64),
    )


def test_exact_values_without_noise() -> None:
    x, rows, _ = ex.policy_iteration(
        _one_state(True), np.array([0]), outer_max=True, idle_min=False
    )
    assert rows.tolist() == [0] and x[0] == pytest.approx(0.5)  # by hand: max(1/2, 0)


def test_a_switch_on_rounding_noise_is_banned(monkeypatch: pytest.MonkeyPatch) -> None:
    """With 1e-9 of noise on every evaluated value, the self-loop looks better than leaving
    (x + 1e-9 > 1/2 + tolerance once x = 1/2 + 1e-9 is read back through the loop); taking it
    drops the value to 1e-9, so the switch is banned and the optimum 1/2 stays."""
    exact = ex.evaluate
    calls = {"n": 0}

    def noisy(gr: ex.Grouped, rows: np.ndarray) -> np.ndarray:
        calls["n"] += 1
        return exact(gr, rows) + 1e-9

    monkeypatch.setattr(ex, "evaluate", noisy)
    x, rows, rounds = ex.policy_iteration(
        _one_state(True), np.array([0]), outer_max=True, idle_min=False, max_rounds=1000
    )
    assert rows.tolist() == [0]
    assert x[0] == pytest.approx(0.5, abs=1e-8)
    assert calls["n"] <= 3 and rounds <= 3  # one losing try, then nothing left to switch
