"""Co-safe LTL to DFA: atoms, co-safety, hand-checked automata and words, and random formulas
checked against a reference LTL evaluator on lasso words (good-prefix semantics)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.engines.ltl import Dfa, extract_atoms, is_cosafe, to_dfa
from posgmc.engines.ltl.dfa import _good_prefix_closure
from posgmc.errors import LimitError, SemanticError, SourceSpan, UnsupportedError
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    BoolLit,
    Expr,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    ProbQuery,
    Temporal,
    TemporalOp,
    TimeBound,
)
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
    dfa_accepts_lasso,
    same_language,
    satisfies,
    violating_extension,
)

hazard, goal1 = LabelRef("hazard"), LabelRef("goal1")


def word(dfa: Dfa, *letters: str) -> list[int]:
    """Letters written as strings of atom names joined by '+', '' for the empty letter."""
    index = {atom.name: i for i, atom in enumerate(dfa.atoms) if isinstance(atom, LabelRef)}
    out = []
    for text in letters:
        bits = 0
        for name in filter(None, text.split("+")):
            bits |= 1 << index[name]
        out.append(bits)
    return out


def check_against_reference(formula: Expr, dfa: Dfa, w: Sequence[int]) -> None:
    """Good-prefix semantics, decided independently of the automaton's verdict: an accepted word
    must satisfy the formula under sample extensions; a rejected one must have an extension,
    found in the automaton, that the reference evaluator confirms violates the formula."""
    if dfa.accepts(w):
        for u, v in ([], [0]), ([], [dfa.num_letters - 1]), ([0], [1 % dfa.num_letters, 0]):
            assert satisfies(formula, dfa.atoms, list(w) + u, v)
    else:
        ext = violating_extension(dfa, w)
        if ext is None:
            # PRISM's acceptance may lag the first good prefix (a state formula needs a letter:
            # R[X true] collects one step), but only where every continuation is accepted later
            closure = _good_prefix_closure(dfa.delta, dfa.accepting)
            assert closure[dfa.run(w)], "a rejected word must have a violating extension"
            return
        u, v = ext
        assert not satisfies(formula, dfa.atoms, list(w) + u, v)


# -- atoms -----------------------------------------------------------------------------------


def test_atoms_are_maximal_temporal_free_subformulas_without_negation() -> None:
    c_eq_2 = Binary(BinaryOp.EQ, Ident("c"), IntLit(2))
    goal_or = Or(LabelRef("goal1"), LabelRef("goal2"))
    path = U(Not(hazard), And(goal1, X(And(goal1, c_eq_2))))
    assert extract_atoms(path) == (hazard, goal1, And(goal1, c_eq_2))
    assert extract_atoms(X(F(goal_or))) == (goal_or,)
    # boolean literals are constants, not atoms; negations share the atom
    assert extract_atoms(Or(F(BoolLit(True)), U(Not(a), a))) == (a,)


def test_nested_query_is_an_atom() -> None:
    nested = ProbQuery(None, None, None, F(a))
    assert extract_atoms(F(nested)) == (nested,)


def test_temporal_operator_under_non_boolean_expression_is_rejected_with_span() -> None:
    span = SourceSpan(3, 9, 3, 25)
    bad = Ite(Ident("x"), F(a), b, span=span)
    with pytest.raises(UnsupportedError, match="inside a Ite expression") as info:
        extract_atoms(F(bad))
    assert info.value.span == span


# -- hand-checked automata -------------------------------------------------------------------
# State counts: the minimal DFAs, derived by progressing the formula by hand (comments list the
# states); an accepting state means "good prefix read".


def test_eventually() -> None:
    dfa = to_dfa(F(a))  # states: F a, true
    assert dfa.num_states == 2 and dfa.rejecting_sink is None
    assert not dfa.accepts([]) and not dfa.accepts(word(dfa, "", "", ""))
    assert dfa.accepts(word(dfa, "a")) and dfa.accepts(word(dfa, "", "", "a", ""))


def test_until() -> None:
    dfa = to_dfa(U(a, b))  # states: a U b, false, true
    assert dfa.num_states == 3 and dfa.rejecting_sink is not None
    assert dfa.accepts(word(dfa, "b")) and dfa.accepts(word(dfa, "a", "a", "a+b"))
    assert not dfa.accepts(word(dfa, "a", "a"))
    assert dfa.run(word(dfa, "a", "")) == dfa.rejecting_sink
    assert dfa.run(word(dfa, "", "b")) == dfa.rejecting_sink


def test_nested_eventually() -> None:
    dfa = to_dfa(F(And(a, F(b))))  # states: F(a & F b), F b | F(a & F b), true
    assert dfa.num_states == 3 and dfa.rejecting_sink is None
    assert dfa.accepts(word(dfa, "a", "b")) and dfa.accepts(word(dfa, "a+b"))
    assert not dfa.accepts(word(dfa, "b", "a"))
    assert dfa.accepts(word(dfa, "b", "a", "", "b"))


def test_disjunction_of_eventualities() -> None:
    dfa = to_dfa(Or(F(a), F(b)))  # states: F a | F b, true
    assert dfa.num_states == 2
    assert dfa.accepts(word(dfa, "b")) and dfa.accepts(word(dfa, "", "a"))
    assert not dfa.accepts(word(dfa, "", "", ""))


def test_next_next() -> None:
    dfa = to_dfa(X(X(a)))  # states: X X a, X a, a, false, true
    assert dfa.num_states == 5
    assert dfa.accepts(word(dfa, "", "", "a"))
    assert not dfa.accepts(word(dfa, "a", "a"))
    assert dfa.run(word(dfa, "a", "a", "")) == dfa.rejecting_sink
    assert dfa.run(word(dfa, "a", "a")) != dfa.rejecting_sink


def test_eventually_next() -> None:
    # F X a == X F a: a at some position >= 1. States: F X a, a | F X a, true
    dfa = to_dfa(F(X(a)))
    assert dfa.num_states == 3 and dfa.rejecting_sink is None
    assert not dfa.accepts(word(dfa, "a"))
    assert dfa.accepts(word(dfa, "a", "a")) and dfa.accepts(word(dfa, "", "", "a"))


def test_robot_until_formula() -> None:
    # robot.prism.cosafe.props: !"hazard" U ("goal1" & X "goal1"). States (phi = the formula):
    # phi, goal1 | phi (after goal1 & !hazard), goal1 (after goal1 & hazard), false, true
    phi = U(Not(hazard), And(goal1, X(goal1)))
    dfa = to_dfa(phi)
    assert dfa.atoms == (hazard, goal1)
    assert dfa.num_states == 5
    assert dfa.accepts(word(dfa, "goal1", "goal1"))
    assert dfa.accepts(word(dfa, "", "", "goal1+hazard", "goal1"))
    assert not dfa.accepts(word(dfa, "goal1", "", "goal1"))
    assert dfa.run(word(dfa, "goal1", "hazard")) == dfa.rejecting_sink
    assert dfa.run(word(dfa, "hazard")) == dfa.rejecting_sink
    for w in (["goal1", "", "goal1", "goal1"], ["goal1+hazard", ""], ["", "goal1+hazard"]):
        check_against_reference(phi, dfa, word(dfa, *w))


def test_bounded_eventually() -> None:
    dfa = to_dfa(F(a, le=3))  # states: F<=3 a, F<=2 a, F<=1 a, a, false, true
    assert dfa.num_states == 6
    assert dfa.accepts(word(dfa, "", "", "", "a"))
    assert dfa.run(word(dfa, "", "", "", "")) == dfa.rejecting_sink


def test_bounded_globally() -> None:
    dfa = to_dfa(G(a, le=2))  # states: G<=2 a, G<=1 a, a, false, true
    assert dfa.num_states == 5
    assert dfa.accepts(word(dfa, "a", "a", "a"))
    assert not dfa.accepts(word(dfa, "a", "a"))
    assert dfa.run(word(dfa, "a", "")) == dfa.rejecting_sink


def test_lower_and_interval_bounds() -> None:
    # F>=2 a: a at some position >= 2; F[1,2] a: a at position 1 or 2
    later = to_dfa(Temporal(TemporalOp.EVENTUALLY, (a,), TimeBound(lower=IntLit(2))))
    assert not later.accepts(word(later, "a", "a"))
    assert later.accepts(word(later, "a", "a", "", "a"))
    window = to_dfa(Temporal(TemporalOp.EVENTUALLY, (a,), TimeBound(IntLit(1), False, IntLit(2))))
    assert not window.accepts(word(window, "a"))
    assert window.accepts(word(window, "", "", "a"))
    assert window.run(word(window, "a", "", "", "a")) == window.rejecting_sink
    # F<2 a = F<=1 a
    below_2 = TimeBound(upper=IntLit(2), upper_strict=True)
    strict = to_dfa(Temporal(TemporalOp.EVENTUALLY, (a,), below_2))
    assert same_language(strict, to_dfa(F(a, le=1)))


def test_negations_of_safety_operators_are_cosafe() -> None:
    # !G a = F !a; !(a W b) = !b U (!a & !b); !(a R b) = !a U !b
    assert same_language(to_dfa(Not(G(a))), to_dfa(F(Not(a))))
    assert is_cosafe(Not(W(a, b))) and is_cosafe(Not(R(a, b)))
    # "& F true" keeps !a and !b separate atoms (a temporal-free "!a & !b" would be one atom)
    not_a_and_not_b = And(Not(a), And(Not(b), F(BoolLit(True))))
    assert same_language(to_dfa(Not(W(a, b))), to_dfa(U(Not(b), not_a_and_not_b), (a, b)))
    assert same_language(to_dfa(Not(R(a, b))), to_dfa(U(Not(a), Not(b)), (a, b)))
    assert is_cosafe(W(a, b, le=2)) and is_cosafe(Implies(G(a), F(b)))


def test_valid_formula_is_accepted_when_progression_sees_it() -> None:
    # (X a & X b) | X !a | X !b is valid; progression reaches true after two letters, and that is
    # where PRISM stops collecting the reward of R[...] (its cosafety tests, e.g. R[X true] = one
    # step); the first good prefix (the empty word) is still available as an option
    phi = Or(And(X(a), X(b)), Or(X(Not(a)), X(Not(b))))
    prism = to_dfa(phi)
    assert not prism.accepts([0]) and prism.accepts([0, 0])
    exact = to_dfa(phi, exact_good_prefixes=True)
    assert exact.num_states == 1 and exact.accepts([])


# -- not co-safe ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        lambda s: F(Temporal(TemporalOp.GLOBALLY, (a,), span=s)),
        lambda s: Temporal(TemporalOp.GLOBALLY, (a,), span=s),
        lambda s: And(Temporal(TemporalOp.GLOBALLY, (Not(hazard),), span=s), G(F(goal1))),
        lambda s: Not(Temporal(TemporalOp.EVENTUALLY, (a,), span=s)),
        lambda s: Temporal(TemporalOp.WEAK_UNTIL, (a, b), span=s),
        lambda s: Temporal(TemporalOp.GLOBALLY, (a,), TimeBound(lower=IntLit(1)), span=s),
    ],
    ids=["FG", "G", "G-and-GF", "not-F", "W", "G>=1"],
)
def test_not_cosafe_is_rejected_at_the_operator(make) -> None:  # type: ignore[no-untyped-def]
    span = SourceSpan(2, 14, 2, 20, "robot.props")
    path = make(span)
    assert not is_cosafe(path)
    with pytest.raises(UnsupportedError, match="formula is not co-safe LTL") as info:
        to_dfa(path)
    assert info.value.span == span
    assert info.value.hint and "G<=k" in info.value.hint


def test_not_cosafe_message_names_the_negated_operator() -> None:
    with pytest.raises(UnsupportedError, match='"F" under a negation'):
        to_dfa(Not(F(a)))


def test_trivial_globally_is_cosafe() -> None:
    # G true simplifies to true
    assert is_cosafe(And(G(BoolLit(True)), F(a)))


# -- bounds and limits ---------------------------------------------------------------------


def test_empty_step_interval_is_an_error_with_span() -> None:
    span = SourceSpan(1, 9, 1, 11)
    below_0 = TimeBound(upper=IntLit(0), upper_strict=True, span=span)
    path = Temporal(TemporalOp.EVENTUALLY, (a,), below_0)
    with pytest.raises(SemanticError, match="admits no step") as info:
        to_dfa(path)
    assert info.value.span == span


def test_negative_step_bound_is_an_error_with_span() -> None:
    span = SourceSpan(1, 11, 1, 13)
    path = Temporal(TemporalOp.EVENTUALLY, (a,), TimeBound(upper=IntLit(-2, span=span)))
    with pytest.raises(SemanticError, match="must not be negative") as info:
        to_dfa(path)
    assert info.value.span == span


def test_symbolic_step_bound_needs_an_evaluator() -> None:
    span = SourceSpan(1, 8, 1, 9)
    path = Temporal(TemporalOp.EVENTUALLY, (a,), TimeBound(upper=Ident("k", span=span)))
    with pytest.raises(UnsupportedError, match="constant integer") as info:
        to_dfa(path)
    assert info.value.span == span
    dfa = to_dfa(path, bound_value=lambda e: 2 if e == Ident("k") else 0)
    assert same_language(dfa, to_dfa(F(a, le=2)))


def test_bounded_next_is_rejected() -> None:
    span = SourceSpan(1, 2, 1, 5)
    path = Temporal(TemporalOp.NEXT, (a,), TimeBound(upper=IntLit(2), span=span))
    with pytest.raises(UnsupportedError, match="cannot have a step bound") as info:
        to_dfa(path)
    assert info.value.span == span


def test_too_many_atoms() -> None:
    span = SourceSpan(4, 1, 4, 80)
    path = F(LabelRef("l0"))
    for i in range(1, 17):
        path = Or(path, F(LabelRef(f"l{i}")))
    path = Temporal(TemporalOp.NEXT, (path,), span=span)
    with pytest.raises(UnsupportedError, match="17 distinct atoms") as info:
        to_dfa(path)
    assert info.value.span == span


def test_state_limit() -> None:
    with pytest.raises(
        LimitError, match="too large: 11 states found so far .* the limits are 10 states"
    ):
        to_dfa(F(a, le=50), max_states=10)


def test_table_limit_states_the_measured_size() -> None:
    # F a & F b & ... over all 2**8 letters: the table passes 1000 entries at the 4th state
    atoms = [LabelRef(f"l{i}") for i in range(8)]
    path = F(atoms[0])
    for x in atoms[1:]:
        path = And(path, F(x))
    with pytest.raises(
        LimitError, match=r"over 256 letters; the limits are 100000 states and 1000 table"
    ):
        to_dfa(path, max_table=1000)


def test_subsumption_keeps_bounded_obligations_small() -> None:
    # F<=k (a & F<=k b): without merging F<=i b | F<=j b the states would be subsets of pending
    # deadlines; with it, a state is (time left for a, latest deadline for b)
    dfa = to_dfa(F(And(a, F(b, le=6)), le=6))
    assert dfa.num_states < 60


def test_atoms_may_be_given_in_another_order() -> None:
    dfa = to_dfa(U(a, b), (b, a))
    assert dfa.accepts([0b01])  # bit 0 is b
    assert not dfa.accepts([0b10, 0b00])
    with pytest.raises(ValueError, match="not among the atoms"):
        to_dfa(U(a, b), (a,))


# -- random formulas -----------------------------------------------------------------------

LETTERS = st.integers(0, 7)  # masked to the alphabet in the tests


def _mask(letters: list[int], dfa: Dfa) -> list[int]:
    return [x % dfa.num_letters for x in letters]


@settings(max_examples=150, deadline=None)
@given(
    FORMULAS,
    st.lists(LETTERS, max_size=4),
    st.lists(LETTERS, max_size=3),
    st.lists(LETTERS, min_size=1, max_size=3),
)
def test_random_formulas_agree_with_reference(
    formula: Expr, w: list[int], prefix: list[int], loop: list[int]
) -> None:
    if not is_cosafe(formula):
        with pytest.raises(UnsupportedError, match="not co-safe"):
            to_dfa(formula)
        return
    dfa = to_dfa(formula)
    w, prefix, loop = _mask(w, dfa), _mask(prefix, dfa), _mask(loop, dfa)
    # an infinite word satisfies a co-safe formula iff its run meets acceptance
    assert dfa_accepts_lasso(dfa, prefix, loop) == satisfies(formula, dfa.atoms, prefix, loop)
    # accepted finite words are exactly the good prefixes
    check_against_reference(formula, dfa, w)
    # minimal: one accepting state at most, absorbing; one rejecting sink at most
    acc = np.flatnonzero(dfa.accepting)
    assert acc.size <= 1
    assert all((dfa.delta[q] == q).all() for q in acc)
    if dfa.rejecting_sink is not None:
        assert not dfa.accepting[dfa.rejecting_sink]
        assert (dfa.delta[dfa.rejecting_sink] == dfa.rejecting_sink).all()


@settings(max_examples=100, deadline=None)
@given(FORMULAS)
def test_minimisation_keeps_the_language(formula: Expr) -> None:
    if not is_cosafe(formula):
        return
    for exact in (True, False):
        raw = to_dfa(formula, minimal=False, exact_good_prefixes=exact)
        small = to_dfa(formula, exact_good_prefixes=exact)
        assert small.num_states <= raw.num_states
        assert same_language(raw, small)


@settings(max_examples=100, deadline=None)
@given(FORMULAS, st.lists(LETTERS, max_size=5))
def test_progression_acceptance_implies_good_prefix(formula: Expr, w: list[int]) -> None:
    """Progression reaching true is a good prefix; the exact automaton accepts no later."""
    if not is_cosafe(formula):
        return
    lagging = to_dfa(formula, exact_good_prefixes=False, minimal=False)
    exact = to_dfa(formula)
    w = _mask(w, exact)
    if lagging.accepts(w):
        assert exact.accepts(w)
