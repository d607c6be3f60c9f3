"""The belief-grid bound (posgmc.synthesis.belief_grid): the abstraction's bound is on the
optimistic side of every known POMDP optimum (hand-derived, Storm's completed belief unfolding)
and of every strategy's proven value on random POMDPs, and equals the optimum where the
reachable belief set is on the grid."""

from __future__ import annotations

import itertools
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.engines.options import SolverOptions
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.synthesis import belief, belief_dynamics, belief_exact, belief_grid, grid_certificate
from posgmc.synthesis.search import parametrisation, problem_of
from tests.random_games import random_pomdp, random_signed_pomdp
from tests.synthesis.helpers import BLIND, GUESS, SIGNED

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "benchmarks" / "pomdp"


def _problem(model, prop: str):  # type: ignore[no-untyped-def]
    coalition = api._resolver(model, False).coalition_of
    return problem_of(model, parser.parse_property(prop).expr, player=0, adversary=None,
                      coalition_of=coalition, scalar=api._scalar)


def _small_abstraction(problem, resolution: int):  # type: ignore[no-untyped-def]
    """The full-observation cut-off values and the grid abstraction of a random model's problem
    at ``resolution``, at most 200 vertices (None where the grid does not apply)."""
    cutoff = belief_grid.full_observation_bounds(problem)[0]
    return cutoff, belief_grid.grid_abstraction(problem, resolution, cutoff=cutoff,
                                                max_vertices=200)


def _built(path: Path | None = None, text: str | None = None, **constants: str):  # type: ignore[no-untyped-def]
    session = api.load(path, text=text, constants=constants or None)
    return api.build(session).model


@given(seed=st.integers(0, 10_000), n_parts=st.integers(1, 4), known=st.integers(0, 6))
def test_the_batched_lookup_numbers_vertices_as_one_call_per_reference(
        seed: int, n_parts: int, known: int) -> None:
    # the exploration looks vertices up in batches; it must find (and number) exactly what one
    # ``vertex`` call per reference in rank order does, or the explored grid would change
    rng = np.random.default_rng(seed)
    parts = []
    for _ in range(n_parts):
        r, m = int(rng.integers(1, 30)), int(rng.integers(1, 4))
        idx = np.sort(rng.choice(5, size=(r, m)), axis=1).astype(np.int64)
        counts = rng.integers(0, 3, size=(r, m)).astype(np.int64)  # zero counts are dropped
        counts[:, 0] += 1
        parts.append((idx, counts))
    total = sum(idx.shape[0] for idx, _ in parts)
    ranks = rng.permutation(total)
    one, batched = belief_grid._Grid(5, 4), belief_grid._Grid(5, 4)
    for g in (one, batched):  # some vertices known before the batch
        for j in range(known):
            g.vertex(np.array([j % 5], dtype=np.int64), np.array([4], dtype=np.int64))
    in_order: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    with_ranks, at = [], 0
    for idx, counts in parts:
        r = ranks[at:at + idx.shape[0]]
        with_ranks.append((r, idx, counts))
        in_order.update((int(k), (idx[i], counts[i])) for i, k in enumerate(r))
        at += idx.shape[0]
    expected = [one.vertex(*in_order[k]) for k in range(total)]
    assert batched.lookup(with_ranks, total).tolist() == expected
    assert one.key == batched.key
    assert all(np.array_equal(a, b) for a, b in zip(one.rows, batched.rows, strict=True))
    assert all(np.array_equal(a, b) for a, b in zip(one.vals, batched.vals, strict=True))


def _bound(problem, vertices: int = 20_000) -> belief_grid.GridBound:  # type: ignore[no-untyped-def]
    """The bound within a work budget (grid vertices), not a wall-clock one: what it proves
    depends on the model alone, however loaded the machine is."""
    found = belief_grid.grid_bound(problem, deadline=None, vertices=vertices)
    assert found is not None
    return found


def test_guessing_game_is_exact() -> None:
    """GUESS (tests/synthesis/helpers.py): the optimum is 1, derived by hand; its reachable
    beliefs ({s0}, {s1, s2} half each, {s3}, {s4}) are grid beliefs at N = 2, so the abstraction
    is the belief MDP itself and the bound is the optimum (up to the solver's precision); the
    belief unfolding that comes first finds the same four beliefs."""
    model = _built(text=GUESS)
    assert model.num_states == 7
    problem = _problem(model, 'Pmax=? [ F "goal" ]')
    found = belief_grid.grid_bound(problem, deadline=None, unfold=False)
    assert found is not None and found.exact and found.resolution == 2
    assert 1.0 <= found.value <= 1.0 + 1e-7
    unfolded = _bound(problem)
    assert unfolded.exact and unfolded.resolution == 0 and unfolded.vertices == 4
    assert 1.0 <= unfolded.value <= 1.0 + 1e-7


def test_blind_cost_is_bounded_below_by_its_optimum() -> None:
    """BLIND (tests/synthesis/test_synthesis.py): the optimum cost is 3/2, derived by hand."""
    model = _built(text=BLIND)
    assert model.num_states == 4
    found = _bound(_problem(model, 'R{"cost"}min=? [ F s=3 ]'))
    assert 1.5 - 1e-6 <= found.value <= 1.5


@pytest.mark.parametrize(("path", "prop", "optimum", "states"), [
    # models/tiger/README.md derives 2391/494 (Storm's unfolding agrees)
    (ROOT / "models/tiger/tiger.pomdp", 'R{"cost"}min=? [ F "opened" ]', 2391 / 494, 19),
    # models/trap_grid/README.md: (q^4 + q^6)/2 with q = 0.9
    (ROOT / "models/trap_grid/trap_grid.pomdp", 'Pmax=? [ F "goal" ]',
     (0.9 ** 4 + 0.9 ** 6) / 2, 25),
    # models/maze/maze.props: 4.3 (PRISM's RESULT; Storm's unfolding, completed)
    (ROOT / "models/maze/maze.pomdp", 'R{"steps"}min=? [ F "target" ]', 4.3, 12),
    # tests/data/README.md: Storm's completed unfolding
    (DATA / "nrp-8" / "sketch.templ", 'Pmax=? [ F "unfair" ]', 0.125, 125),
    (DATA / "crypt-4" / "sketch.templ", 'Pmax=? [ F correct=1 ]', 1 / 3, 1972),
])
def test_the_bound_holds_against_known_optima(path: Path, prop: str, optimum: float,
                                              states: int) -> None:
    model = _built(path)
    assert model.num_states == states
    problem = _problem(model, prop)
    found = _bound(problem)
    if problem.maximize:
        assert found.value >= optimum - 1e-9
        assert found.value <= belief_grid.full_observation_bounds(problem)[0][
            model.initial_states[0]] + 1e-9
    else:
        assert found.value <= optimum + 1e-9


@pytest.mark.parametrize(("name", "prop", "optimum", "states"), [
    # Storm 2.0's verify_with_belief_unfolding completes on both (the shared benchmarks'
    # RESULTS.md): the reachable belief MDPs are finite
    ("crypt-4", "Pmax=? [ F correct=1 ]", 1 / 3, 1972),
    ("nrp-8", 'Pmax=? [ F "unfair" ]', 0.125, 125),
])
def test_a_finite_belief_mdp_is_unfolded_to_its_optimum(name: str, prop: str, optimum: float,
                                                        states: int) -> None:
    """Where the reachable belief set is finite and fits the unfolding's share of the budget,
    the abstraction is the belief MDP itself: the bound is the optimum (no grid is needed),
    where the finest grid Storm reaches stays 0.002 (crypt-4) and 0.0008 (nrp-8) above."""
    model = _built(DATA / name / "sketch.templ")
    assert model.num_states == states
    found = belief_grid.grid_bound(_problem(model, prop), deadline=None, vertices=20_000)
    assert found is not None
    assert found.resolution == 0 and found.exact and found.complete
    assert found.vertices <= 20_000 * belief_grid.UNFOLD_SHARE
    assert optimum <= found.value <= optimum + 1e-7


def test_the_bound_tightens_with_the_resolution_on_tiger() -> None:
    """Tiger's belief is one number (the chance the tiger is left): the grid at N = 2^k has
    vertices every 2^-k, and the bound climbs to the optimum 2391/494 (the belief unfolding
    first, resolution 0, does not complete: tiger's reachable beliefs are infinitely many)."""
    model = _built(ROOT / "models/tiger/tiger.pomdp")
    found = _bound(_problem(model, 'R{"cost"}min=? [ F "opened" ]'))
    assert found.tried[0][0] == 0 and not found.exact
    values = [v for n, v in found.tried if n > 0]
    assert values[0] < values[-1] <= 2391 / 494
    assert 2391 / 494 - values[-1] <= 0.05


@pytest.mark.slow
def test_network_bound_holds() -> None:
    model = _built(DATA / "network-2-8-20" / "sketch.templ")
    assert model.num_states == 4589
    coalition = api._resolver(model, False).coalition_of
    text = 'R{"dropped_packets"}min=?[F sched=0 & t=8-1 & k=20-1 ]'
    problem = problem_of(model, parser.parse_property(text).expr, player=0, adversary=None,
                         coalition_of=coalition, scalar=api._scalar)
    found = _bound(problem, vertices=100_000)
    assert found.value <= 3.1989577412 + 1e-9


def _deterministic_memoryless(problem) -> list[FiniteStateStrategy]:  # type: ignore[no-untyped-def]
    """Every deterministic memoryless strategy of the POMDP (its actions per observation)."""
    par = parametrisation(problem, 1)
    options = [np.flatnonzero(par.mask[z]) for z in range(par.mask.shape[0])]
    out = []
    for pick in itertools.product(*options):
        g = np.zeros(par.shapes[0][1:])
        g[np.arange(len(pick)), list(pick)] = 1.0
        d = np.ones((1, *par.mask.shape, 1))
        out.append(par.strategy(g[None], d))
    return out


def _bracket_contains_the_brute_force(seed: int, maximize: bool, unfold: bool) -> None:
    model = random_pomdp(seed)
    prop = 'Pmax=? [ F "goal" ]' if maximize else 'Pmin=? [ F "goal" ]'
    problem = _problem(model, prop)
    # the belief unfolding completes on most of these small POMDPs; without it the grids are
    # what proves the bound
    found = belief_grid.grid_bound(problem, deadline=None, vertices=4000, unfold=unfold)
    s0 = int(model.initial_states[0])
    if found is None:  # the initial state does not continue: full observation is exact there
        reach = belief.can_reach(model, problem.target, problem.remain)
        assert not (problem.remain & ~problem.target & reach)[s0]
        return
    sign = 1.0 if maximize else -1.0
    # the lower side: every deterministic memoryless strategy, and the belief-based controller
    # (memory as needed), proven by the product check; the bound is on the far side of all
    strategies = _deterministic_memoryless(problem)
    controller = belief.belief_phase(problem, strategies[0], deadline=None, explore=2000)
    if controller is not None:
        strategies.append(controller.strategy)
    for fss in strategies:
        r = StrategyChecker(model, {0: fss}, coalition_of=problem.coalition_of,
                            scalar=api._scalar).check(problem.query, text="t").guaranteed
        assert r is not None and r.sound
        achieved = r.lower if maximize else r.upper
        assert sign * found.value >= sign * achieved - 1e-9
    # no looser than full observation, up to the abstraction's solving precision (its bound side
    # is the end of an interval of relative width PRECISION: 2.2e-9 above on seed 5264)
    full = belief_grid.full_observation_bounds(problem)[0][s0]
    assert sign * found.value <= sign * full + 2 * belief_grid.PRECISION * max(1.0, abs(full))


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans(), unfold=st.booleans())
def test_random_pomdp_brackets_contain_every_strategy(seed: int, maximize: bool,
                                                      unfold: bool) -> None:
    _bracket_contains_the_brute_force(seed, maximize, unfold)


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans(), unfold=st.booleans())
def test_many_random_pomdp_brackets_contain_every_strategy(seed: int, maximize: bool,
                                                           unfold: bool) -> None:
    _bracket_contains_the_brute_force(seed, maximize, unfold)


def test_a_fully_observed_pomdp_is_bounded_exactly() -> None:
    """With every state its own observation the beliefs are the states (grid vertices at any
    N): the bound is the MDP's optimum, which the full-observation solve also gives."""
    text = GUESS.replace("observables o endobservables", "observables s, o endobservables")
    model = _built(text=text)
    problem = _problem(model, 'Pmax=? [ F "goal" ]')
    found = _bound(problem)
    assert found.exact
    assert found.value == pytest.approx(
        belief_grid.full_observation_bounds(problem)[0][model.initial_states[0]], abs=1e-7)


def _exact_successors(problem, state_counts: dict[int, int], N: int,  # type: ignore[no-untyped-def]
                      action: int) -> tuple[Fraction, dict[int, Fraction]]:
    """The exact stop mass and continuing successor vector of the grid belief counts/N under
    the model's action ``action`` (its float probabilities taken as exact rationals)."""
    model = problem.model
    cont = problem.remain & ~problem.target & belief.can_reach(model, problem.target,
                                                                problem.remain)
    stop, y = Fraction(0), {}
    for s, c in state_counts.items():
        lo, hi = model.row_groups[s], model.row_groups[s + 1]
        ch = [i for i in range(lo, hi) if model.choice_actions[i] == action]
        assert len(ch) == 1
        row = model.transitions[ch[0]]
        for t, p in zip(row.indices.tolist(), row.data.tolist()):
            mass = Fraction(c, N) * Fraction(p)
            if problem.target[t]:
                stop += mass
            elif cont[t]:
                y[t] = y.get(t, Fraction(0)) + mass
    return stop, y


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), maximize=st.booleans(), resolution=st.sampled_from([2, 3, 4]))
@example(seed=0, maximize=False, resolution=2)  # unscaled weights exceed the exact successors
@example(seed=0, maximize=True, resolution=2)
def test_every_choice_is_on_the_optimistic_side_of_its_exact_belief_successors(
        seed: int, maximize: bool, resolution: int) -> None:
    """Float rounding in posteriors and weights must not cost soundness: in exact rational
    arithmetic over the stored floats, each expanded choice of the abstraction is on the
    optimistic side of the exact belief MDP's. Minimising: the vertices' combination x is below
    the exact continuing successors y entry by entry and the target mass below the exact stop
    mass (so the choice's value is below the exact one's, V* being superlinear). Maximising:
    the target mass is at least the exact stop mass (the continuing weights are the float
    decomposition; what proves the maximiser's bound is its enclosure, checked by
    test_a_maximisers_enclosure_holds_the_exact_belief_successors)."""
    model = random_pomdp(seed)
    prop = 'Pmax=? [ F "goal" ]' if maximize else 'Pmin=? [ F "goal" ]'
    problem = _problem(model, prop)
    _, abstraction = _small_abstraction(problem, resolution)
    if abstraction is None:
        return
    V = abstraction.vertices
    N = abstraction.resolution
    B = abstraction.beliefs
    counts = [dict(zip(B.indices[B.indptr[v]:B.indptr[v + 1]].tolist(),
                       np.rint(B.data[B.indptr[v]:B.indptr[v + 1]] * N).astype(int).tolist()))
              for v in range(V)]
    used = np.flatnonzero(np.isin(np.arange(len(model.action_names)), model.choice_actions))
    T = abstraction.model.transitions
    rg = abstraction.model.row_groups
    checked = 0
    for v in np.flatnonzero(abstraction.expanded).tolist():
        for row in range(rg[v], rg[v + 1]):
            a = int(used[abstraction.action[row]])
            stop, y = _exact_successors(problem, counts[v], N, a)
            entries = T[row]
            x: dict[int, Fraction] = {}
            t = Fraction(0)
            for col, w in zip(entries.indices.tolist(), entries.data.tolist()):
                if col == V:
                    t += Fraction(w)
                elif col < V:
                    for s, c in counts[col].items():
                        x[s] = x.get(s, Fraction(0)) + Fraction(w) * Fraction(c, N)
            if maximize:
                assert t >= stop
            else:
                assert all(x[s] <= y.get(s, Fraction(0)) for s in x)
                assert t <= stop
            checked += 1
    assert checked > 0


def _exact_freudenthal(p: list[Fraction], N: int) -> list[tuple[tuple[int, ...], Fraction]]:
    """Freudenthal's decomposition of the rational distribution ``p`` at resolution N, written
    here independently of the package: (counts, weight) per vertex of positive weight."""
    m = len(p)
    x = [Fraction(N)] + [N * sum(p[j:], Fraction(0)) for j in range(1, m)]
    v = [int(xj // 1) for xj in x]
    d = [xj - vj for xj, vj in zip(x, v)]
    order = sorted(range(1, m), key=lambda j: -d[j])
    out = []
    for k in range(m):
        Y = list(v)
        for j in order[:k]:
            Y[j] += 1
        weight = (1 - d[order[0]] if k == 0 else
                  (d[order[k - 1]] - d[order[k]] if k < m - 1 else d[order[-1]])) if m > 1 \
            else Fraction(1)
        counts = tuple(Y[j] - Y[j + 1] for j in range(m - 1)) + (Y[m - 1],)
        if weight > 0:
            out.append((counts, weight))
    return out


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), resolution=st.sampled_from([2, 3, 4, 8]))
@example(seed=0, resolution=2)
@example(seed=7, resolution=4)
def test_a_maximisers_enclosure_holds_the_exact_belief_successors(seed: int,
                                                                   resolution: int) -> None:
    """The claims the maximiser's certificate rests on (posgmc/synthesis/grid_certificate.py),
    checked in exact rational arithmetic on every expanded choice of random POMDPs' grids: with
    the exact model (stored rows scaled to sum to 1) and the exact vertex beliefs counts/N, the
    top is at least the exact stop mass; ``gone`` at most the exact mass that does not
    continue; every observation part whose exact Freudenthal vertices are all among the row's,
    each weighted at most its coefficient, is certified; the others' uncovered mass, worth the
    full-observation bound per state, is at most the row's leak, and their float weights exceed
    their exact mass by at most its slack. A float decomposition that only approximates the
    exact one (a vertex missing, a weight below the exact one, no leak) fails it."""
    _check_enclosure(random_pomdp(seed), 'Pmax=? [ F "goal" ]', resolution)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), resolution=st.sampled_from([2, 3, 4, 8]))
@example(seed=0, resolution=2)
def test_a_signed_enclosure_holds_the_exact_belief_successors(seed: int,
                                                               resolution: int) -> None:
    """The same claims with rewards of both signs (random POMDPs that stop with 1/10 a step):
    the top is at least the exact reward, and the leak prices each |y*_s - x_s| at
    max(cap(s), -floor(s), 0), the floor being the full-observation minimum
    (posgmc/synthesis/grid_certificate.py, "Rewards of both signs")."""
    _check_enclosure(random_signed_pomdp(seed), 'R{"r"}max=? [ F "goal" ]', resolution)


def _check_enclosure(model, prop: str, resolution: int) -> None:  # type: ignore[no-untyped-def]
    problem = _problem(model, prop)
    signed = problem.rewards is not None and bool((problem.rewards < 0).any())
    cutoff, abstraction = _small_abstraction(problem, resolution)
    if abstraction is None:
        return
    enc = abstraction.enclosure
    assert enc is not None
    N = abstraction.resolution
    V = abstraction.vertices
    B = abstraction.beliefs
    counts = [dict(zip(B.indices[B.indptr[v]:B.indptr[v + 1]].tolist(),
                       np.rint(B.data[B.indptr[v]:B.indptr[v + 1]] * N).astype(int).tolist()))
              for v in range(V)]
    vertex_of = {tuple(sorted(c.items())): v for v, c in enumerate(counts)}
    dyn = belief_dynamics.Dynamics(problem, None)
    if problem.rewards is None:
        cap = np.clip(np.where(np.isfinite(cutoff), cutoff, 1.0), 0.0, 1.0)
    else:
        cap = cutoff
        if signed:
            cap = np.maximum(np.maximum(cap, -belief_grid.full_observation_floor(problem)), 0.0)
    used = np.flatnonzero(np.isin(np.arange(len(model.action_names)), model.choice_actions))
    rg = abstraction.model.row_groups
    coef = enc.coef
    checked = 0
    for v in np.flatnonzero(abstraction.expanded).tolist():
        rows = np.flatnonzero(enc.state == v)
        assert rows.size == rg[v + 1] - rg[v]
        for j, row in zip(rows.tolist(), range(rg[v], rg[v + 1])):
            a = int(used[abstraction.action[row]])
            y: dict[int, Fraction] = {}
            stop, reward = Fraction(0), Fraction(0)
            for s, c in counts[v].items():
                ch = [i for i in range(model.row_groups[s], model.row_groups[s + 1])
                      if model.choice_actions[i] == a]
                if problem.rewards is not None:
                    reward += Fraction(c, N) * Fraction(float(problem.rewards[ch[0]]))
                r = model.transitions[ch[0]]
                total = sum((Fraction(p) for p in r.data.tolist()), Fraction(0))
                for t, p in zip(r.indices.tolist(), r.data.tolist()):
                    mass = Fraction(c, N) * Fraction(p) / total
                    if problem.target[t]:
                        stop += mass
                    elif dyn.cont[t]:
                        y[t] = y.get(t, Fraction(0)) + mass
            assert Fraction(enc.top[j]) >= (stop if problem.rewards is None else reward)
            assert Fraction(enc.gone[j]) <= 1 - sum(y.values(), Fraction(0))
            entries = dict(zip(coef.indices[coef.indptr[j]:coef.indptr[j + 1]].tolist(),
                               coef.data[coef.indptr[j]:coef.indptr[j + 1]].tolist()))
            leak, slack = Fraction(0), Fraction(0)
            for g in sorted({int(dyn.group[s]) for s in y}):
                states = sorted(s for s in y if dyn.group[s] == g)
                w = sum((y[s] for s in states), Fraction(0))
                exact = _exact_freudenthal([y[s] / w for s in states], N)
                ids = [vertex_of.get(tuple(sorted((s, c) for s, c in zip(states, cs) if c)))
                       for cs, _ in exact]
                if all(i is not None and i in entries and w * lam <= Fraction(entries[i])
                       for i, (_, lam) in zip(ids, exact)):
                    continue
                # an ambiguous part: what its float weights leave uncovered is leaked
                mine = {i: Fraction(e) for i, e in entries.items()
                        if set(counts[i]) <= set(states)}
                x = {s: Fraction(0) for s in states}
                for i, e in mine.items():
                    for s, c in counts[i].items():
                        x[s] += e * Fraction(c, N)
                # (with rewards of both signs the excess is priced too)
                leak += sum(((abs(y[s] - x[s]) if signed else max(y[s] - x[s], Fraction(0)))
                             * Fraction(float(cap[s])) for s in states), Fraction(0))
                slack += max(sum(mine.values(), Fraction(0)) - w, Fraction(0))
            assert leak <= Fraction(enc.leak[j])
            assert slack <= Fraction(enc.slack[j])
            checked += 1
    assert checked > 0


def _one_vertex(loop_leak: float) -> grid_certificate.Enclosure:
    """One vertex with two rows: a loop back to itself (clean unless it leaks) and a stop with
    probability 1/2."""
    coef = sp.csr_matrix((np.array([1.0]), (np.array([0]), np.array([0]))), shape=(2, 1))
    return grid_certificate.Enclosure(
        state=np.zeros(2, dtype=np.int64), coef=coef, top=np.array([0.0, 0.5]),
        slack=np.zeros(2), leak=np.array([loop_leak, 0.0]), gone=np.array([0.0, 0.5]),
        kept_lo=np.array([1.0, 0.5]),
        clean=np.array([loop_leak == 0, False]), infinite=np.zeros(2, dtype=bool),
        adversary=np.zeros(1, dtype=bool), probability=True, discount=1.0)


def test_a_clean_loop_keeps_its_exit_value() -> None:
    """Staying in a loop of exact rows is worth nothing: the vertex's value is its exit's, 1/2,
    proven up to the outward rounding of the exit row (the loop itself adds nothing: R(W) = W
    on it without any rounding)."""
    W = grid_certificate.certified_upper(_one_vertex(0.0), np.array([0.5, 1.0, 0.0]))
    assert W is not None and 0.5 <= W[0] <= 0.5 + 1e-14


def test_a_leak_in_a_loop_is_not_ignored() -> None:
    """A loop whose exact successor is only known up to a leak (an ambiguous part) may drift
    anywhere in the long run: no bound below 1 holds for it, so none is proven."""
    W = grid_certificate.certified_upper(_one_vertex(1e-16), np.array([0.5, 1.0, 0.0]))
    assert W is None or W[0] >= 1.0


def test_a_deadline_passed_before_the_steps_are_bounded_proves_nothing_lower() -> None:
    """The steps h of the raise are solved by the caller's deadline: when it has passed, the
    iteration stops where it is, and the bound it then proves is no lower than without the
    deadline (here: none below 1 for the leaking loop, none below its exit's 1/2 for the clean
    loop)."""
    late = time.perf_counter() - 1.0
    W = grid_certificate.certified_upper(_one_vertex(1e-16), np.array([0.5, 1.0, 0.0]),
                                         deadline=late)
    assert W is None or W[0] >= 1.0
    W = grid_certificate.certified_upper(_one_vertex(0.0), np.array([0.5, 1.0, 0.0]),
                                         deadline=late)
    assert W is None or W[0] >= 0.5


DODGE = ROOT / "tests" / "data" / "benchmarks" / "posmg" / "dodge-6-lines" / "sketch.templ"


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), preferred=st.booleans())
def test_the_batched_rules_are_each_vertexs_rules(seed: int, preferred: bool) -> None:
    """The adversary's rules laid out for a group of vertices at once (_rule_entries) are, vertex
    by vertex, the rules Dynamics.rules gives for that vertex alone (weighted by the belief),
    in the same order: all deterministic rules where there are at most RULE_CAP (supports of
    up to three 4-choice states of PAYNT's dodge-6-lines), the preferred rule and its one-state
    deviations beyond (four states or more: 256 combinations), then the uniform mixture."""
    model = _built(DODGE)
    # PAYNT's DRN: 331 states of the decision maker and 308 of the adversary
    assert model.num_states == 639
    coalition = api._resolver(model, True).coalition_of
    problem = problem_of(model, parser.parse_property('<<0>> Pmax=? [F "goal"]').expr,
                         player=0, adversary=1, coalition_of=coalition, scalar=api._scalar)
    rng = np.random.default_rng(seed)
    rg = model.row_groups
    rules = None
    if preferred:  # a random choice of each state, sometimes outside the state (ignored then)
        rules = rng.integers(0, model.num_choices, model.num_states)
    dyn = belief_dynamics.Dynamics(problem, rules)
    theirs = np.flatnonzero(~dyn.owned)
    per_state = np.diff(rg)
    for m in (1, 2, 3, 4, 5):
        # supports of one shape: states offering the same numbers of choices
        n = per_state[theirs]
        pool = theirs[n == 4] if m > 1 else theirs
        g = 3
        states = np.stack([np.sort(rng.choice(pool, m, replace=False)) for _ in range(g)])
        shape = per_state[states]
        keep = (shape == shape[0]).all(axis=1)
        states = states[keep]
        mass = rng.random(states.shape) + 0.1
        mass /= mass.sum(axis=1, keepdims=True)
        k, vi, r, col, w = belief_grid._rule_entries(dyn, per_state[states[0]], states, mass)
        for j in range(states.shape[0]):
            cols, probs = dyn.rules(states[j])
            assert np.array_equal(probs, _reference_rules(states[j], rg, rules))
            assert probs.shape[0] == k
            owner = np.repeat(np.arange(m), per_state[states[j]])
            dense = np.zeros((k, model.num_choices))
            at = vi == j
            np.add.at(dense, (r[at], col[at]), w[at])
            expected = np.zeros((k, model.num_choices))
            expected[:, cols] = probs * mass[j][owner]
            assert np.array_equal(dense, expected)
            # each rule's entries in the order of its choices
            for rule in range(k):
                c = col[at & (r == rule)]
                assert np.all(np.diff(c) > 0)


def _reference_rules(states: np.ndarray, rg: np.ndarray, preferred: np.ndarray | None
                     ) -> np.ndarray:
    """The adversary's rules at a support, one state and one choice at a time: every
    deterministic rule when there are at most RULE_CAP (lexicographic), else the preferred rule
    (each state's first choice where its preferred one is not its own) and its one-state
    deviations in state and choice order, the first RULE_CAP in all; then the uniform mixture
    when some state has a choice. float64[rules, the support's choices]."""
    n = [int(rg[s + 1] - rg[s]) for s in states.tolist()]
    offset = [sum(n[:i]) for i in range(len(n))]
    varying = [i for i in range(len(n)) if n[i] > 1]
    combos = 1
    for i in varying:
        combos *= n[i]
    det: list[list[int]] = []
    if combos <= belief_dynamics.RULE_CAP:
        for pick in itertools.product(*[range(n[i]) for i in varying]):
            rule = [0] * len(n)
            for i, c in zip(varying, pick):
                rule[i] = c
            det.append(rule)
    else:
        base = []
        for s, ni in zip(states.tolist(), n):
            p = -1 if preferred is None else int(preferred[s]) - int(rg[s])
            base.append(p if 0 <= p < ni else 0)
        det.append(base)
        for i in varying:
            for c in range(n[i]):
                if c != base[i] and len(det) < belief_dynamics.RULE_CAP:
                    det.append(base[:i] + [c] + base[i + 1:])
    out = np.zeros((len(det) + (1 if varying else 0), sum(n)))
    for r, rule in enumerate(det):
        for i, c in enumerate(rule):
            out[r, offset[i] + c] = 1.0
    if varying:
        for i in range(len(n)):
            out[-1, offset[i]:offset[i] + n[i]] = 1.0 / n[i]
    return out


def test_the_unfolding_of_a_game_keeps_exact_posteriors() -> None:
    """On a one-sided game the maximiser's belief unfolding keys each posterior by its exact
    rational value (the adversary's uniform mixture read as the exact rule): on dodge_lanes.posg
    (18 states and 44 choices, from the model's own text) every vertex's floats sum to 1 up to
    their rounding and no row leaks, so the runner's peeking loop is certified (0.12, the value
    of those rules derived in
    test_stage_lp.test_a_guard_that_keeps_the_runner_guessing_is_found_on_the_grid)."""
    model = _built(ROOT / "tests" / "data" / "games" / "dodge_lanes.posg")
    assert (model.num_states, model.num_choices) == (18, 44)
    coalition = api._resolver(model, False).coalition_of
    problem = problem_of(model, parser.parse_property('<<runner>> Pmax=? [ F "won" ]').expr,
                         player=0, adversary=1, coalition_of=coalition, scalar=api._scalar)
    cutoff, rules = belief_grid.full_observation_bounds(problem)
    abstraction = belief_grid.grid_abstraction(problem, 0, cutoff=cutoff,
                                               adversary_rules=rules, max_vertices=5_000)
    assert abstraction is not None
    enc = abstraction.enclosure
    assert enc is not None
    B = abstraction.beliefs
    sums = np.asarray(B.sum(axis=1)).ravel()
    assert np.abs(sums - 1.0).max() <= 1e-15 * 8
    # the reachable beliefs are infinitely many (the odds change every round); the 5,000
    # vertices explored are cut off, and none of their rows leaks
    assert abstraction.vertices > 5_000 and not abstraction.complete
    assert not (enc.leak > 0).any() and not (enc.slack > 0).any()
    result = abstraction.solve(SolverOptions(precision=1e-6, relative=True,
                                             want_strategy=False, stiff_certificate=True))
    proven = belief_grid._proven_side(abstraction, result)
    assert proven is not None and 0.12 <= proven[0] <= 0.12 + 1e-6


def _exact_choice_rewards(abstraction: belief_grid.GridAbstraction, problem  # type: ignore[no-untyped-def]
                          ) -> list[tuple[float, Fraction]]:
    """(the abstraction's reward, the exact one) per expanded choice: Σ_s (counts_s / N) r(s, a)
    over the vertex belief's support, the stored rewards taken as exact."""
    model = problem.model
    N = abstraction.resolution
    B = abstraction.beliefs
    used = np.flatnonzero(np.isin(np.arange(len(model.action_names)), model.choice_actions))
    rg = abstraction.model.row_groups
    out = []
    for v in np.flatnonzero(abstraction.expanded).tolist():
        support = B.indices[B.indptr[v]:B.indptr[v + 1]].tolist()
        counts = np.rint(B.data[B.indptr[v]:B.indptr[v + 1]] * N).astype(int).tolist()
        for row in range(rg[v], rg[v + 1]):
            a = int(used[abstraction.action[row]])
            exact = Fraction(0)
            for s, c in zip(support, counts, strict=True):
                ch = [i for i in range(model.row_groups[s], model.row_groups[s + 1])
                      if model.choice_actions[i] == a]
                exact += Fraction(c, N) * Fraction(float(problem.rewards[ch[0]]))
            out.append((float(abstraction.rewards[row]), exact))
    return out


@pytest.mark.parametrize("resolution", [2, 4, 8])
def test_a_negative_reward_is_rounded_up_for_a_maximiser(resolution: int) -> None:
    """SIGNED (tests/synthesis/helpers.py): every expanded choice's reward in a maximiser's
    abstraction is at least the exact reward of its vertex belief (exact rational arithmetic),
    negative ones included (scaling a negative sum by 1 + γ moved it below the exact value)."""
    model = _built(text=SIGNED)
    assert model.num_states == 5 and model.num_choices == 10
    problem = _problem(model, 'R{"r"}max=? [ F s=4 ]')
    cutoff = belief_grid.full_observation_bounds(problem)[0]
    abstraction = belief_grid.grid_abstraction(problem, resolution, cutoff=cutoff)
    assert abstraction is not None and abstraction.rewards is not None
    pairs = _exact_choice_rewards(abstraction, problem)
    assert any(exact < 0 for _, exact in pairs)
    assert all(Fraction(got) >= exact for got, exact in pairs)


def test_a_minimisers_rewards_of_both_signs_get_no_grid() -> None:
    """A minimiser's abstraction scales its rows below the exact ones and prices what it gives
    up at 0, which is below V* only where V* >= 0: with rewards of both signs no grid applies
    (the bracket keeps full observation). Before, SIGNED's Rmin got a "bound" of 0.018 while the
    belief-based controller proves -3.24 (rewards rounded to 0 and the cut-offs clipped at 0)."""
    model = _built(text=SIGNED)
    problem = _problem(model, 'R{"r"}min=? [ F s=4 ]')
    assert not belief_grid.applies(problem)
    assert belief_grid.grid_bound(problem, deadline=None, vertices=2000) is None


def _signed_bracket_contains_the_strategies(seed: int) -> None:
    model = random_signed_pomdp(seed)
    problem = _problem(model, 'R{"r"}max=? [ F "goal" ]')
    found = belief_grid.grid_bound(problem, deadline=None, vertices=4000)
    assert found is not None
    s0 = int(model.initial_states[0])
    for fss in _deterministic_memoryless(problem):
        r = StrategyChecker(model, {0: fss}, coalition_of=problem.coalition_of,
                            scalar=api._scalar).check(problem.query, text="t").guaranteed
        assert r is not None and r.sound
        assert found.value >= r.lower - 1e-9
    full = belief_grid.full_observation_bounds(problem)[0][s0]
    assert found.value <= full + 2 * belief_grid.PRECISION * max(1.0, abs(full))


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000))
def test_random_signed_pomdp_bounds_contain_every_strategy(seed: int) -> None:
    """Rewards of both signs (every choice stops with 1/10): the maximiser's grid bound, proven
    by the contraction argument, is at least every deterministic memoryless strategy's proven
    value and at most full observation."""
    _signed_bracket_contains_the_strategies(seed)


def test_signed_grid_is_proven_below_full_observation() -> None:
    """SIGNED: the agent cannot tell s=1 from s=2, so a grid bounds its optimum below full
    observation (7.04, helpers.py); the proven bound (resolution 8 and finer: 5.19 and below,
    measured) stays above every deterministic memoryless strategy (0.757 at best, proven by the
    product check). With negative rewards every ambiguous part leaked +inf before, and the bound
    was full observation."""
    model = _built(text=SIGNED)
    problem = _problem(model, 'R{"r"}max=? [ F s=4 ]')
    full = belief_grid.full_observation_bounds(problem)[0][0]
    found = belief_grid.grid_bound(problem, deadline=None, vertices=3000)
    assert found is not None
    assert found.value <= 5.2 < full
    for fss in _deterministic_memoryless(problem):
        r = StrategyChecker(model, {0: fss}, coalition_of=problem.coalition_of,
                            scalar=api._scalar).check(problem.query, text="t").guaranteed
        assert r is not None and r.sound and r.lower <= found.value


def _game(path: Path, prop: str):  # type: ignore[no-untyped-def]
    model = _built(path)
    coalition = api._resolver(model, False).coalition_of
    return model, problem_of(model, parser.parse_property(prop).expr, player=0, adversary=1,
                             coalition_of=coalition, scalar=api._scalar)


def test_the_default_refinement_settles_once_a_complete_grid_stops_tightening() -> None:
    """``settle`` (the default bracket's budget rule, docs/synthesis.md "Budget"): on
    models/rover.posg the complete grids of resolution 2 and 4 prove the same bound (0.98765618,
    the full-observation value 0.9876561794 of models/README.md within the solve's precision),
    so refinement stops there; without the rule the same budget buys resolutions 8 and 16 and
    proves nothing tighter. On dodge_lanes.posg the grids plateau at 0.125 (resolutions 8 to 32)
    above the unfolding's 0.12 and descend again from resolution 64: the rule does not stop a
    plateau that is not the best bound, so both runs try the same resolutions."""
    model, rover = _game(ROOT / "models" / "rover.posg", '<<rover>> Pmax=? [ !"crash" U "goal" ]')
    assert (model.num_states, model.num_choices) == (60, 100)
    settled = belief_grid.grid_bound(rover, deadline=None, vertices=20_000, mix=False,
                                     settle=True)
    full = belief_grid.grid_bound(rover, deadline=None, vertices=20_000, mix=False)
    assert settled is not None and full is not None
    assert [n for n, _ in settled.tried] == [0, 2, 4]
    assert [n for n, _ in full.tried] == [0, 2, 4, 8, 16]
    assert settled.value == full.value and settled.resolution == 2 and settled.complete
    assert 0.9876561794 <= settled.value <= 0.9876561794 * (1 + 1e-8)
    model, lanes = _game(ROOT / "tests" / "data" / "games" / "dodge_lanes.posg",
                         '<<runner>> Pmax=? [ F "won" ]')
    assert (model.num_states, model.num_choices) == (18, 44)
    settled = belief_grid.grid_bound(lanes, deadline=None, vertices=20_000, mix=False,
                                     settle=True)
    full = belief_grid.grid_bound(lanes, deadline=None, vertices=20_000, mix=False)
    assert settled is not None and full is not None
    assert settled.tried == full.tried
    assert all(dict(full.tried)[n] == pytest.approx(0.125, abs=1e-8) for n in (8, 16, 32))
    assert dict(full.tried)[64] < 0.125 - 1e-3


@pytest.mark.parametrize(("path", "prop"), [
    (ROOT / "models" / "rover.posg", '<<rover>> Pmax=? [ !"crash" U "goal" ]'),
    (ROOT / "tests" / "data" / "games" / "dodge_lanes.posg", '<<runner>> Pmax=? [ F "won" ]'),
])
def test_shared_exact_posteriors_are_the_ones_each_row_would_give(
        path: Path, prop: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The unfolding computes an adversary's deterministic rule's exact posteriors once per
    signature from the choices reaching the part (belief_exact.shared_parts); with that sharing
    switched off every part's posterior comes from its row's whole exact vector. Both must give
    the same abstraction: the same vertices in the same order, the same exact beliefs, the
    same enclosure (models/rover.posg: 60 states and 100 choices; dodge_lanes.posg: 18 and
    44)."""
    model, problem = _game(path, prop)
    assert (model.num_states, model.num_choices) in ((60, 100), (18, 44))
    cutoff, rules = belief_grid.full_observation_bounds(problem)
    shared = belief_grid.grid_abstraction(problem, 0, cutoff=cutoff, adversary_rules=rules,
                                          max_vertices=1_500)
    called: list[int] = []
    real = belief_exact.shared_parts

    def unshared(source, live, rows, starts, sizes, col, vertex, dyn):  # type: ignore[no-untyped-def]
        sigs, _ = real(source, live, rows, starts, sizes, col, vertex, dyn)
        called.append(sum(s is not None for s in sigs))
        return [None] * starts.size, live

    monkeypatch.setattr(belief_grid, "shared_parts", unshared)
    alone = belief_grid.grid_abstraction(problem, 0, cutoff=cutoff, adversary_rules=rules,
                                         max_vertices=1_500)
    assert shared is not None and alone is not None
    assert sum(called) > 0  # the sharing had parts to share
    assert shared.vertices == alone.vertices
    for a, b in ((shared.beliefs, alone.beliefs), (shared.model.transitions,
                                                   alone.model.transitions)):
        assert (a != b).nnz == 0 and a.shape == b.shape
    ea, eb = shared.enclosure, alone.enclosure
    assert ea is not None and eb is not None
    assert (ea.coef != eb.coef).nnz == 0
    for f in ("state", "top", "slack", "leak", "clean", "infinite"):
        assert np.array_equal(getattr(ea, f), getattr(eb, f)), f
