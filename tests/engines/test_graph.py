"""Graph precomputation and the slot-layout Bellman operator, on hand-built structures."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines.graph import (
    Structure,
    almost_sure_reach,
    attractor,
    concat_ranges,
    end_components,
    positive_buchi,
    positive_reach,
    safe_region,
    structure_of,
)
from posgmc.engines.system import bellman, build_system, choice_values, choose
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import ModelType
from tests.engines.engine_models import small_models, smg_example


def _mdp(rows: list[list[float]], groups: list[int]) -> ExplicitModel:
    return make_model(ModelType.MDP, groups, np.array(rows, dtype=float))


def test_concat_ranges() -> None:
    got = concat_ranges(np.array([2, 7, 7, 0]), np.array([4, 7, 9, 1]))
    assert got.tolist() == [2, 3, 7, 8, 0]


def test_attractor_existential_versus_universal() -> None:
    # s0: a -> s2 (goal), b -> s1;  s1: loop;  s2 goal
    m = _mdp([[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 0, 1]], [0, 2, 3, 4])
    g = structure_of(m)
    goal = np.array([False, False, True])
    everyone = np.ones(3, bool)
    inside, witness = attractor(g, goal, existential=everyone, candidates=everyone)
    assert inside.tolist() == [True, False, True] and witness[0] == 0
    # universal: s0's choice b avoids the goal
    inside, _ = attractor(g, goal, existential=np.zeros(3, bool), candidates=everyone)
    assert inside.tolist() == [False, False, True]
    # universal over the allowed choices only
    allowed = np.array([True, False, True, True])
    inside, _ = attractor(
        g, goal, existential=np.zeros(3, bool), candidates=everyone, allowed=allowed
    )
    assert inside.tolist() == [True, False, True]


def test_qualitative_reachability_on_smg_example() -> None:
    m = smg_example()
    g = structure_of(m)
    c2 = m.state_values[:, 1] == 2
    p1_max = np.array([True, True, False, True, False])
    everywhere = np.ones(5, bool)
    # p1 reaches c=2 almost surely from every state but (1,1), where p2 waits forever
    one, witness = almost_sure_reach(g, c2, everywhere, existential=p1_max)
    assert one.tolist() == [True, True, False, True, True]
    assert witness[0] == 1  # send2
    assert positive_reach(g, c2, everywhere, existential=p1_max).tolist() == [
        True,
        True,
        False,
        True,
        True,
    ]
    # p1 minimising never sends message 2 (restart forever)
    assert positive_reach(g, c2, everywhere, existential=~p1_max).tolist() == [
        False,
        False,
        False,
        False,
        True,
    ]


def test_almost_sure_reach_universal_state_with_a_leaving_choice() -> None:
    # s0 (universal): a -> 0.25 goal + 0.75 s2, b -> goal; s2: loop (never reaches)
    m = _mdp([[0, 0.25, 0.75], [0, 1, 0], [0, 1, 0], [0, 0, 1]], [0, 2, 3, 4])
    one, _ = almost_sure_reach(
        structure_of(m),
        np.array([False, True, False]),
        np.ones(3, bool),
        existential=np.zeros(3, bool),
    )
    assert one.tolist() == [False, True, False]


def test_end_components() -> None:
    # s0 <-> s1 by choices a; s0 also b -> s2; s2 loop; s3 -> s2
    m = _mdp(
        [[0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 1, 0]], [0, 2, 3, 4, 5]
    )
    T = m.transitions
    state_of_row = m.choice_states
    mec_of, num, internal = end_components(T, state_of_row, np.ones(5, bool))
    assert num == 2
    assert mec_of[0] == mec_of[1] != mec_of[2] and mec_of[3] == -1
    assert internal.tolist() == [True, False, True, True, False]
    # without s1's choice back, {s0, s1} is no end component
    mec_of, num, _ = end_components(T, state_of_row, np.array([True, True, False, True, True]))
    assert num == 1 and mec_of[2] >= 0 and mec_of[0] == -1


def test_safe_region_and_buchi() -> None:
    # s0: a -> s1 (reward), b -> s2;  s1 -> s0;  s2 loop
    m = _mdp([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1]], [0, 2, 3, 4])
    g = structure_of(m)
    good = np.array([True, False, False, False])
    everyone = np.ones(3, bool)
    # the existential player can avoid "good" forever everywhere (s1 -> s0 -> b)
    safe, choice = safe_region(g, everyone, existential=everyone, good=~good)
    assert safe.all() and choice[0] == 1
    # ... but a universal player at s0 could be forced to take it: s0 and s1 are unsafe
    safe, _ = safe_region(g, everyone, existential=np.zeros(3, bool), good=~good)
    assert safe.tolist() == [False, False, True]
    # Büchi: the existential player loops s0 -a-> s1 -> s0 forever taking "good"
    winning, witness = positive_buchi(g, good, everyone, existential=everyone)
    assert winning.tolist() == [True, True, False] and witness[0] == 0
    assert not positive_buchi(g, good, everyone, existential=np.zeros(3, bool))[0].any()


@settings(max_examples=60, deadline=None)
@given(small_models(), st.data())
def test_slot_layout_bellman_matches_a_direct_computation(
    model: ExplicitModel, data: st.DataObject
) -> None:
    S = model.num_states
    unknown = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)), bool)
    maximize = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)), bool)
    fixed = np.array(data.draw(st.lists(st.floats(0, 1), min_size=S, max_size=S)))
    reward = np.array(
        data.draw(st.lists(st.floats(0, 3), min_size=model.num_choices, max_size=model.num_choices))
    )
    g = structure_of(model)
    sys = build_system(g, unknown, maximize=maximize, choice_offset=reward, fixed=fixed)
    assert sys.n == int(unknown.sum())
    x_local = np.array(data.draw(st.lists(st.floats(0, 1), min_size=sys.n, max_size=sys.n)))
    full = np.where(unknown, 0.0, fixed)
    full[sys.states] = x_local
    y = reward + model.transitions @ full
    expected = np.array(
        [
            (max if maximize[s] else min)(y[model.row_groups[s] : model.row_groups[s + 1]])
            for s in sys.states
        ]
    )
    assert np.allclose(bellman(sys, x_local), expected)
    assert np.allclose(choice_values(sys, x_local), y[sys.rows])
    # maximisers come first, every state's rows are all there
    assert np.all(maximize[sys.states[: sys.num_max]]) and not np.any(
        maximize[sys.states[sys.num_max :]]
    )
    assert sorted(sys.rows.tolist()) == np.flatnonzero(unknown[model.choice_states]).tolist()
    best, cand = choose(sys, x_local, x_local)
    assert np.all(sys.row_state[best] == np.arange(sys.n)) and cand[best].all()


def test_structure_of_is_cached_per_model() -> None:
    m = smg_example()
    assert structure_of(m) is structure_of(m)
    assert isinstance(structure_of(m), Structure)


@settings(max_examples=300, deadline=None)
@given(
    model=small_models(ModelType.MDP, max_states=7),
    data=st.data(),
)
def test_one_player_almost_sure_reach_equals_the_nested_fixpoint(model, data) -> None:
    """The end-component quotient (one player) agrees with the classical nested fixpoint, and its
    witness really reaches the target almost surely (checked on the induced chain)."""
    from posgmc.engines import graph as gr

    S = model.num_states
    g = structure_of(model)
    target = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    remain = np.array(data.draw(st.lists(st.booleans(), min_size=S, max_size=S)))
    allowed = None
    if data.draw(st.booleans()):
        allowed = np.array(
            data.draw(
                st.lists(st.booleans(), min_size=model.num_choices, max_size=model.num_choices)
            )
        )
        allowed[model.row_groups[:-1]] = True  # every state keeps a choice
    everyone = np.ones(S, bool)
    fast, _ = almost_sure_reach(g, target, remain, existential=everyone, allowed=allowed)
    slow, _, done = gr._almost_sure_reach_nested(
        g,
        target,
        remain,
        existential=everyone,
        allowed=allowed,
        target_choices=None,
        start=None,
        universal_allowed=None,
    )
    assert done
    quotient, witness = gr._almost_sure_reach_one_player(
        g, target, remain, allowed=allowed, superset=np.ones(S, bool)
    )
    assert fast.tolist() == slow.tolist() == quotient.tolist()
    # the witness: the chain it induces reaches the target with probability 1 from the region
    inner = quotient & ~target
    assert np.all(witness[inner] >= 0)
    P = model.transitions.toarray()
    chain = np.zeros((S, S))
    for s in range(S):
        if inner[s]:
            chain[s] = P[witness[s]]
        else:
            chain[s, s] = 1.0
    reach = target.astype(float)
    for _ in range(2000):
        reach = np.where(target, 1.0, chain @ reach)
    assert np.all(reach[inner] > 1 - 1e-6)


def test_almost_sure_reach_switches_to_the_quotient_on_a_deep_chain() -> None:
    """s_i -> 1/2 s_(i+1) + 1/2 t for i < k, s_k -> 1/2 z + 1/2 t (z a trap): the nested fixpoint
    removes one s_i per round (k rounds, more than it is allowed), the quotient finishes. Only t
    and w (which can go to t directly) reach t almost surely."""
    k = 20
    S = k + 3  # s_1..s_k = 0..k-1, t = k, z = k+1, w = k+2
    t, z, w = k, k + 1, k + 2
    rows = []
    for i in range(k):
        row = np.zeros(S)
        row[t] = 0.5
        row[i + 1 if i + 1 < k else z] = 0.5
        rows.append(row)
    for loop in (t, z):
        row = np.zeros(S)
        row[loop] = 1.0
        rows.append(row)
    for succ in (0, t):  # w: a -> s_1, b -> t
        row = np.zeros(S)
        row[succ] = 1.0
        rows.append(row)
    groups = list(range(k + 3)) + [k + 4]
    m = _mdp(rows, groups)
    target = np.zeros(S, bool)
    target[t] = True
    region, witness = almost_sure_reach(
        structure_of(m), target, np.ones(S, bool), existential=np.ones(S, bool)
    )
    assert np.flatnonzero(region).tolist() == [t, w]
    assert witness[w] == k + 3  # w's choice b
