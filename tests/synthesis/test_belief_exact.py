"""The exact-arithmetic side of the grid abstraction (posgmc.synthesis.belief_exact): a stored
randomised rule stands for an exact rational rule, and the exact rows are the rational successor
vectors."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.synthesis import belief_dynamics, belief_exact
from tests.random_games import random_pomdp
from tests.synthesis.test_belief_grid import _problem


@settings(max_examples=200, deadline=None)
@given(weights=st.lists(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=6),
                        min_size=1, max_size=4),
       simple=st.booleans())
def test_a_randomised_rule_is_read_as_an_exact_rule(weights: list[list[float]],
                                                    simple: bool) -> None:
    """A randomised rule stored in floats (per state normalised by its float sum, as every rule
    offered is) stands for an exact rule (_rational_rule): per state its probabilities sum to 1
    exactly and each lies within (n + 4) u of its float, the bound the doubled rounding of
    entry_rounding covers; a rule of simple fractions (a grid rule's, denominators up to
    1000) is read as those fractions themselves."""
    probs: list[float] = []
    states: list[int] = []
    exact: list[Fraction] = []
    for s, w in enumerate(weights):
        if simple:
            q = [Fraction(round(x * 40) + 1, 1) for x in w]
            total = sum(q, Fraction(0))
            exact.extend(x / total for x in q)  # denominators at most 6 * 41
            row = np.asarray([float(x / total) for x in q])
        else:
            row = np.asarray(w) + 1e-3
            row = row / row.sum()
        probs.extend(row.tolist())
        states.extend([s] * len(w))
    rule = belief_exact._rational_rule(probs, states)
    u = Fraction(2) ** -53
    for s, w in enumerate(weights):
        mine = [q for q, t in zip(rule, states) if t == s]
        assert sum(mine, Fraction(0)) == 1
        for q, x in zip(mine, [x for x, t in zip(probs, states) if t == s]):
            assert abs(q - Fraction(x)) <= (len(w) + 4) * u * q
    if simple:
        assert rule == exact


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), deterministic=st.booleans())
def test_the_exact_rows_are_the_rational_successor_vectors(seed: int,
                                                           deterministic: bool) -> None:
    """exact_rows (the exact re-triangulation's input, batched over rows) gives each row's
    continuing vector Σ_k B_rk T*_k up to one positive factor, T* the stored rows scaled to
    sum to 1, checked against Fractions on random POMDPs: with stored weights counts/N (no
    rule), and as a deterministic adversary rule's masses (rule 1 everywhere, mass = B)."""
    model = random_pomdp(seed)
    problem = _problem(model, 'Pmax=? [ F "goal" ]')
    dyn = belief_dynamics.Dynamics(problem, None)
    rng = np.random.default_rng(seed)
    choice_of = dyn.choice_of[0]
    live = np.flatnonzero(choice_of >= 0)
    if live.size == 0:
        return
    N, R = 8, 5
    dense = np.zeros((R, model.num_states))
    for r in range(R - 1):  # the last row empty
        on = rng.choice(live, min(live.size, int(rng.integers(1, 4))), replace=False)
        dense[r, on] = rng.integers(1, N + 1, on.size) / N
    B = sp.csr_matrix(dense)
    source = belief_exact.Source(B, choice_of) if not deterministic else belief_exact.Source(
        B, choice_of, mass=B, rule=sp.csr_matrix((np.ones(B.nnz), B.indices, B.indptr),
                                                 shape=B.shape))
    rows = np.arange(R, dtype=np.int64)
    got = belief_exact.exact_rows(source, rows, dyn)
    assert sorted(got) == rows.tolist()
    assert got[R - 1] == {}
    T = model.transitions
    for r in range(R - 1):
        want: dict[int, Fraction] = {}
        for k in np.flatnonzero(dense[r]).tolist():
            c = int(choice_of[k])
            data = T.data[T.indptr[c]:T.indptr[c + 1]].tolist()
            total = sum((Fraction(p) for p in data), Fraction(0))
            for t, p in zip(T.indices[T.indptr[c]:T.indptr[c + 1]].tolist(), data):
                want[t] = want.get(t, Fraction(0)) + Fraction(dense[r, k]) * Fraction(p) / total
        y = {s: n for s, n in got[r].items() if n}
        assert set(y) == {s for s, q in want.items() if q}
        scale = Fraction(sum(y.values())) / sum(want.values(), Fraction(0))
        assert scale > 0
        assert all(Fraction(n) == scale * want[s] for s, n in y.items())
