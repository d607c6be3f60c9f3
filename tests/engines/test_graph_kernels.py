"""The compiled graph analysis (posgmc/engines/kernels/graph.py) against the numpy path and
against brute force: the transposed pattern, attractors (one player, two players, restricted
choices, extra hitting choices, layers, witnesses), Prob0 (``positive_reach``) and Prob1
(``almost_sure_reach``).

The expected sets of the hand-made models are derived by hand in each test's docstring; the
random models are checked against a definitional fixpoint written here with Python sets, and on
small models against the values of every memoryless deterministic profile (they suffice for
reachability in turn-based stochastic games, Condon 1992)."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import kernels, scc
from posgmc.engines.graph import (
    Structure,
    almost_sure_reach,
    attractor,
    leaving_choices,
    positive_reach,
)
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType
from tests.engines.engine_models import chain_reach, small_models

needs_numba = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")

PATHS = [pytest.param(True, id="compiled", marks=needs_numba), pytest.param(False, id="numpy")]


@pytest.fixture(params=PATHS)
def path(request: pytest.FixtureRequest) -> Iterator[bool]:
    """Run the test once with the compiled kernels, once with the numpy path."""
    before, size = kernels.STATE.use, scc.COMPILED_MIN_SIZE
    kernels.STATE.use = bool(request.param)
    scc.COMPILED_MIN_SIZE = 0  # the compiled path on these small models too
    try:
        yield bool(request.param)
    finally:
        kernels.STATE.use, scc.COMPILED_MIN_SIZE = before, size


def _on_both(fn: Callable[[], Any]) -> tuple[Any, Any]:
    """``fn()`` with the kernels (when numba is there) and with the numpy path."""
    before, size = kernels.STATE.use, scc.COMPILED_MIN_SIZE
    try:
        kernels.STATE.use = kernels.available()
        scc.COMPILED_MIN_SIZE = 0  # the compiled path on these small models too
        compiled = fn()
        kernels.STATE.use = False
        fallback = fn()
    finally:
        kernels.STATE.use, scc.COMPILED_MIN_SIZE = before, size
    return compiled, fallback


def _mdp(rows: list[list[float]], groups: list[int]) -> ExplicitModel:
    return make_model(ModelType.MDP, groups, np.array(rows, dtype=float))


def _structure(m: ExplicitModel) -> Structure:
    """A fresh structure (not the per-model cache) built by the current path."""
    return Structure.build(m.transitions, m.row_groups)


def _bools(data: st.DataObject, n: int) -> np.ndarray:
    return np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)


# ---------------------------------------------------------------------------------------------
# brute-force references, straight from the definitions
# ---------------------------------------------------------------------------------------------


def _succ(m: ExplicitModel) -> list[set[int]]:
    T = m.transitions.tocoo()
    out: list[set[int]] = [set() for _ in range(m.num_choices)]
    for c, t in zip(T.row.tolist(), T.col.tolist()):
        out[c].add(t)
    return out


def _choices(m: ExplicitModel, s: int) -> range:
    return range(int(m.row_groups[s]), int(m.row_groups[s + 1]))


def _attractor_fixpoint(
    m: ExplicitModel,
    initial: np.ndarray,
    existential: np.ndarray,
    candidates: np.ndarray,
    allowed: np.ndarray | None = None,
    initial_choices: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The attractor by rounds: in round k a candidate joins when one (existential) or every
    (universal, at least one) allowed choice hits the set of round k - 1 or is an initial choice.
    Returns the set and the round of joining (0 for ``initial``, -1 outside)."""
    succ = _succ(m)
    ok = np.ones(m.num_choices, bool) if allowed is None else allowed
    extra = np.zeros(m.num_choices, bool) if initial_choices is None else initial_choices
    inside = initial.copy()
    layer = np.where(initial, 0, -1)
    k = 0
    while True:
        k += 1
        hits = [bool(extra[c]) or any(inside[t] for t in succ[c]) for c in range(m.num_choices)]
        new = []
        for s in range(m.num_states):
            if inside[s] or not candidates[s]:
                continue
            mine = [c for c in _choices(m, s) if ok[c]]
            if not mine:
                continue
            join = any(hits[c] for c in mine) if existential[s] else all(hits[c] for c in mine)
            if join:
                new.append(s)
        if not new:
            return inside, layer
        inside[new] = True
        layer[new] = k


def _almost_sure_fixpoint(
    m: ExplicitModel, target: np.ndarray, remain: np.ndarray, existential: np.ndarray
) -> np.ndarray:
    """``nu Y. mu X. target | (remain & CPre(Y, X))``: an existential state needs a choice that
    stays in Y and hits X, a universal one needs every choice to stay in Y and hit X."""
    succ = _succ(m)
    S = m.num_states
    Y = np.ones(S, bool)
    while True:
        X = target.copy()
        while True:
            good = [succ[c] <= set(np.flatnonzero(Y)) and any(X[t] for t in succ[c])
                    for c in range(m.num_choices)]
            stay = [succ[c] <= set(np.flatnonzero(Y)) for c in range(m.num_choices)]
            nxt = X.copy()
            for s in range(S):
                if X[s] or not remain[s]:
                    continue
                mine = list(_choices(m, s))
                if existential[s]:
                    nxt[s] = any(good[c] for c in mine)
                else:
                    nxt[s] = all(stay[c] and good[c] for c in mine)
            if (nxt == X).all():
                break
            X = nxt
        if (X == Y).all():
            return X
        Y = X


def _game_values(m: ExplicitModel, target: np.ndarray, existential: np.ndarray) -> np.ndarray:
    """max over the existential player's memoryless deterministic strategies of the min over the
    other player's of the reach probability (``F target``), per state."""
    S = m.num_states
    rg = m.row_groups
    own = [range(int(rg[s]), int(rg[s + 1])) for s in range(S)]
    one = [range(int(rg[s]), int(rg[s]) + 1) for s in range(S)]
    mine = [own[s] if existential[s] else one[s] for s in range(S)]
    theirs = [one[s] if existential[s] else own[s] for s in range(S)]
    best = np.full(S, -1.0)
    for a in itertools.product(*mine):
        worst = np.full(S, 2.0)
        for b in itertools.product(*theirs):
            rows = np.array([a[s] if existential[s] else b[s] for s in range(S)], dtype=np.int64)
            worst = np.minimum(worst, chain_reach(m, rows, target))
        best = np.maximum(best, worst)
    return best


def _num_profiles(m: ExplicitModel) -> int:
    return int(np.prod(np.diff(m.row_groups)))


# ---------------------------------------------------------------------------------------------
# hand-made models with end components
# ---------------------------------------------------------------------------------------------


def _two_end_components() -> ExplicitModel:
    """s0 (two choices): a -> s1, b -> 1/2 s2 + 1/2 s4; s1: a -> s0, b -> s4 (goal);
    s2 <-> s3 (an end component without the goal: s2 a -> s3, s3 a -> s2, s3 b -> 1/2 s3 +
    1/2 s5); s4 goal (loop); s5 trap (loop). States 0..5, choices 0..8."""
    return _mdp(
        [
            [0, 1, 0, 0, 0, 0],  # 0: s0 a
            [0, 0, 0.5, 0, 0.5, 0],  # 1: s0 b
            [1, 0, 0, 0, 0, 0],  # 2: s1 a
            [0, 0, 0, 0, 1, 0],  # 3: s1 b
            [0, 0, 0, 1, 0, 0],  # 4: s2 a
            [0, 0, 1, 0, 0, 0],  # 5: s3 a
            [0, 0, 0, 0.5, 0, 0.5],  # 6: s3 b
            [0, 0, 0, 0, 1, 0],  # 7: s4 loop
            [0, 0, 0, 0, 0, 1],  # 8: s5 loop
        ],
        [0, 2, 4, 5, 7, 8, 9],
    )


def test_hand_made_mdp_with_end_components(path: bool) -> None:
    """Pmax(F s4): s0 (b) and s1 (b) have an edge into s4 (layer 1); s2 and s3 only move inside
    {s2, s3, s5}: positive region {s0, s1, s4}. Almost surely: s0's b leaves the region with 1/2,
    so s0 must take a to s1, whose b enters s4: region {s0, s1, s4}, witnesses s1 b (3), s0 a (0).
    Pmin(F s4): the end component {s0, s1} (choices a, a) avoids s4 forever, so no state joins the
    universal attractor: positive and almost-sure regions {s4}. The transposed pattern lists, per
    state, the choices with an edge into it."""
    m = _two_end_components()
    g = _structure(m)
    goal = np.zeros(6, bool)
    goal[4] = True
    everywhere = np.ones(6, bool)
    layer = np.full(6, -1, dtype=np.int64)
    pos = positive_reach(g, goal, everywhere, existential=everywhere, layer=layer)
    assert np.flatnonzero(pos).tolist() == [0, 1, 4]
    assert layer.tolist() == [1, 1, -1, -1, 0, -1]
    one, witness = almost_sure_reach(g, goal, everywhere, existential=everywhere)
    assert np.flatnonzero(one).tolist() == [0, 1, 4]
    assert witness[1] == 3 and witness[0] == 0  # s1 b; s0 a (b leaves the region with 1/2)
    nobody = np.zeros(6, bool)
    assert np.flatnonzero(positive_reach(g, goal, everywhere, existential=nobody)).tolist() == [4]
    one_min, _ = almost_sure_reach(g, goal, everywhere, existential=nobody)
    assert np.flatnonzero(one_min).tolist() == [4]
    assert g.back_ptr.tolist() == [0, 1, 2, 4, 6, 9, 11]
    assert g.back_choices.tolist() == [2, 0, 1, 5, 4, 6, 1, 3, 7, 6, 8]


def _smg_with_traps() -> ExplicitModel:
    """A turn-based game: p0 owns s0, s2; p1 owns s1, s3.
    s0: a -> s1, b -> s3;  s1: a -> s4 (goal), b -> s0;  s2: a -> 1/2 s4 + 1/2 s2;
    s3: a -> s2, b -> s3 (a self-loop end component);  s4: goal loop.
    States 0..4, choices 0..8."""
    T = np.zeros((8, 5))
    T[0, 1] = T[1, 3] = T[2, 4] = T[3, 0] = 1.0  # s0 a, s0 b, s1 a, s1 b
    T[4, 4] = T[4, 2] = 0.5  # s2 a
    T[5, 2] = T[6, 3] = T[7, 4] = 1.0  # s3 a, s3 b, s4 loop
    return make_model(
        ModelType.SMG,
        [0, 2, 4, 5, 7, 8],
        T,
        state_players=[0, 1, 0, 1, 0],
        player_names=("p0", "p1"),
    )


def test_hand_made_game(path: bool) -> None:
    """p0 reaching s4: s2 reaches it almost surely (1/2 per round); from s0 both choices lead to
    p1's states, and p1 can bounce from s1 back to s0 (b) or loop at s3 (b) forever: positive and
    almost-sure regions {s2, s4}. p1 reaching: s1 (a) and s2 (its only choice) in layer 1, s3 (a
    into s2) in layer 2, s0 (both choices inside) in layer 3; s2's loop leaves with 1/2 each
    round, so every state reaches almost surely, p1 by a at s1 (choice 2) and at s3 (5)."""
    m = _smg_with_traps()
    g = _structure(m)
    goal = np.zeros(5, bool)
    goal[4] = True
    everywhere = np.ones(5, bool)
    p0 = np.array([True, False, True, False, True])
    assert np.flatnonzero(positive_reach(g, goal, everywhere, existential=p0)).tolist() == [2, 4]
    one, _ = almost_sure_reach(g, goal, everywhere, existential=p0)
    assert np.flatnonzero(one).tolist() == [2, 4]
    assert positive_reach(g, goal, everywhere, existential=~p0).all()
    one, witness = almost_sure_reach(g, goal, everywhere, existential=~p0)
    assert one.all()
    assert witness[1] == 2 and witness[3] == 5  # p1's a at s1, a at s3


def test_attractor_with_allowed_and_extra_choices(path: bool) -> None:
    """On the end-component mdp: the universal attractor of {s4} with s0's b and s1's a
    forbidden: s1 joins (only b, into s4), then s0 (only a, into s1). From nothing, with the extra
    choice 6 (s3 b) counting as a hit: s3 joins in layer 1, s2 (a into s3) in layer 2, s0 (b into
    s2) in layer 3, s1 (a into s0) in layer 4."""
    m = _two_end_components()
    g = _structure(m)
    goal = np.zeros(6, bool)
    goal[4] = True
    everywhere = np.ones(6, bool)
    allowed = np.ones(9, bool)
    allowed[[1, 2]] = False
    inside, witness = attractor(
        g, goal, existential=np.zeros(6, bool), candidates=everywhere, allowed=allowed
    )
    assert np.flatnonzero(inside).tolist() == [0, 1, 4]
    assert witness[1] == 3 and witness[0] == 0
    extra = np.zeros(9, bool)
    extra[6] = True
    layer = np.full(6, -1, dtype=np.int64)
    inside, witness = attractor(
        g, np.zeros(6, bool), existential=everywhere, candidates=everywhere,
        initial_choices=extra, layer=layer,
    )
    assert np.flatnonzero(inside).tolist() == [0, 1, 2, 3]
    assert layer.tolist() == [3, 4, 2, 1, -1, -1]
    assert witness.tolist() == [1, 2, 4, 6, -1, -1]


def test_preferred_witness_is_kept_when_it_hits_in_the_joining_layer(path: bool) -> None:
    """s0 has two choices into the goal s1; either may be the witness, the preferred one wins."""
    m = _mdp([[0, 1], [0, 1], [0, 1]], [0, 2, 3])
    g = _structure(m)
    goal = np.array([False, True])
    for pref in (0, 1):
        _, witness = attractor(
            g, goal, existential=np.ones(2, bool), candidates=np.ones(2, bool),
            preferred=np.array([pref, -1]),
        )
        assert witness[0] == pref


def test_nobody_to_join_returns_the_initial_set(path: bool) -> None:
    m = _two_end_components()
    g = _structure(m)
    start = np.array([True, False, True, False, False, False])
    inside, witness = attractor(g, start, existential=np.ones(6, bool), candidates=start)
    assert inside.tolist() == start.tolist() and (witness == -1).all()


def test_leaving_choices(path: bool) -> None:
    """Choices with an edge out of {s0, s1, s4}: s0 b (to s2), every choice of s2, s3 (their
    successors are outside), s5's loop."""
    m = _two_end_components()
    g = _structure(m)
    region = np.array([True, True, False, False, True, False])
    assert np.flatnonzero(leaving_choices(g, region)).tolist() == [1, 4, 5, 6, 8]


# ---------------------------------------------------------------------------------------------
# random models: compiled == numpy == brute force
# ---------------------------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(model=small_models(max_states=7), data=st.data())
def test_transposed_pattern_is_scipys(model: ExplicitModel, data: st.DataObject) -> None:
    a, b = _on_both(lambda: _structure(model))
    csc = sp.csr_matrix(model.transitions, copy=True).tocsc()
    csc.sort_indices()
    for g in (a, b):
        assert g.back_ptr.tolist() == csc.indptr.tolist()
        assert g.back_choices.tolist() == csc.indices.tolist()
        assert g.choice_state.tolist() == model.choice_states.tolist()


@settings(max_examples=400, deadline=None)
@given(model=small_models(max_states=7), data=st.data())
def test_attractor_random(model: ExplicitModel, data: st.DataObject) -> None:
    S, C = model.num_states, model.num_choices
    initial = _bools(data, S)
    existential = _bools(data, S)
    candidates = _bools(data, S)
    allowed = _bools(data, C) if data.draw(st.booleans()) else None
    extra = _bools(data, C) if data.draw(st.booleans()) else None
    expected, expected_layer = _attractor_fixpoint(
        model, initial, existential, candidates, allowed, extra
    )

    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        layer = np.full(S, -1, dtype=np.int64)
        inside, witness = attractor(
            _structure(model), initial, existential=existential, candidates=candidates,
            allowed=allowed, initial_choices=extra, layer=layer,
        )
        return inside, witness, layer

    (a, wa, la), (b, wb, lb) = _on_both(run)
    assert a.tolist() == b.tolist() == expected.tolist()
    assert la.tolist() == lb.tolist() == expected_layer.tolist()
    succ = _succ(model)
    for witness, layer in ((wa, la), (wb, lb)):
        for s in range(S):
            if not expected[s] or initial[s]:
                assert witness[s] == -1
                continue
            c = int(witness[s])
            # a choice of s, allowed, that hit the set of the previous layer (or was extra)
            assert c in _choices(model, s)
            assert allowed is None or allowed[c]
            assert (extra is not None and extra[c]) or any(
                0 <= layer[t] < layer[s] for t in succ[c]
            )


@settings(max_examples=300, deadline=None)
@given(model=small_models(max_states=6), data=st.data())
def test_prob0_prob1_random(model: ExplicitModel, data: st.DataObject) -> None:
    """positive_reach and almost_sure_reach equal the definitional fixpoints on both paths, and
    (with few profiles) the game values' zero and one sets."""
    S = model.num_states
    target = _bools(data, S)
    remain = np.ones(S, bool) if data.draw(st.booleans()) else _bools(data, S)
    if model.model_type is ModelType.SMG:
        existential = model.state_players == 0
    else:
        existential = np.ones(S, bool) if data.draw(st.booleans()) else np.zeros(S, bool)

    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        g = _structure(model)
        pos = positive_reach(g, target, remain, existential=existential)
        one, witness = almost_sure_reach(g, target, remain, existential=existential)
        one_start, _ = almost_sure_reach(g, target, remain, existential=existential, start=pos)
        return pos, one, one_start, witness

    (pa, oa, sa, wa), (pb, ob, sb, wb) = _on_both(run)
    pos_expected, _ = _attractor_fixpoint(model, target, existential, remain & ~target)
    one_expected = _almost_sure_fixpoint(model, target, remain, existential)
    assert pa.tolist() == pb.tolist() == pos_expected.tolist()
    assert oa.tolist() == ob.tolist() == sa.tolist() == sb.tolist() == one_expected.tolist()
    for witness in (wa, wb):
        inner = one_expected & existential & ~target
        assert np.all(witness[inner] >= 0)
    if remain.all() and _num_profiles(model) <= 256:
        values = _game_values(model, target, existential)
        assert pos_expected.tolist() == (values > 1e-12).tolist()
        assert one_expected.tolist() == (values > 1 - 1e-9).tolist()


def _safe_fixpoint(
    m: ExplicitModel,
    region: np.ndarray,
    existential: np.ndarray,
    good: np.ndarray,
    frozen: np.ndarray,
) -> np.ndarray:
    """The greatest fixpoint by rounds: an existential state stays with one good choice whose
    successors all stay, a universal one when every choice is good and stays; frozen states
    always stay."""
    succ = _succ(m)
    current = region | frozen
    while True:
        stays = [bool(good[c]) and all(current[t] for t in succ[c]) for c in range(m.num_choices)]
        keep = current.copy()
        for s in np.flatnonzero(current & ~frozen):
            mine = [stays[c] for c in _choices(m, int(s))]
            keep[s] = any(mine) if existential[s] else all(mine)
        if (keep == current).all():
            return current
        current = keep


@settings(max_examples=300, deadline=None)
@given(model=small_models(max_states=7), data=st.data())
def test_safe_region_random(model: ExplicitModel, data: st.DataObject) -> None:
    """safe_region (one attractor of the other player) equals the round-by-round fixpoint, and
    its choices keep the play inside."""
    from posgmc.engines.graph import safe_region

    S, C = model.num_states, model.num_choices
    region = _bools(data, S)
    existential = _bools(data, S)
    good = _bools(data, C)
    frozen = _bools(data, S) if data.draw(st.booleans()) else np.zeros(S, bool)
    expected = _safe_fixpoint(model, region, existential, good, frozen)
    (a, ca), (b, cb) = _on_both(
        lambda: safe_region(
            _structure(model), region, existential=existential, good=good, frozen=frozen
        )
    )
    assert a.tolist() == b.tolist() == expected.tolist()
    assert ca.tolist() == cb.tolist()
    succ = _succ(model)
    for s in range(S):
        if expected[s] and existential[s] and not frozen[s]:
            c = int(ca[s])
            assert c in _choices(model, s) and good[c] and all(expected[t] for t in succ[c])
        else:
            assert ca[s] == -1


@needs_numba
def test_the_warm_up_loads_the_variants_that_a_check_uses() -> None:
    """After the background warm-up, a check's graph analysis on a built model calls no kernel
    with argument types the warm-up did not load (each new variant costs a compilation or a
    cache load inside the check)."""
    from posgmc.engines import graph as gr
    from posgmc.engines.kernels import graph as gk

    before_use, size = kernels.STATE.use, scc.COMPILED_MIN_SIZE
    kernels.STATE.use = True
    scc.COMPILED_MIN_SIZE = 0
    try:
        kernels.warm_up_in_background()
        thread = kernels._WARM_UP.thread
        if thread is not None:
            thread.join()
        gr._warm_up()  # (the thread may have run before this test switched the kernels on)
        loaded = {name: list(getattr(gk, name)._compiled.signatures) for name in gk.__all__}
        m = _smg_with_traps()
        g = _structure(m)
        goal = np.zeros(5, bool)
        goal[4] = True
        everywhere = np.ones(5, bool)
        p0 = m.state_players == 0
        layer = np.full(5, -1, dtype=np.int64)
        pos = positive_reach(g, goal, everywhere, existential=p0, layer=layer)
        almost_sure_reach(g, goal, everywhere, existential=p0, start=pos)
        almost_sure_reach(g, goal, everywhere, existential=~p0)
        leaving_choices(g, pos)
        after = {name: list(getattr(gk, name)._compiled.signatures) for name in gk.__all__}
        assert after == loaded
    finally:
        kernels.STATE.use, scc.COMPILED_MIN_SIZE = before_use, size
