"""Model x DFA products: hand-counted products, carried-over model data, a naive reference product
on random models, and the co-safe properties of PRISM-games' robot example end to end."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines.ltl import Dfa, extract_atoms, letter_graph, pack_letters, product, to_dfa
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel, Observation, RewardModel, make_model
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    Direction,
    Expr,
    Ident,
    IntLit,
    LabelRef,
    ModelType,
    ProbQuery,
    RewardKind,
    RewardQuery,
)
from tests.engines.ltl.ltl_reference import And, F, Not, Or, U, X, a, b

# -- a tiny mdp ------------------------------------------------------------------------------
#   s0: c0 -> s1 (1/2), s2 (1/2)    c1 -> s0
#   s1: -> s1                        labels: a = {s1}, b = {s2}
#   s2: -> s0


def tiny_mdp() -> ExplicitModel:
    return make_model(
        ModelType.MDP,
        [0, 2, 3, 4],
        [[0, 0.5, 0.5], [1, 0, 0], [0, 1, 0], [1, 0, 0]],
        choice_actions=[1, 2, 0, 0],
        action_names=("", "go", "wait"),
        labels={"a": [False, True, False], "b": [False, False, True]},
        reward_models=(
            RewardModel("r", state=np.array([1.0, 2.0, 3.0]), choice=np.array([10.0, 20, 30, 40])),
        ),
        variable_names=("x",),
        state_values=[[0], [1], [2]],
    )


def atom_values(model: ExplicitModel, dfa: Dfa) -> np.ndarray:
    return np.array([model.label(atom.name) for atom in dfa.atoms])  # type: ignore[attr-defined]


def test_until_product_counts() -> None:
    # !b U a; DFA: q0 = formula, acc, sink. Product (hand-derived): initial (s0, q0) since L(s0)
    # has neither a nor b; c0 -> (s1, acc), (s2, sink); c1 -> (s0, q0); (s2, sink) -> (s0, sink)
    # -> (s1, sink), (s2, sink), (s0, sink): 5 states, 1 accepting, 4 rejecting-or-initial
    model = tiny_mdp()
    dfa = to_dfa(U(Not(b), a))
    prod = product(model, dfa, atom_values(model, dfa))
    assert prod.num_states == 5
    assert prod.model.num_choices == 2 + 1 + 1 + 2 + 1
    assert prod.accepting.sum() == 1
    assert prod.rejecting.sum() == 3
    pairs = set(zip(prod.state_of.tolist(), prod.dfa_state_of.tolist()))
    q0, sink = dfa.initial, dfa.rejecting_sink
    acc = int(np.flatnonzero(dfa.accepting)[0])
    assert pairs == {(0, q0), (1, acc), (2, sink), (0, sink), (1, sink)}
    assert prod.initial_map.tolist() == [0]
    assert prod.model.initial_states.tolist() == [0]
    assert (prod.state_of[prod.accepting] == 1).all()


def test_eventually_product_counts_and_carried_data() -> None:
    # F a: (s0, q0), (s1, acc), (s2, q0): 3 states
    model = tiny_mdp()
    dfa = to_dfa(F(a))
    prod = product(model, dfa, atom_values(model, dfa))
    pm = prod.model
    assert prod.num_states == 3 and pm.num_choices == 4 and pm.num_transitions == 5
    assert pm.model_type is ModelType.MDP
    # choices copy their model choice: actions and choice rewards; states their state rewards
    choice_of = np.repeat(prod.state_of, np.diff(pm.row_groups))
    first_choice = model.row_groups[choice_of]
    owner = np.repeat(np.arange(3), np.diff(pm.row_groups))
    local = np.arange(pm.num_choices) - pm.row_groups[owner]
    original_choice = first_choice + local
    assert (pm.choice_actions == model.choice_actions[original_choice]).all()
    assert (pm.reward_models[0].choice == model.reward_models[0].choice[original_choice]).all()
    assert (pm.reward_models[0].state == model.reward_models[0].state[prod.state_of]).all()
    assert pm.reward_models[0].name == "r"
    # labels follow the model state, "init" marks the product's initial states only
    assert (pm.label("a") == model.label("a")[prod.state_of]).all()
    assert pm.label("init").tolist() == [True, False, False]
    assert pm.variable_names == ("x", "_dfa")
    assert (pm.state_values[:, 0] == prod.state_of).all()
    assert (pm.state_values[:, 1] == prod.dfa_state_of).all()


def test_accepting_initial_state() -> None:
    # F a read at an initial state that satisfies a: the product starts accepting
    model = make_model(ModelType.DTMC, [0, 1], [[1.0]], labels={"a": [True]})
    dfa = to_dfa(F(a))
    prod = product(model, dfa, atom_values(model, dfa))
    assert prod.num_states == 1 and prod.accepting.tolist() == [True]


def test_several_initial_states_map_in_order() -> None:
    model = make_model(
        ModelType.DTMC, [0, 1, 2], [[0, 1.0], [0, 1.0]], initial_states=[0, 1],
        labels={"a": [False, True]},
    )
    dfa = to_dfa(X(a))  # X a, a, false, true
    prod = product(model, dfa, atom_values(model, dfa))
    assert prod.state_of[prod.initial_map].tolist() == [0, 1]
    assert sorted(prod.initial_map.tolist()) == prod.model.initial_states.tolist()


def test_players_and_observations() -> None:
    # a 2-player smg where player 1 (state 1) observes the parity of the state
    model = make_model(
        ModelType.SMG, [0, 2, 3, 4], [[0, 1, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]],
        state_players=[0, 1, 0], player_names=("p1", "p2"),
        observations=(
            Observation(1, np.array([0, 1, 0], dtype=np.int32), ("par",), np.array([[0], [1]])),
        ),
        labels={"a": [False, False, True], "b": [False, True, False]},
    )
    dfa = to_dfa(F(And(b, F(a))))
    prod = product(model, dfa, atom_values(model, dfa))
    assert (prod.model.state_players == model.state_players[prod.state_of]).all()
    assert prod.model.player_names == ("p1", "p2")
    obs = prod.model.observations[0]
    assert obs.player == 1 and obs.names == ("par", "_dfa")
    # the observed pair (parity, DFA state) identifies each id
    pairs = np.column_stack([model.observations[0].state_ids[prod.state_of], prod.dfa_state_of])
    assert (obs.values[obs.state_ids] == pairs).all()
    assert obs.num_observations == len({tuple(p) for p in pairs.tolist()})
    hidden_prod = product(model, dfa, atom_values(model, dfa), observe_dfa_state=False)
    hidden = hidden_prod.model.observations[0]
    assert hidden.names == ("par",)
    assert (hidden.state_ids == model.observations[0].state_ids[prod.state_of]).all()


def test_atom_values_shape_is_checked() -> None:
    model = tiny_mdp()
    with pytest.raises(ValueError, match="atom_values has shape"):
        product(model, to_dfa(F(a)), np.zeros((2, 3), dtype=bool))


def test_pack_letters() -> None:
    assert pack_letters(np.array([[True, False, True], [True, True, False]])).tolist() == [3, 2, 1]


# -- random models against a naive product -------------------------------------------------


def naive_product(
    model: ExplicitModel, dfa: Dfa, letters: np.ndarray
) -> dict[tuple[int, int], list[dict[tuple[int, int], float]]]:
    """(s, q) -> list over choices of {(t, q'): probability}, by a plain BFS."""
    T = model.transitions.toarray()
    rg = model.row_groups
    start = [(int(s), int(dfa.delta[dfa.initial, letters[s]])) for s in model.initial_states]
    out: dict[tuple[int, int], list] = {}
    stack = list(start)
    while stack:
        s, q = stack.pop()
        if (s, q) in out:
            continue
        rows = []
        for ch in range(rg[s], rg[s + 1]):
            row = {}
            for t in np.flatnonzero(T[ch]):
                key = (int(t), int(dfa.delta[q, letters[t]]))
                row[key] = T[ch, t]
                stack.append(key)
            rows.append(row)
        out[(s, q)] = rows
    return out


@st.composite
def random_models(draw: st.DrawFn) -> ExplicitModel:
    num_states = draw(st.integers(1, 6))
    counts = [draw(st.integers(1, 3)) for _ in range(num_states)]
    rows = []
    for _ in range(sum(counts)):
        succ = draw(st.lists(st.integers(0, num_states - 1), min_size=1, max_size=3, unique=True))
        weights = [draw(st.integers(1, 4)) for _ in succ]
        row = np.zeros(num_states)
        row[succ] = np.array(weights) / sum(weights)
        rows.append(row)
    init = draw(st.lists(st.integers(0, num_states - 1), min_size=1, max_size=2, unique=True))
    labels = {
        name: draw(st.lists(st.booleans(), min_size=num_states, max_size=num_states))
        for name in ("a", "b")
    }
    return make_model(
        ModelType.MDP, np.concatenate([[0], np.cumsum(counts)]), np.array(rows),
        initial_states=init, labels=labels,
    )


FORMULAS = [
    F(a), U(a, b), F(And(a, F(b))), Or(F(a), F(b)), X(X(a)), F(X(b)), U(Not(b), And(a, X(a)))
]


@settings(max_examples=60, deadline=None)
@given(random_models(), st.sampled_from(FORMULAS))
def test_product_matches_naive_construction(model: ExplicitModel, formula: Expr) -> None:
    dfa = to_dfa(formula)
    values = atom_values(model, dfa)
    prod = product(model, dfa, values)
    reference = naive_product(model, dfa, pack_letters(values))
    pairs = list(zip(prod.state_of.tolist(), prod.dfa_state_of.tolist()))
    assert set(pairs) == set(reference) and len(pairs) == len(reference)
    T = prod.model.transitions.toarray()
    rg = prod.model.row_groups
    for i, key in enumerate(pairs):
        got = [
            {pairs[j]: T[ch, j] for j in np.flatnonzero(T[ch])} for ch in range(rg[i], rg[i + 1])
        ]
        expected = reference[key]
        assert len(got) == len(expected)
        for g, r in zip(got, expected):
            assert g.keys() == r.keys()
            assert all(abs(g[k] - r[k]) < 1e-12 for k in g)
        assert prod.accepting[i] == dfa.accepting[key[1]]
    # accepting product states are closed under successors
    from_accepting = np.repeat(prod.accepting, np.diff(rg))
    successors = (T[from_accepting] > 0).any(axis=0)
    assert prod.accepting[successors].all()


# -- PRISM-games robot example end to end --------------------------------------------------
# smg/robot/robot.prism, one player; a tiny value iteration stands in for the engines package.


def robot() -> ExplicitModel:
    # choices in command order: s0 east, south; s1 east, south; s2 stuck; s3 stuck; s4 east, west;
    # s5 north, west
    rows = [
        {1: 0.6, 0: 0.4}, {3: 0.8, 1: 0.1, 4: 0.1},
        {2: 1.0}, {4: 0.5, 2: 0.5},
        {2: 1.0},
        {3: 1.0},
        {5: 1.0}, {3: 0.6, 4: 0.4},
        {2: 0.9, 5: 0.1}, {4: 1.0},
    ]
    T = np.zeros((len(rows), 6))
    for i, row in enumerate(rows):
        for t, p in row.items():
            T[i, t] = p
    s = np.arange(6)
    return make_model(
        ModelType.SMG, [0, 2, 4, 5, 6, 8, 10], T,
        choice_actions=[2, 3, 2, 3, 5, 5, 2, 4, 1, 4],
        action_names=("", "north", "east", "south", "west", "stuck"),
        player_names=("one",),
        labels={"hazard": s == 1, "goal1": s == 5, "goal2": (s == 2) | (s == 3)},
        reward_models=(RewardModel("time", state=np.ones(6)),),
        variable_names=("s",),
        state_values=s[:, None],
    )


def _bellman(model: ExplicitModel, x: np.ndarray, maximise: bool) -> np.ndarray:
    per_choice = model.transitions @ x
    reduce = np.maximum if maximise else np.minimum
    return reduce.reduceat(per_choice, model.row_groups[:-1])


def reach_probability(model: ExplicitModel, target: np.ndarray, *, maximise: bool) -> np.ndarray:
    x = target.astype(float)
    for _ in range(100_000):
        new = np.where(target, 1.0, _bellman(model, x, maximise))
        if np.abs(new - x).max() < 1e-14:
            break
        x = new
    return x


def reach_reward(model: ExplicitModel, target: np.ndarray, *, maximise: bool) -> np.ndarray:
    """PRISM's R[F target] with the state rewards of the first reward model: infinite where the
    target is not almost sure under the best strategy (Rmin: Pmax < 1) or under the worst one
    (Rmax: Pmin < 1). Enough for positive rewards, as in the robot's "time"."""
    sure = reach_probability(model, target, maximise=not maximise)
    finite = sure > 1 - 1e-9
    allowed = np.ones(model.num_choices, dtype=bool)
    if not maximise:  # Rmin: only choices that keep the target almost sure
        inside = model.transitions @ finite.astype(float)
        allowed = inside > 1 - 1e-9
    reward = model.reward_models[0].state
    assert reward is not None
    x = np.zeros(model.num_states)
    for _ in range(100_000):
        per_choice = model.transitions @ x
        per_choice = np.where(allowed, per_choice, -np.inf if maximise else np.inf)
        best = (np.maximum if maximise else np.minimum).reduceat(per_choice, model.row_groups[:-1])
        new = np.where(target | ~finite, 0.0, reward + best)
        if np.abs(new - x).max() < 1e-13:
            break
        x = new
    return np.where(finite, x, np.inf)


def robot_atom_values(model: ExplicitModel, atoms: tuple[Expr, ...]) -> np.ndarray:
    s = model.state_values[:, 0]
    rows = []
    for atom in atoms:
        if isinstance(atom, LabelRef):
            rows.append(model.label(atom.name))
        elif isinstance(atom, Binary) and atom.op is BinaryOp.OR:
            left, right = atom.left, atom.right
            assert isinstance(left, LabelRef) and isinstance(right, LabelRef)
            rows.append(model.label(left.name) | model.label(right.name))
        elif atom == Binary(BinaryOp.NE, Ident("s"), IntLit(3)):
            rows.append(s != 3)
        else:
            raise AssertionError(atom)
    return np.array(rows)


def robot_value(formula: Expr, *, reward: bool, maximise: bool) -> float:
    model = robot()
    atoms = extract_atoms(formula)
    dfa = to_dfa(formula, atoms)
    prod = product(model, dfa, robot_atom_values(model, atoms))
    solve = reach_reward if reward else reach_probability
    values = solve(prod.model, prod.accepting, maximise=maximise)
    return float(values[prod.initial_map[0]])


g1, g2, hz = LabelRef("goal1"), LabelRef("goal2"), LabelRef("hazard")


def test_robot_product_size() -> None:
    # (F goal1) | (F goal2), 2 DFA states: (s0,q0), (s1,q0), (s4,q0) before a goal, then
    # (s2,acc), (s3,acc), (s5,acc), (s4,acc) (s4 again from s5): 7 states
    model = robot()
    formula = Or(F(g1), F(g2))
    dfa = to_dfa(formula)
    prod = product(model, dfa, robot_atom_values(model, dfa.atoms))
    assert model.num_states == 6 and model.num_choices == 10
    assert dfa.num_states == 2 and prod.num_states == 7
    assert sorted(prod.state_of[prod.accepting].tolist()) == [2, 3, 4, 5]


# expected values: the `// RESULT:` lines of smg/robot/robot.prism.cosafe.props (PRISM-games)
@pytest.mark.parametrize(
    ("formula", "maximise", "expected"),
    [
        (Or(F(g1), F(g2)), True, 1.0),
        (Or(F(g1), F(g2)), False, 1.0),
        (X(F(Or(g1, g2))), True, 1.0),
        (X(X(g2)), True, 0.96),
        (X(X(X(g2))), True, 0.99),
        (X(F(g1)), True, 0.5),
        (X(X(g1)), True, 0.1),
        (U(Not(hz), And(g1, X(g1))), True, 0.01),
        (U(Not(hz), And(g1, X(X(g1)))), True, 0.1),
    ],
)
def test_robot_probabilities(formula: Expr, maximise: bool, expected: float) -> None:
    value = robot_value(formula, reward=False, maximise=maximise)
    assert value == pytest.approx(expected, abs=1e-9)


# expected values: smg/robot/robot.prism.rewards.cosafe.props (PRISM-games)
@pytest.mark.parametrize(
    ("formula", "maximise", "expected"),
    [
        (Or(F(g1), F(g2)), False, 1.2),
        (Or(F(g1), F(g2)), True, 3.5),
        (X(F(Or(g1, g2))), False, 1.2),
        (F(X(Or(g1, g2))), False, 1.2),
        (X(X(Or(g1, g2))), False, 2.0),
        (X(X(g2)), False, float("inf")),
        (F(g2), False, float(Fraction(19, 15))),
        (U(Binary(BinaryOp.NE, Ident("s"), IntLit(3)), g2), False, float(Fraction(19, 15))),
    ],
)
def test_robot_rewards(formula: Expr, maximise: bool, expected: float) -> None:
    value = robot_value(formula, reward=True, maximise=maximise)
    assert value == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize(
    ("file", "reward"),
    [("robot.prism.cosafe.props", False), ("robot.prism.rewards.cosafe.props", True)],
)
def test_robot_props_files(benchmarks: Path, file: str, reward: bool) -> None:
    """Every property of the PRISM-games props file, parsed, against its `// RESULT:` line."""
    parser = pytest.importorskip("posgmc.syntax.parser")
    text = (benchmarks / "smg" / "robot" / file).read_text()
    props = parser.parse_properties(text, file=file)
    assert len(props.properties) == (12 if reward else 9)
    for prop in props.properties:
        expected = prop.expected[0].text
        query = prop.expr
        if reward:
            assert isinstance(query, RewardQuery)
            objective = query.objective
            assert objective.target is not None
            # R[F phi] arrives as a reachability reward over the state formula phi
            path = F(objective.target) if objective.kind is RewardKind.REACH else objective.target
        else:
            assert isinstance(query, ProbQuery)
            path = query.path
        maximise = query.direction is Direction.MAX
        if expected == "Error:co-safe":
            with pytest.raises(UnsupportedError, match="not co-safe") as info:
                to_dfa(path)
            span = info.value.span
            assert span is not None and span.file == file
            assert text.splitlines()[span.line - 1][span.column - 1] == "G"
            continue
        value = robot_value(path, reward=reward, maximise=maximise)
        if expected == "Infinity":
            assert value == float("inf"), prop.text
        else:
            assert value == pytest.approx(float(Fraction(expected)), abs=1e-9), prop.text


# -- the automaton over a model's own letters (issue #13) ------------------------------------------


@given(random_models(), st.sampled_from(FORMULAS))
@settings(max_examples=60, deadline=None)
def test_model_letter_automaton_agrees_with_the_full_one(
    model: ExplicitModel, formula: Expr
) -> None:
    # along every path of the model, both automata accept at the same steps: a joint breadth-first
    # walk over (model state, full DFA state, model-letter DFA state)
    full = to_dfa(formula)
    values = atom_values(model, full)
    own = to_dfa(formula, alphabet=letter_graph(model, values))
    letters = pack_letters(values)
    cols = own.columns(letters)
    graph = [set(model.transitions[c].indices.tolist()) for c in range(model.num_choices)]
    seen = set()
    todo = [
        (int(s), int(full.delta[full.initial, letters[s]]), int(own.delta[own.initial, cols[s]]))
        for s in model.initial_states
    ]
    while todo:
        s, p, q = todo.pop()
        if (s, p, q) in seen:
            continue
        seen.add((s, p, q))
        assert full.accepting[p] == own.accepting[q]
        if full.rejecting_sink is not None and p == full.rejecting_sink:
            assert q == own.rejecting_sink
        for c in range(model.row_groups[s], model.row_groups[s + 1]):
            for t in graph[c]:
                todo.append((t, int(full.delta[p, letters[t]]), int(own.delta[q, cols[t]])))
    assert own.num_states <= full.num_states + 1  # + the "false" filler


def ring(n: int) -> tuple[ExplicitModel, Expr]:
    """A dtmc cycling through n states (stay or move on, 1/2 each), atom i true in state i, and
    the conjunction of F over all atoms (issue #13: 13 atoms took 110 s and 4.4 GB)."""
    rows = [[0.0] * n for _ in range(n)]
    for i in range(n):
        rows[i][i] += 0.5
        rows[i][(i + 1) % n] += 0.5
    labels = {f"l{i}": [j == i for j in range(n)] for i in range(n)}
    model = make_model(ModelType.DTMC, list(range(n + 1)), rows, labels=labels)
    formula: Expr = F(LabelRef("l0"))
    for i in range(1, n):
        formula = And(formula, F(LabelRef(f"l{i}")))
    return model, formula


def test_conjunction_of_13_eventualities_on_a_ring_is_small() -> None:
    model, formula = ring(13)
    atoms = extract_atoms(formula)
    values = np.array([model.label(x.name) for x in atoms])  # type: ignore[attr-defined]
    dfa = to_dfa(formula, atoms, alphabet=letter_graph(model, values))
    # from state 0 the visited atoms form an arc 0..k of the ring: the initial formula, the 12
    # arcs k < 12 still waiting, "true" and the "false" filler (hand count; the minimal automaton
    # over all letters has 2**13 states)
    assert dfa.num_states == 15 and dfa.delta.shape == (dfa.num_states, 13)
    prod = product(model, dfa, values)
    # (i, arc 0..i) for i = 0..12, then (i, true) for the 12 states after the arc closed at 12
    assert prod.model.num_states == 25 and prod.accepting.sum() == 13
