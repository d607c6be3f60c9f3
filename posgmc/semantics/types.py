"""Type checking of expressions, with PRISM's typing rules (``parser/visitor/TypeCheck.java``).

The rules: ``& | => <=> !`` take Booleans (or path formulas, inside ``P``/``R``); ``= !=``
compare two Booleans or two numbers; ``< <= > >=`` compare numbers; ``+ - *`` give an int when
both sides are ints and a double otherwise; ``/`` always gives a double; ``c ? a : b`` needs a
Boolean ``c`` and branches of compatible types (int widens to double); ``min``/``max``/``pow``
give an int when every argument is an int; ``floor``/``ceil``/``round``/``mod`` give ints
(``mod`` takes ints only); ``log`` gives a double. Temporal operators make path formulas and may
only appear inside ``P``/``R``.

Every error is recorded (not raised) so that ``lint`` can report all of them; a sub-expression in
error has type None and does not cause follow-up errors.
"""

from __future__ import annotations

from collections.abc import Callable

from posgmc.errors import PosgmcError, SemanticError, SourceSpan
from posgmc.semantics.symbols import Symbol, SymbolKind, Type, span_or_none
from posgmc.syntax.ast import (
    FUNCTION_ARITY,
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    DoubleLit,
    Expr,
    Filter,
    FilterOp,
    Function,
    Ident,
    IntLit,
    Ite,
    LabelRef,
    MultiQuery,
    PathQuantifier,
    ProbQuery,
    RewardKind,
    RewardQuery,
    SteadyQuery,
    Temporal,
    TimeBound,
    Unary,
    UnaryOp,
)

__all__ = ["TypeChecker", "infer_type", "span_or_none"]

_LOGICAL = (BinaryOp.OR, BinaryOp.AND, BinaryOp.IMPLIES, BinaryOp.IFF)
_EQUALITY = (BinaryOp.EQ, BinaryOp.NE)
_ORDER = (BinaryOp.LT, BinaryOp.LE, BinaryOp.GT, BinaryOp.GE)
_ARITHMETIC = (BinaryOp.ADD, BinaryOp.SUB, BinaryOp.MUL)


def _name(t: Type) -> str:
    return "a path formula" if t is Type.PATH else t.value


class TypeChecker:
    """Computes expression types and records every type/name error it meets.

    Args:
        lookup: what an identifier names (None: undefined).
        errors: where errors are appended.
        labels: the type of a quoted name ``"x"`` (None: no such label); None when labels may not
            be used at all (model expressions).
        allow_queries: whether ``P``/``R`` operators may appear (properties only).
        undefined_hint: optional extra hint for an undefined identifier (e.g. "labels are quoted").
        unknown_label_hint: optional extra hint for an unknown quoted name.
        int_division: type ``int / int`` as int, as Storm does (PRISM: always double); used to
            tell Storm's int-valued divisions from real doubles (see ``dialect.py``).
    """

    def __init__(
        self,
        *,
        lookup: Callable[[str], Symbol | None],
        errors: list[PosgmcError],
        labels: Callable[[str], Type | None] | None = None,
        allow_queries: bool = False,
        undefined_hint: Callable[[str], str | None] | None = None,
        unknown_label_hint: Callable[[str], str | None] | None = None,
        int_division: bool = False,
    ) -> None:
        self._lookup = lookup
        self._errors = errors
        self._labels = labels
        self._allow_queries = allow_queries
        self._undefined_hint = undefined_hint
        self._unknown_label_hint = unknown_label_hint
        self._constant: str | None = None
        self._query_depth = 0
        self._int_division = int_division

    # -- public ----------------------------------------------------------------------------------

    def check(self, expr: Expr, *, constant: str | None = None) -> Type | None:
        """The type of ``expr``, or None if it has an error (already recorded).

        Args:
            expr: the expression.
            constant: if given, the expression must not refer to variables; the text names what
                must be constant, for the message (e.g. ``'the definition of constant "N"'``).
        """
        saved = self._constant
        self._constant = constant
        try:
            return self._type(expr)
        finally:
            self._constant = saved

    def expect(
        self, expr: Expr, expected: Type, what: str, *, constant: str | None = None
    ) -> Type | None:
        """Check ``expr`` and that its type fits where ``expected`` is needed (int widens to
        double); ``what`` names the place for the message, e.g. ``"a guard"``."""
        t = self.check(expr, constant=constant)
        if t is not None and not expected.accepts(t):
            self._error(f"{what} must be {_article(expected)}, found {_name(t)}", expr.span)
            return None
        return t

    # -- helpers ---------------------------------------------------------------------------------

    def _error(self, message: str, span: SourceSpan, hint: str | None = None) -> None:
        self._errors.append(SemanticError(message, span_or_none(span), hint=hint))

    def _type(self, e: Expr) -> Type | None:
        if isinstance(e, BoolLit):
            return Type.BOOL
        if isinstance(e, IntLit):
            return Type.INT
        if isinstance(e, DoubleLit):
            return Type.DOUBLE
        if isinstance(e, Ident):
            return self._ident(e)
        if isinstance(e, Unary):
            return self._unary(e)
        if isinstance(e, Binary):
            return self._binary(e)
        if isinstance(e, Ite):
            return self._ite(e)
        if isinstance(e, Call):
            return self._call(e)
        if isinstance(e, Filter):
            return self._filter(e)
        if isinstance(e, PathQuantifier):
            return self._quantifier(e)
        if isinstance(e, SteadyQuery):
            return self._steady(e)
        if isinstance(e, LabelRef):
            return self._label(e)
        if isinstance(e, Temporal):
            return self._temporal(e)
        if isinstance(e, ProbQuery):
            return self._prob(e)
        if isinstance(e, RewardQuery):
            return self._reward(e)
        if isinstance(e, MultiQuery):
            return self._multi(e)
        self._error(f"unexpected expression {type(e).__name__}", e.span)
        return None

    def _ident(self, e: Ident) -> Type | None:
        sym = self._lookup(e.name)
        if sym is None:
            hint = self._undefined_hint(e.name) if self._undefined_hint is not None else None
            self._error(f'undefined name "{e.name}"', e.span, hint)
            return None
        if sym.kind is SymbolKind.FORMULA:
            # only cyclic formulas are left unexpanded; the cycle is reported where it is found
            return None
        if sym.kind is SymbolKind.VARIABLE and self._constant is not None:
            self._error(
                f'{self._constant} must be constant, but it refers to variable "{e.name}"', e.span
            )
        return sym.type

    def _unary(self, e: Unary) -> Type | None:
        t = self._type(e.operand)
        if t is None:
            return None
        if e.op is UnaryOp.NOT:
            if not t.is_boolean:
                self._error(f'"!" needs a Boolean operand, found {_name(t)}', e.operand.span)
                return None
            return t
        if not t.is_numeric:
            self._error(f'"-" needs a number, found {_name(t)}', e.operand.span)
            return None
        return t

    def _binary(self, e: Binary) -> Type | None:
        t1 = self._type(e.left)
        t2 = self._type(e.right)
        op = e.op.value
        if e.op in _LOGICAL:
            ok = True
            for t, side in ((t1, e.left), (t2, e.right)):
                if t is not None and not t.is_boolean:
                    self._error(f'"{op}" needs Boolean operands, found {_name(t)}', side.span)
                    ok = False
            if t1 is None or t2 is None or not ok:
                return None
            return Type.PATH if Type.PATH in (t1, t2) else Type.BOOL
        if t1 is None or t2 is None:
            return None
        if e.op in _EQUALITY:
            if (t1 is Type.BOOL and t2 is Type.BOOL) or (t1.is_numeric and t2.is_numeric):
                return Type.BOOL
            self._error(f'"{op}" cannot compare {_name(t1)} and {_name(t2)}', e.span)
            return None
        if e.op in _ORDER:
            if t1.is_numeric and t2.is_numeric:
                return Type.BOOL
            self._error(f'"{op}" cannot compare {_name(t1)} and {_name(t2)}', e.span)
            return None
        # arithmetic
        ok = True
        for t, side in ((t1, e.left), (t2, e.right)):
            if not t.is_numeric:
                self._error(f'"{op}" needs numbers, found {_name(t)}', side.span)
                ok = False
        if not ok:
            return None
        if Type.DOUBLE in (t1, t2) or (e.op is BinaryOp.DIV and not self._int_division):
            return Type.DOUBLE
        return Type.INT

    def _ite(self, e: Ite) -> Type | None:
        tc = self._type(e.cond)
        t1 = self._type(e.then)
        t2 = self._type(e.otherwise)
        if tc is not None and tc is not Type.BOOL:
            self._error(f'the condition of "? :" must be Boolean, found {_name(tc)}', e.cond.span)
            return None
        if tc is None or t1 is None or t2 is None:
            return None
        if Type.PATH in (t1, t2):
            self._error('the branches of "? :" cannot be path formulas', e.span)
            return None
        if not (t1.accepts(t2) or t2.accepts(t1)):
            found = f"found {_name(t1)} and {_name(t2)}"
            self._error(f'the branches of "? :" must have matching types, {found}', e.span)
            return None
        if t1 is Type.BOOL:
            return Type.BOOL
        return Type.INT if t1 is Type.INT and t2 is Type.INT else Type.DOUBLE

    def _filter(self, e: Filter) -> Type | None:
        """PRISM's type rules of filters (``parser/visitor/TypeCheck.java``)."""
        t = self._type(e.operand)
        if e.states is not None:
            ts = self._type(e.states)
            if ts is not None and ts is not Type.BOOL:
                self._error(f"the states of a filter must be a Boolean formula, found {_name(ts)}",
                            e.states.span)
        if t is None:
            return None
        name = e.op.value
        if t is Type.PATH:
            self._error(f"filter {name} applies to a state formula, found a path formula",
                        e.operand.span, hint="write it inside P[...] or R[...]")
            return None
        numeric = (FilterOp.MIN, FilterOp.MAX, FilterOp.ARGMIN, FilterOp.ARGMAX, FilterOp.SUM,
                   FilterOp.AVG, FilterOp.RANGE)
        if e.op in numeric and not t.is_numeric:
            self._error(f"filter {name} needs a numeric operand, found {_name(t)}", e.operand.span)
            return None
        if e.op in (FilterOp.COUNT, FilterOp.FORALL, FilterOp.EXISTS) and t is not Type.BOOL:
            self._error(f"filter {name} needs a Boolean operand, found {_name(t)}", e.operand.span)
            return None
        if e.op in (FilterOp.ARGMIN, FilterOp.ARGMAX, FilterOp.FORALL, FilterOp.EXISTS):
            return Type.BOOL
        if e.op is FilterOp.COUNT:
            return Type.INT
        if e.op is FilterOp.AVG:
            return Type.DOUBLE
        return t

    def _call(self, e: Call) -> Type | None:
        fn = e.function.value
        low, high = FUNCTION_ARITY[e.function]
        n = len(e.args)
        types = [self._type(a) for a in e.args]
        if n < low or (high is not None and n > high):
            if low == high:
                want = f"{low}"
            else:
                want = f"at least {low}" if high is None else f"{low}-{high}"
            plural = "s" if want != "1" else ""
            self._error(f"{fn}() takes {want} argument{plural}, found {n}", e.span)
            return None
        ok = True
        for t, a in zip(types, e.args):
            if t is None:
                ok = False
            elif e.function is Function.MOD and t is not Type.INT:
                self._error(f"mod() needs int arguments, found {_name(t)}", a.span)
                ok = False
            elif not t.is_numeric:
                self._error(f"{fn}() needs numeric arguments, found {_name(t)}", a.span)
                ok = False
        if not ok:
            return None
        if e.function in (Function.MIN, Function.MAX, Function.POW):
            return Type.DOUBLE if Type.DOUBLE in types else Type.INT
        if e.function is Function.LOG:
            return Type.DOUBLE
        return Type.INT

    def _label(self, e: LabelRef) -> Type | None:
        if self._labels is None:
            self._error(
                f'the label "{e.name}" cannot be used in a model expression',
                e.span,
                "labels are for properties; use a formula to share an expression within a model",
            )
            return None
        t = self._labels(e.name)
        if t is None:
            hint = self._unknown_label_hint(e.name) if self._unknown_label_hint else None
            self._error(f'unknown label "{e.name}"', e.span, hint)
            return None
        return t

    def _bound(self, expr: Expr | None, what: str) -> bool:
        if expr is None:
            return True
        return self.expect(expr, Type.INT, what, constant=what) is not None

    def _temporal(self, e: Temporal) -> Type | None:
        op = e.op.value
        if self._query_depth == 0:
            self._error(
                f'the temporal operator "{op}" can only appear inside a P or R operator', e.span
            )
            return None
        ok = True
        for operand in e.operands:
            t = self._type(operand)
            if t is None:
                ok = False
            elif not t.is_boolean:
                self._error(
                    f'the operand of "{op}" must be Boolean, found {_name(t)}', operand.span
                )
                ok = False
        if e.bound is not None:
            ok &= self._time_bound(e.bound, op)
        return Type.PATH if ok else None

    def _time_bound(self, bound: TimeBound, op: str) -> bool:
        ok = self._bound(bound.lower, f'the step bound of "{op}"')
        ok &= self._bound(bound.upper, f'the step bound of "{op}"')
        return ok

    def _query_allowed(self, e: Expr, name: str) -> bool:
        if not self._allow_queries:
            self._error(f"the {name} operator cannot appear in a model expression", e.span)
            return False
        if self._constant is not None:
            self._error(
                f"{self._constant} must be constant, but it contains a {name} operator", e.span
            )
            return False
        return True

    def _threshold(self, e: ProbQuery | RewardQuery | SteadyQuery, name: str) -> bool:
        if e.threshold is None:
            return True
        what = f"the bound of the {name} operator"
        return self.expect(e.threshold.value, Type.DOUBLE, what, constant=what) is not None

    def _steady(self, e: SteadyQuery) -> Type | None:
        if not self._query_allowed(e, "S"):
            return None
        ok = self._threshold(e, "S")
        t = self._type(e.operand)
        if t is not None and t is not Type.BOOL:
            self._error(f"the S operator needs a Boolean state formula, found {_name(t)}",
                        e.operand.span)
            return None
        if t is None or not ok:
            return None
        return Type.DOUBLE if e.threshold is None else Type.BOOL

    def _quantifier(self, e: PathQuantifier) -> Type | None:
        name = "A" if e.universal else "E"
        if not self._query_allowed(e, name):
            return None
        self._query_depth += 1
        try:
            t = self._type(e.path)
        finally:
            self._query_depth -= 1
        if t is not None and not t.is_boolean:
            self._error(f"the {name} operator needs a path formula, found {_name(t)}", e.path.span)
            return None
        return None if t is None else Type.BOOL

    def _prob(self, e: ProbQuery) -> Type | None:
        if not self._query_allowed(e, "P"):
            return None
        ok = self._threshold(e, "P")
        self._query_depth += 1
        try:
            t = self._type(e.path)
        finally:
            self._query_depth -= 1
        if t is not None and not t.is_boolean:
            self._error(
                f"the P operator needs a path formula or a Boolean, found {_name(t)}", e.path.span
            )
            return None
        if t is None or not ok:
            return None
        return Type.DOUBLE if e.threshold is None else Type.BOOL

    def _multi(self, e: MultiQuery) -> Type | None:
        # which arguments may stand in multi(...) is semantics/multi.py's question; here each
        # argument is typed, and the query is Boolean when every argument has a threshold
        types = [self._type(o) for o in e.objectives]
        if any(t is None for t in types):
            return None
        return Type.BOOL if all(t is Type.BOOL for t in types) else Type.DOUBLE

    def _reward(self, e: RewardQuery) -> Type | None:
        if not self._query_allowed(e, "R"):
            return None
        ok = self._threshold(e, "R")
        obj = e.objective
        kind = obj.kind.value
        if obj.bound is not None:
            ok &= self._bound(obj.bound, f'the step bound of "{kind}"')
        if obj.discount is not None:
            what = f'the discount factor of "{kind}"'
            ok &= self.expect(obj.discount, Type.DOUBLE, what, constant=what) is not None
        if obj.target is not None:
            # co-safe LTL objectives hold path formulas; the reachability kinds a state formula
            depth = 1 if obj.kind is RewardKind.LTL else 0
            self._query_depth += depth
            try:
                t = self._type(obj.target)
            finally:
                self._query_depth -= depth
            if t is None:
                ok = False
            elif not (t is Type.BOOL or (t is Type.PATH and obj.kind is RewardKind.LTL)):
                self._error(
                    f'the target of "{kind}" in the R operator must be Boolean, found {_name(t)}',
                    obj.target.span,
                )
                ok = False
        if not ok:
            return None
        return Type.DOUBLE if e.threshold is None else Type.BOOL


def _article(t: Type) -> str:
    return {Type.BOOL: "Boolean", Type.INT: "an int", Type.DOUBLE: "a number"}.get(t, _name(t))


def infer_type(expr: Expr, lookup: Callable[[str], Symbol | None]) -> Type:
    """The type of a model expression (no labels, no queries).

    Raises:
        SemanticError: the first type or name error.
    """
    errors: list[PosgmcError] = []
    t = TypeChecker(lookup=lookup, errors=errors).check(expr)
    if errors:
        raise errors[0]
    assert t is not None  # internal: no error recorded implies a type
    return t

