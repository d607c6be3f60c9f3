"""Co-safe LTL formulas: atoms, negation normal form, syntactic co-safety, and progression.

A path formula is read as an LTL formula over *atoms*: the maximal sub-expressions without temporal
operators (label references, state predicates, nested ``P``/``R`` queries), with leading negations
stripped so that ``"a"`` and ``!"a"`` share one atom. The caller evaluates each atom to a bool[S]
array; here atoms are only indices.

The formula is translated to negation normal form (NNF) over a small hash-consed formula algebra
(:class:`FormulaTable`)::

    phi ::= true | false | a_i | !a_i | phi & phi | phi | phi | X phi
          | phi U[lo,hi] phi | phi R[lo,hi] phi           (hi = None: unbounded)

with ``F[I] b = true U[I] b``, ``G[I] a = false R[I] a``, ``a W b = b R (a | b)`` and the dualities
``!(a U b) = !a R !b``, ``!X a = X !a`` (infinite words). A formula is *syntactically co-safe*
(PRISM-games' ``isCoSafeLTLSyntactic``) when its NNF contains no unbounded ``R``, i.e. only ``X``,
``U``/``F`` and step-bounded operators; every satisfying word of such a formula has a finite good
prefix. This is a sufficient condition only: ``G a | F a`` is semantically co-safe (it is ``F a``)
but is rejected, as PRISM-games rejects it.

Progression (Bacchus & Kabanza): ``progress(phi, sigma)`` is the formula that the rest of the word
must satisfy after the letter ``sigma`` has been read at the current position, so that
``sigma w |= phi`` iff ``w |= progress(phi, sigma)``. Step bounds are unrolled one step at a time::

    progress(a U[0,h] b)  = progress(b) | (progress(a) & a U[0,h-1] b)   (h = 0: progress(b))
    progress(a U[l,h] b)  = progress(a) & a U[l-1,h-1] b                 (l > 0)
    progress(a R[0,h] b)  = progress(b) & (progress(a) | a R[0,h-1] b)   (h = 0: progress(b))
    progress(a R[l,h] b)  = progress(a) | a R[l-1,h-1] b                 (l > 0)

Constructors keep formulas in a canonical form: every conjunction/disjunction is a disjunctive
normal form over *basic* formulas (literals, ``X``, ``U``, ``R``) with absorption (no term implied
by another; ``true``/``false`` absorbed; terms with ``a & !a`` dropped; ``a U[0,h] b`` with the same
operands compared by ``h``). NNF formulas are monotone in their basics and the minimal terms of a
monotone function are unique, so progression, whose results are boolean combinations of finitely
many basics, reaches finitely many distinct formulas: those are the states of the DFA built in
:mod:`posgmc.engines.ltl.dfa`. (The DNF may be exponential in the number of junctions of the
formula; co-safe properties are small.)
"""

from __future__ import annotations

import dataclasses
import enum
import operator
from collections.abc import Callable
from typing import Any

from posgmc.errors import SemanticError, UnsupportedError
from posgmc.syntax.ast import (
    NO_SPAN,
    Binary,
    BinaryOp,
    BoolLit,
    Expr,
    Filter,
    IntLit,
    PathQuantifier,
    ProbQuery,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TemporalOp,
    TimeBound,
    Unary,
    UnaryOp,
)

__all__ = [
    "BoundEvaluator",
    "FormulaTable",
    "Translation",
    "extract_atoms",
    "is_cosafe",
    "translate",
]

BoundEvaluator = Callable[[Expr], int]
"""Evaluates a step-bound expression to an integer (e.g. with the property file's constants)."""

_NESTED_QUERIES = (ProbQuery, RewardQuery, PathQuantifier, SteadyQuery, Filter)
"""State formulas with their own path formula inside: atoms of the enclosing LTL formula."""

_BOOLEAN_CONNECTIVES = (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF)

COSAFE_MESSAGE = (
    "formula is not co-safe LTL; only X, F, U and bounded G may appear under negation-free form"
)


# ---------------------------------------------------------------------------------------------
# Atoms
# ---------------------------------------------------------------------------------------------


def _contains_temporal(expr: Any) -> bool:
    """Whether ``expr`` has a temporal operator at path level (nested queries, ``A``/``E``,
    ``S`` and filters, are opaque)."""
    if isinstance(expr, Temporal):
        return True
    if isinstance(expr, _NESTED_QUERIES) or not isinstance(expr, Expr):
        return False
    for f in dataclasses.fields(expr):
        value = getattr(expr, f.name)
        if isinstance(value, Expr) and _contains_temporal(value):
            return True
        if isinstance(value, tuple) and any(
            isinstance(v, Expr) and _contains_temporal(v) for v in value
        ):
            return True
    return False


def _strip_negations(expr: Expr) -> tuple[Expr, bool]:
    """``!!..!e`` -> (e, number of negations is odd)."""
    negated = False
    while isinstance(expr, Unary) and expr.op is UnaryOp.NOT:
        expr = expr.operand
        negated = not negated
    return expr, negated


def _unsupported_structure(expr: Expr) -> UnsupportedError:
    return UnsupportedError(
        f"a temporal operator inside a {type(expr).__name__} expression is not supported in LTL",
        expr.span,
        hint="temporal operators may only be combined with !, &, |, => and <=>",
    )


def extract_atoms(path: Expr) -> tuple[Expr, ...]:
    """The atoms of an LTL path formula, for the caller to evaluate over the model's states.

    An atom is a maximal sub-expression without temporal operators (nested ``P``/``R`` queries
    count as atoms), with leading ``!`` removed (``"a"`` and ``!"a"`` give one atom) and boolean
    literals left out (they are constants, not atoms).

    Args:
        path: the path formula, e.g. the ``path`` of a :class:`~posgmc.syntax.ast.ProbQuery`.

    Returns:
        The atoms, deduplicated by structural equality, in left-to-right order of first occurrence.

    Raises:
        UnsupportedError: a temporal operator appears under something other than a boolean
            connective (e.g. inside ``c ? F a : b``), with the span of that expression.
    """
    seen: dict[Expr, None] = {}

    def visit(expr: Expr) -> None:
        if not _contains_temporal(expr):
            atom, _ = _strip_negations(expr)
            if not isinstance(atom, BoolLit):
                seen.setdefault(atom, None)
            return
        if isinstance(expr, Temporal):
            for operand in expr.operands:
                visit(operand)
        elif isinstance(expr, Unary) and expr.op is UnaryOp.NOT:
            visit(expr.operand)
        elif isinstance(expr, Binary) and expr.op in _BOOLEAN_CONNECTIVES:
            visit(expr.left)
            visit(expr.right)
        else:
            raise _unsupported_structure(expr)

    visit(path)
    return tuple(seen)


# ---------------------------------------------------------------------------------------------
# The formula algebra
# ---------------------------------------------------------------------------------------------


class Kind(enum.IntEnum):
    """Node kinds of the NNF formula algebra."""

    TRUE = 0
    FALSE = 1
    LIT = 2  # (LIT, atom, positive)
    AND = 3  # (AND, sorted child ids)
    OR = 4  # (OR, sorted child ids)
    NEXT = 5  # (NEXT, f)
    UNTIL = 6  # (UNTIL, a, b, lo, hi)
    RELEASE = 7  # (RELEASE, a, b, lo, hi)


Node = tuple[Any, ...]
Term = frozenset[int]


class FormulaTable:
    """Hash-consed NNF formulas: equal formulas get equal integer ids, so sets of formulas are
    canonical and progression can be memoised. One table per DFA construction (no global state).

    Ids 0 and 1 are always ``true`` and ``false``.
    """

    TRUE = 0
    FALSE = 1

    def __init__(self) -> None:
        self._nodes: list[Node] = []
        self._ids: dict[Node, int] = {}
        self._masks: list[int] = []  # bit i set: atom i is read by progress() at this node
        self._progress_memo: dict[tuple[int, int], int] = {}
        self._intern((Kind.TRUE,))
        self._intern((Kind.FALSE,))

    def _intern(self, node: Node) -> int:
        found = self._ids.get(node)
        if found is not None:
            return found
        ident = len(self._nodes)
        self._nodes.append(node)
        self._ids[node] = ident
        kind = node[0]
        if kind is Kind.LIT:
            mask = 1 << node[1]
        elif kind in (Kind.AND, Kind.OR):
            mask = 0
            for child in node[1]:
                mask |= self._masks[child]
        elif kind in (Kind.UNTIL, Kind.RELEASE):
            mask = self._masks[node[1]] | self._masks[node[2]]
        else:  # TRUE, FALSE, NEXT: nothing read now
            mask = 0
        self._masks.append(mask)
        return ident

    def node(self, f: int) -> Node:
        return self._nodes[f]

    def kind(self, f: int) -> Kind:
        return self._nodes[f][0]  # type: ignore[no-any-return]

    def current_mask(self, f: int) -> int:
        """Bit mask of the atoms whose value at the current position ``progress(f, .)`` reads."""
        return self._masks[f]

    # -- constructors (canonicalising) ---------------------------------------------------------

    def const(self, value: bool) -> int:
        return self.TRUE if value else self.FALSE

    def lit(self, atom: int, positive: bool) -> int:
        return self._intern((Kind.LIT, atom, positive))

    def and_(self, children: list[int] | tuple[int, ...]) -> int:
        terms: set[Term] = {frozenset()}
        for c in children:
            if c == self.TRUE:
                continue
            # distribute: (t1 | t2) & (u1 | u2) = t1&u1 | t1&u2 | ...; reduce as we go
            terms = self._reduce({t | u for t in terms for u in self._terms(c)})
            if not terms:
                return self.FALSE
        return self._from_terms(terms)

    def or_(self, children: list[int] | tuple[int, ...]) -> int:
        terms: set[Term] = set()
        for c in children:
            if c == self.TRUE:
                return self.TRUE
            terms.update(self._terms(c))
        return self._from_terms(self._reduce(terms))

    # Junctions are kept in disjunctive normal form over *basic* formulas (literals, X, U, R):
    # an OR of AND-terms, each term a set of basics, no term implied by another. Formulas in NNF
    # are monotone in their basics, and the minimal terms of a monotone function are unique, so
    # propositionally equivalent junctions get the same id. Without this, progression of
    # (F a) U (F a) would build F a | (F a & (F a | (F a & ...))) forever.

    def _terms(self, f: int) -> set[Term]:
        if f == self.TRUE:
            return {frozenset()}
        if f == self.FALSE:
            return set()
        node = self._nodes[f]
        if node[0] is Kind.OR:
            return {self._term_of(c) for c in node[1]}
        return {self._term_of(f)}

    def _term_of(self, f: int) -> Term:
        node = self._nodes[f]
        return frozenset(node[1]) if node[0] is Kind.AND else frozenset((f,))

    def _implies(self, x: int, y: int) -> bool:
        """Basic formula x implies basic formula y (syntactically): equal, or the same
        ``a U[0,h] b`` with a smaller h, or the same ``a R[0,h] b`` with a larger h."""
        if x == y:
            return True
        nx, ny = self._nodes[x], self._nodes[y]
        if nx[0] is not ny[0] or nx[0] not in (Kind.UNTIL, Kind.RELEASE):
            return False
        if nx[1:4] != ny[1:4] or nx[3] != 0:
            return False
        hx, hy = _horizon(nx[4]), _horizon(ny[4])
        return hx <= hy if nx[0] is Kind.UNTIL else hx >= hy

    def _term_implies(self, t: Term, u: Term) -> bool:
        return all(any(self._implies(x, y) for x in t) for y in u)

    def _reduce(self, terms: set[Term]) -> set[Term]:
        """Drop contradictory terms and implied conjuncts, then terms that imply another term
        (absorption: t | (t & u) = t; with bounds: F<=2 b | F<=5 b = F<=5 b)."""
        reduced: set[Term] = set()
        for term in terms:
            literals = {self._nodes[x][1:] for x in term if self._nodes[x][0] is Kind.LIT}
            if any((atom, not positive) in literals for atom, positive in literals):
                continue  # a & !a
            # within a term keep only conjuncts not implied by another: F<=2 b & F<=5 b = F<=2 b
            reduced.add(
                frozenset(
                    x for x in term if not any(y != x and self._implies(y, x) for y in term)
                )
            )
        if frozenset() in reduced:
            return {frozenset()}
        ordered = sorted(reduced, key=lambda t: (len(t), sorted(t)))
        kept: list[Term] = []
        for term in ordered:
            # terms are distinct, so mutual implication cannot happen after the reduction above
            if not any(self._term_implies(term, other) for other in kept):
                kept = [k for k in kept if not self._term_implies(k, term)]
                kept.append(term)
        out = set(kept)
        # a | !a: a complementary pair of single-literal terms makes the junction valid
        single = {self._nodes[x][1:] for t in out if len(t) == 1 for x in t
                  if self._nodes[x][0] is Kind.LIT}
        if any((atom, not positive) in single for atom, positive in single):
            return {frozenset()}
        return out

    def _from_terms(self, terms: set[Term]) -> int:
        if not terms:
            return self.FALSE
        ids = []
        for term in terms:
            if not term:
                return self.TRUE
            ids.append(
                next(iter(term)) if len(term) == 1
                else self._intern((Kind.AND, tuple(sorted(term))))
            )
        if len(ids) == 1:
            return ids[0]
        return self._intern((Kind.OR, tuple(sorted(ids))))

    def letter(self) -> int:
        """The state formula ``true``: it holds at the position being read, so reading one letter
        satisfies it (``X true`` as a node; :meth:`next_` never builds it from ``true``)."""
        return self._intern((Kind.NEXT, self.TRUE))

    def next_(self, f: int) -> int:
        if f in (self.TRUE, self.FALSE):  # X true = true, X false = false on infinite words
            return f
        return self._intern((Kind.NEXT, f))

    def until(self, a: int, b: int, lo: int, hi: int | None) -> int:
        """``a U[lo,hi] b``: b at some step j in [lo, hi] and a at every step before j."""
        if b == self.FALSE:
            return self.FALSE
        if lo == 0:
            if b == self.TRUE or a == self.FALSE or hi == 0:
                return b
        elif a == self.FALSE:
            return self.FALSE
        return self._intern((Kind.UNTIL, a, b, lo, hi))

    def release(self, a: int, b: int, lo: int, hi: int | None) -> int:
        """``a R[lo,hi] b`` = ``!(!a U[lo,hi] !b)``: b at every step j in [lo, hi] until a held at
        some step before j."""
        if b == self.TRUE or b == self.letter():  # the state formula true holds everywhere
            return self.TRUE
        if lo == 0:
            if b == self.FALSE or a == self.TRUE or hi == 0:
                return b
        elif a == self.TRUE:
            return self.TRUE
        return self._intern((Kind.RELEASE, a, b, lo, hi))

    # -- progression ---------------------------------------------------------------------------

    def progress(self, f: int, letter: int) -> int:
        """The formula the remaining word must satisfy after reading ``letter`` (bit i = atom i
        holds at the current position) under obligation ``f``."""
        key = (f, letter & self._masks[f])
        found = self._progress_memo.get(key)
        if found is not None:
            return found
        result = self._progress(f, key[1])
        self._progress_memo[key] = result
        return result

    def _progress(self, f: int, letter: int) -> int:
        node = self._nodes[f]
        kind = node[0]
        if kind in (Kind.TRUE, Kind.FALSE):
            return f
        if kind is Kind.LIT:
            return self.const(bool((letter >> node[1]) & 1) == node[2])
        if kind is Kind.AND:
            return self.and_([self.progress(c, letter) for c in node[1]])
        if kind is Kind.OR:
            return self.or_([self.progress(c, letter) for c in node[1]])
        if kind is Kind.NEXT:
            return node[1]  # type: ignore[no-any-return]
        _, a, b, lo, hi = node
        rest_hi = None if hi is None else hi - 1
        if kind is Kind.UNTIL:
            if lo > 0:
                return self.and_([self.progress(a, letter), self.until(a, b, lo - 1, rest_hi)])
            rest = f if hi is None else self.until(a, b, 0, rest_hi)
            return self.or_([self.progress(b, letter), self.and_([self.progress(a, letter), rest])])
        # RELEASE
        if lo > 0:
            return self.or_([self.progress(a, letter), self.release(a, b, lo - 1, rest_hi)])
        rest = f if hi is None else self.release(a, b, 0, rest_hi)
        return self.and_([self.progress(b, letter), self.or_([self.progress(a, letter), rest])])

    # -- queries -------------------------------------------------------------------------------

    def unbounded(self, f: int) -> tuple[list[int], list[int]]:
        """(the unbounded ``U`` nodes, the unbounded ``R`` nodes) among the sub-formulas of
        ``f``, each sorted: the one walk over a formula's sub-formulas."""
        mus: set[int] = set()
        nus: set[int] = set()
        seen: set[int] = set()
        stack = [f]
        while stack:
            g = stack.pop()
            if g in seen:
                continue
            seen.add(g)
            node = self._nodes[g]
            kind = node[0]
            if kind in (Kind.AND, Kind.OR):
                stack.extend(node[1])
            elif kind is Kind.NEXT:
                stack.append(node[1])
            elif kind in (Kind.UNTIL, Kind.RELEASE):
                if node[4] is None:
                    (mus if kind is Kind.UNTIL else nus).add(g)
                stack.extend((node[1], node[2]))
        return sorted(mus), sorted(nus)

    def unbounded_releases(self, f: int) -> list[int]:
        """The unbounded ``R`` nodes in ``f`` (empty iff ``f`` is syntactically co-safe)."""
        return self.unbounded(f)[1]

    def render(self, f: int, atom_names: tuple[str, ...] | None = None) -> str:
        """A readable form of ``f`` (atoms as ``a0``, ``a1``, ... unless names are given)."""
        node = self._nodes[f]
        kind = node[0]
        if kind is Kind.TRUE:
            return "true"
        if kind is Kind.FALSE:
            return "false"
        if kind is Kind.LIT:
            name = atom_names[node[1]] if atom_names else f"a{node[1]}"
            return name if node[2] else f"!{name}"
        if kind in (Kind.AND, Kind.OR):
            sep = " & " if kind is Kind.AND else " | "
            return sep.join(self._render_operand(c, atom_names) for c in node[1])
        if kind is Kind.NEXT:
            return "X " + self._render_operand(node[1], atom_names)
        _, a, b, lo, hi = node
        bound = "" if lo == 0 and hi is None else (
            f"<={hi}" if lo == 0 else (f">={lo}" if hi is None else f"[{lo},{hi}]")
        )
        if kind is Kind.UNTIL and a == self.TRUE:
            return f"F{bound} " + self._render_operand(b, atom_names)
        if kind is Kind.RELEASE and a == self.FALSE:
            return f"G{bound} " + self._render_operand(b, atom_names)
        op = "U" if kind is Kind.UNTIL else "R"
        return (
            f"{self._render_operand(a, atom_names)} {op}{bound} "
            f"{self._render_operand(b, atom_names)}"
        )

    def _render_operand(self, f: int, atom_names: tuple[str, ...] | None) -> str:
        text = self.render(f, atom_names)
        if self.kind(f) in (Kind.TRUE, Kind.FALSE, Kind.LIT):
            return text
        return f"({text})"


def _horizon(hi: int | None) -> float:
    return float("inf") if hi is None else float(hi)


# ---------------------------------------------------------------------------------------------
# Translation from syntax trees
# ---------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Translation:
    """An LTL path formula in NNF: ``root`` in ``table``; ``origins`` maps each unbounded ``R``
    node to the syntax node it came from (to point errors at it)."""

    table: FormulaTable
    root: int
    origins: dict[int, Expr]

    def non_cosafe_origin(self) -> Expr | None:
        """The syntax node responsible for the first unbounded ``R``, or None if co-safe."""
        culprits = self.table.unbounded_releases(self.root)
        if not culprits:
            return None
        return self.origins.get(culprits[0])


def _default_bound_value(expr: Expr) -> int:
    """Integer literals and +, -, * of them; anything else must be substituted by the caller."""
    if isinstance(expr, IntLit):
        return expr.value
    if isinstance(expr, Unary) and expr.op is UnaryOp.NEG:
        return -_default_bound_value(expr.operand)
    if isinstance(expr, Binary) and expr.op in (BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL):
        left, right = _default_bound_value(expr.left), _default_bound_value(expr.right)
        if expr.op is BinaryOp.ADD:
            return left + right
        if expr.op is BinaryOp.SUB:
            return left - right
        return left * right
    raise UnsupportedError(
        "a step bound must be a constant integer expression here",
        expr.span,
        hint="substitute the values of constants before building the automaton",
    )


def _interval(
    bound: TimeBound | None, evaluate: BoundEvaluator, where: Expr
) -> tuple[int, int | None]:
    """The inclusive step interval [lo, hi] (hi None: unbounded) of a time bound."""
    if bound is None:
        return 0, None
    lo, hi = 0, None
    for value_expr, strict, is_lower in (
        (bound.lower, bound.lower_strict, True),
        (bound.upper, bound.upper_strict, False),
    ):
        if value_expr is None:
            continue
        raw = evaluate(value_expr)
        span = value_expr.span if value_expr.span != NO_SPAN else bound.span
        try:
            if isinstance(raw, bool):
                raise TypeError
            value = operator.index(raw)
        except TypeError:
            raise SemanticError(f"a step bound must be an integer, not {raw!r}", span) from None
        if value < 0:
            raise SemanticError(f"a step bound must not be negative (it is {value})", span)
        if is_lower:
            lo = value + 1 if strict else value
        else:
            hi = value - 1 if strict else value
    if hi is not None and lo > hi:
        span = bound.span if bound.span != NO_SPAN else where.span
        raise SemanticError(
            f"the step bound admits no step (interval [{lo}, {hi}] is empty)",
            span,
            hint="use a bound such as <=k with k >= 0, or [a,b] with a <= b",
        )
    return lo, hi


def translate(
    path: Expr,
    atoms: tuple[Expr, ...],
    *,
    bound_value: BoundEvaluator | None = None,
    table: FormulaTable | None = None,
) -> Translation:
    """Translate a path formula into NNF over ``atoms`` (see the module docstring).

    Args:
        path: the path formula.
        atoms: the atoms, e.g. from :func:`extract_atoms`; atom i becomes literal i.
        bound_value: evaluates step bounds; by default only integer literal arithmetic.
        table: the formula table to build into (a new one by default).

    Returns:
        The :class:`Translation`.

    Raises:
        UnsupportedError: a temporal operator under a non-boolean expression, a bound on ``X``,
            or a step bound that is not a constant.
        SemanticError: a negative step bound or an empty step interval.
        ValueError: an atom of ``path`` is missing from ``atoms`` (a caller bug).
    """
    tab = table if table is not None else FormulaTable()
    evaluate = bound_value if bound_value is not None else _default_bound_value
    index = {atom: i for i, atom in enumerate(atoms)}
    origins: dict[int, Expr] = {}

    def release(a: int, b: int, lo: int, hi: int | None, origin: Expr) -> int:
        r = tab.release(a, b, lo, hi)
        if hi is None:
            origins.setdefault(r, origin)
        return r

    def tr(expr: Expr, neg: bool) -> int:
        if not _contains_temporal(expr):
            atom, odd = _strip_negations(expr)
            neg = neg != odd
            if isinstance(atom, BoolLit):
                # a state formula holds at a position of the path, so ``true`` needs one to exist
                # (PRISM: R[X true] collects one step's reward, R[true] none)
                return tab.letter() if atom.value != neg else tab.FALSE
            try:
                i = index[atom]
            except KeyError:
                raise ValueError(f"atom {atom!r} is not among the atoms given") from None
            return tab.lit(i, not neg)
        if isinstance(expr, Unary) and expr.op is UnaryOp.NOT:
            return tr(expr.operand, not neg)
        if isinstance(expr, Binary) and expr.op in _BOOLEAN_CONNECTIVES:
            left, right = expr.left, expr.right
            if expr.op is BinaryOp.AND or expr.op is BinaryOp.OR:
                parts = [tr(left, neg), tr(right, neg)]
                # De Morgan: a negated conjunction is a disjunction and vice versa
                return tab.and_(parts) if (expr.op is BinaryOp.AND) != neg else tab.or_(parts)
            if expr.op is BinaryOp.IMPLIES:  # a => b == !a | b
                if neg:
                    return tab.and_([tr(left, False), tr(right, True)])
                return tab.or_([tr(left, True), tr(right, False)])
            # IFF: (a & b) | (!a & !b); negated: (a & !b) | (!a & b)
            return tab.or_(
                [
                    tab.and_([tr(left, False), tr(right, neg)]),
                    tab.and_([tr(left, True), tr(right, not neg)]),
                ]
            )
        if isinstance(expr, Temporal):
            return temporal(expr, neg)
        raise _unsupported_structure(expr)

    def temporal(expr: Temporal, neg: bool) -> int:
        op = expr.op
        if op is TemporalOp.NEXT:
            if expr.bound is not None:
                raise UnsupportedError(
                    "the next operator X cannot have a step bound",
                    expr.bound.span if expr.bound.span != NO_SPAN else expr.span,
                    hint="write X X a for 'a after two steps'",
                )
            return tab.next_(tr(expr.operands[0], neg))
        lo, hi = _interval(expr.bound, evaluate, expr)
        if op is TemporalOp.EVENTUALLY:  # F b = true U b; !F b = false R !b
            b = tr(expr.operands[0], neg)
            if neg:
                return release(tab.FALSE, b, lo, hi, expr)
            return tab.until(tab.TRUE, b, lo, hi)
        if op is TemporalOp.GLOBALLY:  # G a = false R a; !G a = true U !a
            a = tr(expr.operands[0], neg)
            if neg:
                return tab.until(tab.TRUE, a, lo, hi)
            return release(tab.FALSE, a, lo, hi, expr)
        left, right = expr.operands
        if op is TemporalOp.UNTIL:  # !(a U b) = !a R !b
            a, b = tr(left, neg), tr(right, neg)
            return release(a, b, lo, hi, expr) if neg else tab.until(a, b, lo, hi)
        if op is TemporalOp.RELEASE:  # !(a R b) = !a U !b
            a, b = tr(left, neg), tr(right, neg)
            return tab.until(a, b, lo, hi) if neg else release(a, b, lo, hi, expr)
        # WEAK_UNTIL, as PRISM rewrites it: a W b = !((a & !b) U (!a & !b)) = (!a | b) R (a | b);
        # without a lower step bound this is the textbook b R (a | b)
        a, b = tr(left, neg), tr(right, neg)
        if neg:  # (a & !b) U (!a & !b), with a, b already negated here
            return tab.until(tab.and_([tr(left, False), b]), tab.and_([a, b]), lo, hi)
        return release(tab.or_([tr(left, True), b]), tab.or_([a, b]), lo, hi, expr)

    root = tr(path, False)
    return Translation(tab, root, origins)


def cosafe_error(path: Expr, culprit: Expr | None) -> UnsupportedError:
    """The error for a formula that is not syntactically co-safe, pointing at the operator that
    becomes an unbounded G/R once negations are pushed to the atoms."""
    where = culprit if culprit is not None and culprit.span != NO_SPAN else path
    detail = ""
    if isinstance(culprit, Temporal):
        if culprit.op in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL):
            detail = f' ("{culprit.op.value}" under a negation is an unbounded G or R)'
        else:
            detail = f' (the unbounded "{culprit.op.value}" here)'
    return UnsupportedError(
        COSAFE_MESSAGE + detail,
        where.span,
        hint=(
            "bound the operator (G<=k), or check the dual co-safe formula instead, "
            "e.g. Pmax=? [G a] = 1 - Pmin=? [F !a]"
        ),
    )


def is_cosafe(path: Expr, *, bound_value: BoundEvaluator | None = None) -> bool:
    """Whether ``path`` is syntactically co-safe LTL (PRISM-games' criterion).

    After negations are pushed to the atoms, only ``X``, ``F``, ``U``, ``&``, ``|`` and
    step-bounded operators (``G<=k``, ``R<=k``, ``W<=k``, ...) may remain; an unbounded ``G``,
    ``R`` or ``W`` (including ``!F``, ``!U`` in negative position) makes it not co-safe. This is
    sufficient for co-safety, not necessary (``G a | F a`` is rejected).

    Args:
        path: the path formula.
        bound_value: evaluates step bounds; by default only integer literal arithmetic.

    Returns:
        True when the formula is syntactically co-safe.

    Raises:
        UnsupportedError, SemanticError: as :func:`translate`.
    """
    translation = translate(path, extract_atoms(path), bound_value=bound_value)
    return not translation.table.unbounded_releases(translation.root)
