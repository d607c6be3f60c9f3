"""General LTL through limit-deterministic Büchi automata: the automaton accepts exactly the lasso
words that satisfy the formula (checked by the reference evaluator), its product answers hand-
derived probabilities, and on random small models the two constructions (DFA for co-safe formulas,
LDBA for all) and a formula and its negation agree."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines import objectives as obj
from posgmc.engines.ltl import (
    accepting_cycles,
    accepting_end_components,
    extract_atoms,
    is_cosafe,
    omega_product,
    product,
    to_dfa,
    to_ldba,
)
from posgmc.errors import LimitError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType
from posgmc.syntax.ast import Expr
from tests.engines.ltl.ltl_reference import (
    FORMULAS,
    And,
    F,
    G,
    Implies,
    Not,
    Or,
    R,
    U,
    W,
    X,
    a,
    b,
    c,
    satisfies,
)


def lasso(prefix: list[int], loop: list[int], num_atoms: int) -> tuple[ExplicitModel, np.ndarray]:
    """The word ``prefix loop loop ...`` as a one-path dtmc and its atom values."""
    word = prefix + loop
    n = len(word)
    T = np.zeros((n, n))
    for i in range(n):
        T[i, i + 1 if i + 1 < n else len(prefix)] = 1.0
    model = make_model(ModelType.DTMC, np.arange(n + 1), T, initial_states=[0])
    values = np.array([[(w >> k) & 1 for w in word] for k in range(num_atoms)], dtype=bool)
    return model, values.reshape(num_atoms, n)


def ldba_accepts(formula: Expr, prefix: list[int], loop: list[int]) -> bool:
    """Whether some run of the formula's LDBA on the lasso word is accepting (an accepting cycle
    of the product with the one-path dtmc)."""
    atoms = extract_atoms(formula)
    model, values = lasso(prefix, loop, len(atoms))
    ldba = to_ldba(formula, atoms, alphabet=np.arange(1 << len(atoms)))
    prod = omega_product(model, ldba, values)
    return bool(accepting_cycles(prod)[prod.initial_map[0]])


HAND = [
    (G(F(a)), [], [0], False),
    (G(F(a)), [], [0, 1], True),
    (G(F(a)), [1, 1], [0], False),
    (F(G(a)), [0, 0], [1], True),
    (F(G(a)), [], [1, 0], False),
    (G(Implies(a, F(b))), [], [1, 2], True),  # a, then b, forever
    (G(Implies(a, F(b))), [1, 2], [1], False),  # the last a is never answered
    (And(G(F(a)), F(G(b))), [], [3, 2], True),
    (And(G(F(a)), F(G(b))), [], [1, 2], False),
    (U(a, G(b)), [1, 1], [2], True),
    (U(a, G(b)), [1, 0], [2], False),
    (G(X(F(a))), [], [0, 0, 1], True),  # an obligation renewed as soon as it is met
    (R(a, F(b)), [], [0], False),
    (W(a, G(F(b))), [1, 1], [0, 2], True),
]


@pytest.mark.parametrize(("formula", "prefix", "loop", "expected"), HAND)
def test_hand_checked_words(
    formula: Expr, prefix: list[int], loop: list[int], expected: bool
) -> None:
    atoms = extract_atoms(formula)
    assert satisfies(formula, atoms, prefix, loop) is expected  # the reference agrees by hand
    assert ldba_accepts(formula, prefix, loop) is expected


def test_g_f_a_automaton_is_small() -> None:
    """G F a: the residual G F a (initial component) and one accepting component that awaits
    one monitor (pending F a or not), plus the sink: 4 states at most before pruning; the
    accepting states are the ones entered when the monitor succeeded."""
    ldba = to_ldba(G(F(a)), (a,), alphabet=np.arange(2))
    assert ldba.num_states <= 6
    assert ldba.accepting.any()
    assert not ldba.accepting[ldba.initial_component].any()
    # the accepting component is deterministic and closed: no jumps from there
    acc = ~ldba.initial_component
    assert np.all(np.diff(ldba.jump_ptr)[acc] == 0)
    assert np.all(~ldba.initial_component[ldba.delta[acc]])


def test_too_many_guesses_are_a_limit_error() -> None:
    atoms = (a, b, c)
    formula: Expr = G(F(a))
    for x in (b, c, X(a), X(b), X(c), X(X(a))):
        formula = And(formula, G(F(x)))  # 7 distinct G F: 14 unbounded sub-formulas
    with pytest.raises(LimitError, match="unbounded temporal sub-formulas"):
        to_ldba(formula, atoms, alphabet=np.arange(8))


@settings(max_examples=150, deadline=None)
@given(
    FORMULAS,
    st.lists(st.integers(0, 7), max_size=3),
    st.lists(st.integers(0, 7), min_size=1, max_size=3),
)
def test_random_formulas_agree_with_reference(
    formula: Expr, prefix: list[int], loop: list[int]
) -> None:
    atoms = extract_atoms(formula)
    size = 1 << len(atoms)
    prefix, loop = [x % size for x in prefix], [x % size for x in loop]
    try:
        accepted = ldba_accepts(formula, prefix, loop)
    except LimitError:
        return
    assert accepted == satisfies(formula, atoms, prefix, loop)


# -- probabilities -----------------------------------------------------------------------------


def _atom_rows(atoms: tuple[Expr, ...], values: np.ndarray) -> np.ndarray:
    """bool[len(atoms), S]: each atom (a state formula over a, b, c) in each state, evaluated by
    the reference evaluator from ``values`` (one row per label a, b, c)."""
    letters = [int(sum(int(v) << k for k, v in enumerate(col))) for col in values.T]
    rows = [[satisfies(atom, (a, b, c), [], [x]) for x in letters] for atom in atoms]
    return np.array(rows, dtype=bool).reshape(len(atoms), values.shape[1])


def ldba_pmax(model: ExplicitModel, formula: Expr, values: np.ndarray) -> float:
    atoms = extract_atoms(formula)
    ldba = to_ldba(formula, atoms, alphabet=np.arange(1 << len(atoms)))
    prod = omega_product(model, ldba, _atom_rows(atoms, values))
    goal = accepting_end_components(prod)
    r = obj.reach_probability(prod.model, goal, maximize=np.ones(prod.num_states, dtype=bool))
    i = prod.initial_map[0]
    assert r.lower[i] <= r.upper[i]
    return float(r.values[i])


def dfa_pmax(model: ExplicitModel, formula: Expr, values: np.ndarray) -> float:
    atoms = extract_atoms(formula)
    dfa = to_dfa(formula, atoms)
    prod = product(model, dfa, _atom_rows(atoms, values))
    maximize = np.ones(prod.num_states, dtype=bool)
    r = obj.reach_probability(prod.model, prod.accepting, maximize=maximize)
    return float(r.values[prod.initial_map[0]])


# dtmc by hand: s0 -> s1 (1/2, absorbing, "a") or s2 (1/2); s2 -> s2 (1/2, "b") or s3 (1/2, "a");
# s3 -> s2. From s2 the chain alternates between b and a forever.
_DTMC_T = np.array(
    [[0, 0.5, 0.5, 0], [0, 1, 0, 0], [0, 0, 0.5, 0.5], [0, 0, 1, 0]], dtype=float
)
_DTMC_VALUES = np.array([[0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 0]], dtype=bool)  # a, b, c


@pytest.mark.parametrize(
    ("formula", "expected"),
    [
        (F(G(a)), 0.5),  # only s1
        (G(F(a)), 1.0),  # s1 forever, or s3 infinitely often
        (G(F(b)), 0.5),
        (And(G(F(a)), G(F(b))), 0.5),
        (G(Implies(b, X(Or(a, b)))), 1.0),
        (F(G(Not(b))), 0.5),
        (G(Implies(a, X(a))), 0.5),  # from s3 the next state is s2 (not a)
    ],
)
def test_dtmc_by_hand(formula: Expr, expected: float) -> None:
    model = make_model(ModelType.DTMC, np.arange(5), _DTMC_T, initial_states=[0])
    assert model.num_states == 4
    assert ldba_pmax(model, formula, _DTMC_VALUES) == pytest.approx(expected, abs=1e-6)


@st.composite
def small_models(draw: st.DrawFn) -> tuple[ExplicitModel, np.ndarray]:
    """A random mdp (or dtmc) of 2-4 states with 1-2 choices each and random atom values."""
    S = draw(st.integers(2, 4))
    dtmc = draw(st.booleans())
    rows = []
    groups = [0]
    for _ in range(S):
        k = 1 if dtmc else draw(st.integers(1, 2))
        for _ in range(k):
            weights = draw(st.lists(st.integers(0, 3), min_size=S, max_size=S))
            if sum(weights) == 0:
                weights[draw(st.integers(0, S - 1))] = 1
            rows.append(np.array(weights, dtype=float) / sum(weights))
        groups.append(groups[-1] + k)
    kind = ModelType.DTMC if dtmc else ModelType.MDP
    model = make_model(kind, np.array(groups), np.array(rows), initial_states=[0])
    values = np.array(draw(st.lists(st.lists(st.booleans(), min_size=S, max_size=S),
                                    min_size=3, max_size=3)), dtype=bool)
    return model, values


def _small_formula(formula: Expr) -> bool:
    return len(extract_atoms(formula)) <= 3


@settings(max_examples=80, deadline=None)
@given(small_models(), FORMULAS.filter(_small_formula))
def test_cosafe_formulas_give_the_dfa_value(model_values, formula: Expr) -> None:  # type: ignore[no-untyped-def]
    """Two constructions, one number: on a co-safe formula the LDBA's Pmax is the DFA's."""
    if not is_cosafe(formula):
        return
    model, values = model_values
    try:
        via_ldba = ldba_pmax(model, formula, values)
    except LimitError:
        return
    assert via_ldba == pytest.approx(dfa_pmax(model, formula, values), abs=1e-5)


@settings(max_examples=80, deadline=None)
@given(small_models(), FORMULAS.filter(_small_formula))
def test_a_formula_and_its_negation(model_values, formula: Expr) -> None:  # type: ignore[no-untyped-def]
    """On a dtmc P(phi) + P(!phi) = 1; on an mdp Pmax(phi) + Pmax(!phi) >= 1 (the two optimal
    schedulers differ), each automaton built separately."""
    model, values = model_values
    try:
        yes = ldba_pmax(model, formula, values)
        no = ldba_pmax(model, Not(formula), values)
    except LimitError:
        return
    if model.model_type is ModelType.DTMC:
        assert yes + no == pytest.approx(1.0, abs=1e-5)
    else:
        assert yes + no >= 1.0 - 1e-5
