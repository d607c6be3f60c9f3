"""Test helpers for co-safe LTL: formula constructors and a reference LTL evaluator on lasso words.

The evaluator implements the textbook semantics of LTL with step-bounded operators directly on the
syntax tree, independently of posgmc's NNF and progression, on ultimately periodic words
``u v^omega`` (positions ``0 .. len(u)+len(v)-1``; after the last one comes ``len(u)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

from hypothesis import strategies as st

from posgmc.engines.ltl import Dfa
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    BoolLit,
    Expr,
    IntLit,
    LabelRef,
    Temporal,
    TemporalOp,
    TimeBound,
    Unary,
    UnaryOp,
)

# -- constructors ----------------------------------------------------------------------------

a, b, c = LabelRef("a"), LabelRef("b"), LabelRef("c")


def _bound(le: int | None) -> TimeBound | None:
    return None if le is None else TimeBound(upper=IntLit(le))


def X(f: Expr) -> Expr:
    return Temporal(TemporalOp.NEXT, (f,))


def F(f: Expr, le: int | None = None) -> Expr:
    return Temporal(TemporalOp.EVENTUALLY, (f,), _bound(le))


def G(f: Expr, le: int | None = None) -> Expr:
    return Temporal(TemporalOp.GLOBALLY, (f,), _bound(le))


def U(f: Expr, g: Expr, le: int | None = None) -> Expr:
    return Temporal(TemporalOp.UNTIL, (f, g), _bound(le))


def W(f: Expr, g: Expr, le: int | None = None) -> Expr:
    return Temporal(TemporalOp.WEAK_UNTIL, (f, g), _bound(le))


def R(f: Expr, g: Expr, le: int | None = None) -> Expr:
    return Temporal(TemporalOp.RELEASE, (f, g), _bound(le))


def Not(f: Expr) -> Expr:
    return Unary(UnaryOp.NOT, f)


def And(f: Expr, g: Expr) -> Expr:
    return Binary(BinaryOp.AND, f, g)


def Or(f: Expr, g: Expr) -> Expr:
    return Binary(BinaryOp.OR, f, g)


def Implies(f: Expr, g: Expr) -> Expr:
    return Binary(BinaryOp.IMPLIES, f, g)


def Iff(f: Expr, g: Expr) -> Expr:
    return Binary(BinaryOp.IFF, f, g)


# -- reference semantics on lassos -----------------------------------------------------------


def _interval(bound: TimeBound | None) -> tuple[int, int | None]:
    if bound is None:
        return 0, None
    lo = 0
    hi = None
    if bound.lower is not None:
        assert isinstance(bound.lower, IntLit)
        lo = bound.lower.value + (1 if bound.lower_strict else 0)
    if bound.upper is not None:
        assert isinstance(bound.upper, IntLit)
        hi = bound.upper.value - (1 if bound.upper_strict else 0)
    return lo, hi


def satisfies(
    formula: Expr, atoms: tuple[Expr, ...], prefix: Sequence[int], loop: Sequence[int]
) -> bool:
    """Whether the infinite word ``prefix loop loop ...`` satisfies ``formula`` at position 0.

    Letters are ints, bit i = ``atoms[i]`` holds. Any sub-expression equal to an atom (possibly
    negated) is read from the letter.
    """
    assert loop, "a lasso needs a non-empty loop"
    word = list(prefix) + list(loop)
    n = len(word)
    start = len(prefix)

    def succ(i: int) -> int:
        return i + 1 if i + 1 < n else start

    index = {atom: k for k, atom in enumerate(atoms)}

    @cache
    def ev(f: Expr, i: int) -> bool:
        if f in index:
            return bool((word[i] >> index[f]) & 1)
        if isinstance(f, BoolLit):
            return f.value
        if isinstance(f, Unary) and f.op is UnaryOp.NOT:
            return not ev(f.operand, i)
        if isinstance(f, Binary):
            left, right = ev(f.left, i), ev(f.right, i)
            return {
                BinaryOp.AND: left and right,
                BinaryOp.OR: left or right,
                BinaryOp.IMPLIES: (not left) or right,
                BinaryOp.IFF: left == right,
            }[f.op]
        assert isinstance(f, Temporal), f
        op = f.op
        if op is TemporalOp.NEXT:
            return ev(f.operands[0], succ(i))
        lo, hi = _interval(f.bound)
        # beyond lo + n steps every position has been seen again: enough for unbounded operators
        last = lo + n if hi is None else hi

        def until(p: Expr | None, q: Expr | None, neg_p: bool, neg_q: bool) -> bool:
            def holds(g: Expr | None, neg: bool, j: int) -> bool:
                value = True if g is None else ev(g, j)
                return value != neg

            j = i
            for step in range(last + 1):
                if step >= lo and holds(q, neg_q, j):
                    return True
                if not holds(p, neg_p, j):
                    return False
                j = succ(j)
            return False

        if op is TemporalOp.EVENTUALLY:
            return until(None, f.operands[0], False, False)
        if op is TemporalOp.GLOBALLY:
            return not until(None, f.operands[0], False, True)
        p, q = f.operands
        if op is TemporalOp.UNTIL:
            return until(p, q, False, False)
        if op is TemporalOp.RELEASE:  # a R b = !(!a U !b)
            return not until(p, q, True, True)
        # a W b = !(!b U (!a & !b))
        return not until(q, And(Not(p), Not(q)), True, False)

    return ev(formula, 0)


def dfa_accepts_lasso(dfa: Dfa, prefix: Sequence[int], loop: Sequence[int]) -> bool:
    """Whether the run of ``dfa`` on ``prefix loop loop ...`` ever visits an accepting state."""
    q = dfa.run(prefix)
    seen: set[int] = set()
    while q not in seen:
        if dfa.accepting[q]:
            return True
        seen.add(q)
        for letter in loop:
            q = int(dfa.delta[q, letter])
            if dfa.accepting[q]:
                return True
    return bool(dfa.accepting[q])


def violating_extension(dfa: Dfa, word: Sequence[int]) -> tuple[list[int], list[int]] | None:
    """A lasso ``(u, v)`` such that the run on ``word u v^omega`` never accepts, or None.

    Computed from the automaton (states with an infinite run avoiding acceptance), so that the
    reference evaluator can confirm that ``word`` is not a good prefix.
    """
    num_states, num_letters = dfa.delta.shape
    avoid = {q for q in range(num_states) if not dfa.accepting[q]}
    changed = True
    while changed:
        changed = False
        for q in list(avoid):
            if not any(int(dfa.delta[q, s]) in avoid for s in range(num_letters)):
                avoid.discard(q)
                changed = True
    q = dfa.run(word)
    if q not in avoid:
        return None
    letters: list[int] = []
    visited: dict[int, int] = {}
    while q not in visited:
        visited[q] = len(letters)
        letter = next(s for s in range(num_letters) if int(dfa.delta[q, s]) in avoid)
        letters.append(letter)
        q = int(dfa.delta[q, letter])
    cut = visited[q]
    return letters[:cut], letters[cut:]


def same_language(d1: Dfa, d2: Dfa) -> bool:
    """Language equality of two complete DFAs over the same alphabet (product search)."""
    start = (d1.initial, d2.initial)
    stack = [start]
    seen = {start}
    while stack:
        p, q = stack.pop()
        if bool(d1.accepting[p]) != bool(d2.accepting[q]):
            return False
        for letter in range(d1.num_letters):
            nxt = (int(d1.delta[p, letter]), int(d2.delta[q, letter]))
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    return True


# -- random formulas (hypothesis) -----------------------------------------------------------

_BOUNDS = st.one_of(st.none(), st.integers(0, 3))


def _extend(children: st.SearchStrategy[Expr]) -> st.SearchStrategy[Expr]:
    return st.one_of(
        st.builds(Not, children),
        st.builds(And, children, children),
        st.builds(Or, children, children),
        st.builds(Implies, children, children),
        st.builds(Iff, children, children),
        st.builds(X, children),
        st.builds(F, children, _BOUNDS),
        st.builds(G, children, _BOUNDS),
        st.builds(U, children, children, _BOUNDS),
        st.builds(W, children, children, _BOUNDS),
        st.builds(R, children, children, _BOUNDS),
    )


FORMULAS = st.recursive(
    st.one_of(
        st.sampled_from([a, b, c]), st.sampled_from([a, b]), st.builds(BoolLit, st.booleans())
    ),
    _extend,
    max_leaves=8,
)
