"""The certificate that proves a maximiser's grid bound for the exact belief MDP
(posgmc.synthesis.grid_certificate): with rewards of both signs, by a contraction in the weighted
sup norm of the expected steps (checked by ``contracts``), on hand-built enclosures whose exact
fixpoint is known, and on 4x3-95's grid against Storm's discretisation."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from posgmc.engines.options import SolverOptions
from posgmc.synthesis import belief_grid, grid_certificate
from tests.synthesis.test_belief_grid import _built, _problem

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "benchmarks" / "pomdp"


def _signed_loop(stay: float, reward: float, leak: float) -> grid_certificate.Enclosure:
    """One vertex with one row: reward ``reward`` (either sign), back to itself with weight
    ``stay`` (an ambiguous part when ``leak`` > 0), the rest stops."""
    coef = sp.csr_matrix((np.array([stay]), (np.array([0]), np.array([0]))), shape=(1, 1))
    return grid_certificate.Enclosure(
        state=np.zeros(1, dtype=np.int64), coef=coef, top=np.array([reward]),
        slack=np.zeros(1), leak=np.array([leak]), gone=np.array([1.0 - stay]),
        kept_lo=np.array([stay]), clean=np.array([leak == 0.0 and stay == 1.0]),
        infinite=np.zeros(1, dtype=bool), adversary=np.zeros(1, dtype=bool),
        probability=False, discount=1.0, signed=True)


def test_a_negative_loop_is_bounded_by_its_contraction() -> None:
    """X = -1 + 9/10 X + leak: the exact operator's fixpoint is -10 + 10 leak (by hand). The
    engine's -10 is raised just enough: the returned W passes the row's inequality in exact
    arithmetic, so it is at least the fixpoint, and it stays within 1e-9 of it."""
    leak = 1e-12
    W = grid_certificate.certified_upper(_signed_loop(0.9, -1.0, leak), np.array([-10.0]))
    assert W is not None
    w = Fraction(float(W[0]))
    assert Fraction(-1) + Fraction(0.9) * w + Fraction(leak) <= w
    assert w >= Fraction(-10) + 10 * Fraction(leak)
    assert w <= -10.0 + 1e-9


def test_a_signed_loop_that_never_stops_proves_nothing() -> None:
    """A row that keeps all its mass on its own vertex is no contraction: with rewards of both
    signs no W is proven (Park induction from 0, which a clean loop would allow when the
    rewards are nonnegative, does not hold for negative values)."""
    enc = _signed_loop(1.0, -1.0, 0.0)
    h = np.ones(1)
    assert not grid_certificate.contracts(enc, np.ones(1, dtype=bool), h)
    assert grid_certificate.certified_upper(enc, np.array([-10.0])) is None


def test_contracts_needs_every_row_to_shrink_the_weights() -> None:
    """Σ_k coef_k h_k < h_v on every usable row, h > 0: 0.9 h < h holds, a weight of 1 fails,
    and so does h = 0 or an infinite h."""
    enc = _signed_loop(0.9, -1.0, 0.0)
    rows = np.ones(1, dtype=bool)
    assert grid_certificate.contracts(enc, rows, np.array([10.0]))
    assert not grid_certificate.contracts(enc, rows, np.array([0.0]))
    assert not grid_certificate.contracts(enc, rows, np.array([np.inf]))
    assert not grid_certificate.contracts(_signed_loop(1.0, -1.0, 0.0), rows, np.array([10.0]))


def test_4x3_95s_grid_is_proven_at_storms_resolution_2() -> None:
    """4x3-95 (Cassandra's 4x3 maze with the discount 0.95 as a stop to the sink, rewards of
    both signs): the grid at resolution 2 is proven for the exact belief MDP at most Storm's
    discretisation at resolution 2, and no lower than Storm's belief unfolding (both
    tests/data/RESULTS.md: 2.241930211869714, >= 1.8643111356915565); full observation is
    2.48144 there."""
    model = _built(DATA / "4x3-95" / "sketch.templ")
    assert model.num_states == 22
    problem = _problem(model, 'R{"reward"}max=? [F "discount_sink"]')
    cutoff = belief_grid.full_observation_bounds(problem)[0]
    floor = belief_grid.full_observation_floor(problem)
    assert bool((floor < 0).any())
    abstraction = belief_grid.grid_abstraction(problem, 2, cutoff=cutoff, floor=floor)
    assert abstraction is not None and abstraction.vertices == 30
    enc = abstraction.enclosure
    assert enc is not None and enc.signed and bool(np.isfinite(enc.leak).all())
    result = abstraction.solve(SolverOptions(precision=belief_grid.PRECISION, relative=True,
                                             want_strategy=False, stiff_certificate=True))
    W = grid_certificate.certified_upper(enc, np.asarray(result.upper, dtype=np.float64))
    assert W is not None
    assert 1.8643111356915565 <= W[0] <= 2.241930211869714
