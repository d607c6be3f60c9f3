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

from posgmc.engines import kernels, scc
from posgmc.engines import objectives as obj
from posgmc.engines import topological as topo
from posgmc.engines.graph import structure_of
from posgmc.engines.iteration import EndComponents
from posgmc.engines.options import SolverOptions
from posgmc.engines.system import build_system
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import as_floats, chain_reward, game_value, layered_models

TOL = 1e-9


class Forced(list[int]):
    """The topological solves that finished (the number of bands of each), and ``compiled``: those
    that took the compiled component-by-component path."""

    def __init__(self) -> None:
        super().__init__()
        self.compiled: list[int] = []


@pytest.fixture(params=["compiled", "numpy"])
def forced(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Forced:
    """Every system with two or more SCCs laid out topologically, one SCC per band, solved by the
    compiled kernels or by the numpy path (the fixture's parameter); returns a :class:`Forced`
    that counts the topological solves that finished (so a test knows the path ran)."""
    if request.param == "compiled" and not kernels.available():
        pytest.skip("numba is not installed")
    monkeypatch.setattr(kernels.STATE, "use", request.param == "compiled")
    monkeypatch.setattr(scc, "MIN_BAND_STATES", 1)
    monkeypatch.setattr(scc, "DEFAULT_BANDS", 10**9)
    monkeypatch.setattr(scc, "MAX_GIANT_SHARE", 1.0)
    monkeypatch.setattr(scc, "COMPILED_MIN_SIZE", 0)
    calls = Forced()
    original = topo.solve_topological
    original_compiled = topo._solve_components

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        out = original(*args, **kwargs)
        if out is not None:
            calls.append(int(args[0].bands.size - 1))
        return out

    def counting_compiled(*args, **kwargs):  # type: ignore[no-untyped-def]
        out = original_compiled(*args, **kwargs)
        if out is not None:
            calls.compiled.append(int(args[0].bands.size - 1))
        return out

    import posgmc.engines.solving as common

    monkeypatch.setattr(common, "solve_topological", counting)
    monkeypatch.setattr(topo, "_solve_components", counting_compiled)
    return calls


def _path_ran(forced: Forced, *, compiled_applies: bool = True) -> None:
    """The compiled path solved the systems exactly when the kernels are on (and apply)."""
    if kernels.enabled() and compiled_applies:
        assert forced.compiled == list(forced), "the compiled path did not run"
    else:
        assert forced.compiled == []


def _maximize(model: ExplicitModel, flip: bool) -> np.ndarray:
    if model.model_type is ModelType.SMG:
        return (model.state_players == 0) ^ flip
    return np.full(model.num_states, flip)


SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def test_random_reach_bounds_enclose_exact_rationals(forced: Forced) -> None:
    # derandomized for the same reason as the reward test below: the coverage counts at the end
    # depend on the draw (the topological path ran 9 times in one run, under the bar of 10)
    @settings(SETTINGS, derandomize=True)
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
    # the compiled path covers the one-player systems and games without end-component treatment
    assert (len(forced.compiled) >= 5) == kernels.enabled(), "the compiled path rarely ran"


def test_random_reward_bounds_enclose_brute_force(forced: Forced) -> None:
    # derandomized: the compiled path applies to few reward systems (no inflation, one player), so
    # the count below varied with the draw and fell under 5 in some runs (3 in one of six runs
    # seen); a fixed draw keeps the check of that coverage reproducible
    @settings(SETTINGS, derandomize=True)
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
        assert np.all(res.lower[fin] <= ref[fin] + 1e-7) and np.all(
            ref[fin] <= res.upper[fin] + 1e-7
        )
        assert np.all(res.upper[fin] - res.lower[fin] <= 2e-6 + 1e-9)

    check()
    assert len(forced) >= 10, "the topological path rarely ran"
    # the compiled path covers the one-player systems and games without end-component treatment
    assert (len(forced.compiled) >= 5) == kernels.enabled(), "the compiled path rarely ran"


# ---------------------------------------------------------------------------------------------
# each path on a hand-built model (exact values derived in the comments, checked against the
# exact rational solver as well)
# ---------------------------------------------------------------------------------------------


def _mdp(rows: list[list[float]], counts: list[int], mtype: ModelType = ModelType.MDP,
         players: list[int] | None = None) -> ExplicitModel:
    return make_model(
        mtype,
        np.concatenate([[0], np.cumsum(counts)]),
        np.array(rows, dtype=float),
        state_players=players,
        player_names=("p0", "p1") if players is not None else (),
    )


def test_trivial_sccs_are_solved_in_closed_form(forced: Forced) -> None:
    """s0 -> {s0: 1/2, s1: 1/4, sink: 1/4}; s1 -> {s1: 1/4, goal: 1/2, sink: 1/4}; goal = 2,
    sink = 3. Eliminating the self-loops: x1 = (1/2) / (1 - 1/4) = 2/3 and
    x0 = (1/4 * 2/3) / (1 - 1/2) = 1/3 (hand derivation). Two trivial SCCs, one band each; after
    the elimination every band row is a constant (no matrix entries left), so one Bellman step
    gives the exact value."""
    rows = [[0.5, 0.25, 0, 0.25], [0, 0.25, 0.5, 0.25], [0, 0, 1, 0], [0, 0, 0, 1]]
    model = _mdp(rows, [1, 1, 1, 1])
    assert model.num_states == 4 and model.num_choices == 4
    g = structure_of(model)
    unknown = np.array([True, True, False, False])
    goal = np.array([False, False, True, False])
    sys = build_system(
        g, unknown, maximize=np.ones(4, bool), fixed=goal.astype(float), topological=True
    )
    assert sys.bands is not None and sys.bands.tolist() == [0, 1, 2]
    assert sys.states.tolist() == [1, 0]  # s1 (the sink side) is solved first
    lower = np.zeros(2)
    upper = np.ones(2)
    solved = np.zeros(2, dtype=bool)
    band0, _ = topo._band(sys, sys.plan, 0, 1, lower, upper, solved)
    assert band0.matrix.nnz == 0 and band0.offset.tolist() == [2 / 3]
    res = topo.solve_topological(sys, SolverOptions(), cap=1.0, ec=EndComponents.DEFLATE)
    assert res is not None and res.converged and res.sound
    exact = [Fraction(2, 3), Fraction(1, 3)]
    assert exact == obj.exact_rational_reach(model, goal, maximize=np.ones(4, bool))[1::-1]
    assert np.all(res.lower <= as_floats(exact) + TOL)
    assert np.all(as_floats(exact) <= res.upper + TOL)
    assert np.all(res.upper - res.lower <= 2e-6)
    assert res.iterations <= 2 * 3  # per band: one step to the value, one guess, one check


def test_small_sccs_in_order(forced: Forced) -> None:
    """Two 2-state SCCs: {a0, a1} (a0 -> a1 w.p. 1/2 or to {b0} w.p. 1/2; a1 -> a0 w.p. 1/2,
    sink w.p. 1/2) above {b0, b1} (b0 -> b1 w.p. 1/2, goal w.p. 1/4, sink w.p. 1/4;
    b1 -> b0 w.p. 3/4, sink w.p. 1/4). Hand derivation: b0 = 1/2 b1 + 1/4, b1 = 3/4 b0, so
    b0 = 1/4 / (1 - 3/8) = 2/5, b1 = 3/10; a0 = 1/2 a1 + 1/2 b0, a1 = 1/2 a0, so
    a0 = (1/5) / (3/4) = 4/15, a1 = 2/15. States: a0, a1, b0, b1, goal, sink."""
    rows = [
        [0, 0.5, 0.5, 0, 0, 0],
        [0.5, 0, 0, 0, 0, 0.5],
        [0, 0, 0, 0.5, 0.25, 0.25],
        [0, 0, 0.75, 0, 0, 0.25],
        [0, 0, 0, 0, 1, 0],
        [0, 0, 0, 0, 0, 1],
    ]
    model = _mdp(rows, [1] * 6, ModelType.DTMC)
    goal = np.zeros(6, bool)
    goal[4] = True
    exact = obj.exact_rational_reach(model, goal, maximize=np.ones(6, bool))
    assert exact[:4] == [Fraction(4, 15), Fraction(2, 15), Fraction(2, 5), Fraction(3, 10)]
    res = obj.reach_probability(model, goal, maximize=np.ones(6, bool))
    assert forced == [2]  # one topological solve, two bands
    _path_ran(forced)
    assert np.all(res.lower <= as_floats(exact) + TOL) and np.all(
        as_floats(exact) <= res.upper + TOL
    )
    assert np.all(res.upper - res.lower <= 2e-6 + TOL)


def test_giant_scc_band_uses_the_interval_solver_with_end_components(forced: Forced) -> None:
    """A trivial state t above a 5-state ring r0..r4 of an mdp: every ring state may move on
    (r_i -> r_{i+1}, an end component for the maximiser) or gamble (1/2 goal, 1/2 sink); only r4
    may also go to goal w.p. 3/4 and sink w.p. 1/4. Hand derivation: the maximiser walks to r4 and
    takes the 3/4 choice, so every ring state is worth 3/4, and t -> {r0: 1/2, sink: 1/2} is worth
    3/8. The ring is one band (the deflation argument of the interval solver proves its upper
    bound), t the next. States: r0..r4 = 0..4, t = 5, goal = 6, sink = 7."""
    rows, counts = [], []
    for i in range(5):
        nxt = np.zeros(8)
        nxt[(i + 1) % 5] = 1
        gamble = np.zeros(8)
        gamble[6] = gamble[7] = 0.5
        rows += [nxt, gamble]
        counts.append(2)
    special = np.zeros(8)
    special[6], special[7] = 0.75, 0.25
    rows.append(special)
    counts[4] += 1
    t = np.zeros(8)
    t[0] = t[7] = 0.5
    for r in (t, np.eye(8)[6], np.eye(8)[7]):
        rows.append(r)
        counts.append(1)
    model = _mdp([list(r) for r in rows], counts)
    assert model.num_states == 8 and model.num_choices == 14
    goal = np.zeros(8, bool)
    goal[6] = True
    exact = obj.exact_rational_reach(model, goal, maximize=np.ones(8, bool))
    assert exact[:6] == [Fraction(3, 4)] * 5 + [Fraction(3, 8)]
    res = obj.reach_probability(model, goal, maximize=np.ones(8, bool))
    assert forced == [2]
    _path_ran(forced)
    assert np.all(res.lower <= as_floats(exact) + TOL) and np.all(
        as_floats(exact) <= res.upper + TOL
    )
    assert np.all(res.upper - res.lower <= 2e-6 + TOL)
    # the strategy still leaves the end component (attractor fix): the ring reaches goal
    assert res.strategy is not None and res.strategy[4] == 10


def test_game_sccs_in_order(forced: Forced) -> None:
    """A game of three trivial SCCs, one band each. The maximiser's x (player 0) either loops
    (x w.p. 1/2, goal 1/4, sink 1/4) or gambles (goal 1/4, sink 3/4): with the self-loop
    eliminated x = max((1/4) / (1 - 1/2), 1/4) = 1/2. The minimiser's n (player 1) moves to x or
    takes goal w.p. 1/3 (else sink): n = min(1/2, 1/3) = 1/3. The chance state c -> {n: 1/2,
    x: 1/2}: c = 1/2 (1/3 + 1/2) = 5/12 (hand derivation). States: c, n, x, goal, sink."""
    rows = [
        [0, 0.5, 0.5, 0, 0],  # c
        [0, 0, 1, 0, 0],  # n -> x
        [0, 0, 0, 1 / 3, 2 / 3],  # n -> goal 1/3
        [0, 0, 0.5, 0.25, 0.25],  # x loop
        [0, 0, 0, 0.25, 0.75],  # x gamble
        [0, 0, 0, 1, 0],
        [0, 0, 0, 0, 1],
    ]
    model = _mdp(rows, [1, 2, 2, 1, 1], ModelType.SMG, players=[0, 1, 0, 0, 0])
    goal = np.zeros(5, bool)
    goal[3] = True
    maximize = model.state_players == 0
    exact = obj.exact_rational_reach(model, goal, maximize=maximize)
    assert exact[:3] == [Fraction(5, 12), Fraction(1, 3), Fraction(1, 2)]
    res = obj.reach_probability(model, goal, maximize=maximize)
    assert forced == [3]
    _path_ran(forced, compiled_applies=False)  # a game's deflation stays with the band solver
    assert np.all(res.lower <= as_floats(exact) + TOL) and np.all(
        as_floats(exact) <= res.upper + TOL
    )
    assert np.all(res.upper - res.lower <= 2e-6 + TOL)


def test_a_band_reading_unsolved_states_is_refused(forced: Forced) -> None:
    """Soundness guard: band 1 of the small-SCC model read before band 0 is solved."""
    rows = [[0.5, 0.25, 0, 0.25], [0, 0.25, 0.5, 0.25], [0, 0, 1, 0], [0, 0, 0, 1]]
    model = _mdp(rows, [1, 1, 1, 1])
    sys = build_system(
        structure_of(model),
        np.array([True, True, False, False]),
        maximize=np.ones(4, bool),
        fixed=np.array([0, 0, 1.0, 0]),
        topological=True,
    )
    nothing = np.zeros(2, dtype=bool)
    assert topo._band(sys, sys.plan, 1, 2, np.zeros(2), np.ones(2), nothing) is None


def test_default_decision_on_a_long_chain_and_on_one_giant_scc() -> None:
    """Without forcing: a 40,000-state chain (every state its own SCC) is laid out in bands; a
    40,000-state ring (one SCC) keeps the backward-search layout. Chain: s_i -> s_{i+1} (the last
    one -> goal) w.p. 0.999, sink w.p. 0.001, so s_0 is worth 0.999^40000 (hand derivation)."""
    k = 40_000
    S = k + 2  # goal = k, sink = k + 1
    src = np.arange(k)
    nxt = np.where(src + 1 < k, src + 1, k)
    data = np.concatenate([np.full(k, 0.999), np.full(k, 0.001), [1.0, 1.0]])
    rows = np.concatenate([src, src, [k, k + 1]])
    cols = np.concatenate([nxt, np.full(k, k + 1), [k, k + 1]])
    import scipy.sparse as sps

    T = sps.csr_matrix((data, (rows, cols)), shape=(S, S))
    model = make_model(ModelType.MDP, np.arange(S + 1), T)
    goal = np.zeros(S, bool)
    goal[k] = True
    g = structure_of(model)
    unknown = np.zeros(S, bool)
    unknown[:k] = True
    layer = np.arange(k, -2, -1)
    sys = build_system(g, unknown, maximize=np.ones(S, bool), fixed=goal.astype(float),
                       layer=layer, topological=True)
    assert sys.bands is not None and sys.bands.size - 1 == 3  # 40,000 / max(1250, 16384)
    res = obj.reach_probability(model, goal, maximize=np.ones(S, bool))
    expected = 0.999 ** k  # s_0 survives k steps (hand derivation)
    assert res.lower[0] <= expected <= res.upper[0]
    # the ring: s_i -> s_{i+1 mod k} w.p. 0.999, goal w.p. 0.001
    cols = np.concatenate([(src + 1) % k, np.full(k, k), [k, k + 1]])
    ring = make_model(
        ModelType.MDP, np.arange(S + 1), sps.csr_matrix((data, (rows, cols)), shape=(S, S))
    )
    sys = build_system(structure_of(ring), unknown, maximize=np.ones(S, bool),
                       fixed=goal.astype(float), layer=layer, topological=True)
    assert sys.bands is None
