"""Evaluation of expressions on Python scalars with PRISM's semantics, and the tree rewrites built
on it: substitution of identifiers and constant folding.

Values: ``bool`` for Booleans, ``int`` for ints, and for doubles a :class:`~fractions.Fraction`
while the computation is exact (``0.1`` is ``1/10``, ``1/3`` is ``1/3``) or a ``float`` once a
function needs floating point (``log``, ``pow`` with a non-integer exponent). Invariant kept by
:func:`evaluate`: an expression of type double always evaluates to a Fraction or a float, one of
type int to an int, so the value alone tells the type.

PRISM's rules (``parser/ast/ExpressionFunc.java``, ``ExpressionBinaryOp.java``):

* ``a / b`` is always a double; ``+ - *`` of two ints is an int.
* ``floor``, ``ceil``, ``round`` give ints; ``round(x) = floor(x + 1/2)`` (Java ``Math.round``).
* ``pow(i, j)`` of two ints is an int and needs ``j >= 0``; with a double it is a double.
* ``mod(i, n)`` needs ``n > 0`` and is never negative: ``mod(-1, 3) = 2`` (PRISM's ``applyMod``
  adds ``n`` to Java's negative remainder), which is Python's ``%`` for ``n > 0``.
* ``log(x, b) = ln x / ln b``; ``min``/``max`` are n-ary.

Division is IEEE as PRISM's doubles: ``1/0`` is an infinity and ``0/0`` NaN. The partial operators
(``mod``, ``pow`` of ints, ``floor``/``ceil``/``round``) and the exact/IEEE arithmetic come from
:mod:`posgmc.semantics.operators`, shared with the exploration code generator and the state-formula
evaluator.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from fractions import Fraction

from posgmc.errors import PosgmcError, SemanticError, SourceSpan
from posgmc.semantics import operators as ops
from posgmc.semantics.symbols import Symbol, SymbolKind, Type, span_or_none
from posgmc.semantics.types import TypeChecker
from posgmc.syntax.ast import (
    NO_SPAN,
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    DoubleLit,
    Expr,
    Function,
    Ident,
    IntLit,
    Ite,
    Unary,
    UnaryOp,
)
from posgmc.syntax.traversal import children, iter_nodes, map_children

__all__ = [
    "Value",
    "evaluate",
    "evaluate_constant",
    "format_value",
    "free_names",
    "is_literal",
    "literal",
    "literal_value",
    "simplify",
    "substitute",
    "to_double",
    "value_type",
]

Value = bool | int | Fraction | float
"""A scalar value (see the module docstring for which Python type stands for which PRISM type)."""


# ---------------------------------------------------------------------------------------------
# values
# ---------------------------------------------------------------------------------------------


def value_type(v: Value) -> Type:
    """The PRISM type of a value (bool is checked first: Python's bool is an int)."""
    if isinstance(v, bool):
        return Type.BOOL
    if isinstance(v, int):
        return Type.INT
    return Type.DOUBLE


def to_double(v: Value) -> Fraction | float:
    """Widen an int (or keep a double); Booleans are not numbers."""
    if isinstance(v, bool):
        raise TypeError("a Boolean is not a number")
    if isinstance(v, int):
        return Fraction(v)
    return v


def literal(v: Value, *, span: SourceSpan = NO_SPAN) -> Expr:
    """The literal node for a value.

    Raises:
        ValueError: for a non-finite float (no literal can hold it).
    """
    if isinstance(v, bool):
        return BoolLit(v, span=span)
    if isinstance(v, int):
        return IntLit(v, span=span)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"no literal for the non-finite value {v}")
        return DoubleLit(Fraction(v), span=span)
    return DoubleLit(v, span=span)


def format_value(v: Value) -> str:
    """A value as PRISM would print it: ``true``, ``3``, ``0.25``; a Fraction without a finite
    decimal expansion as ``1/3``."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if v.denominator == 1:
        return str(v.numerator)
    d = v.denominator
    for p in (2, 5):
        while d % p == 0:
            d //= p
    if d != 1:
        return f"{v.numerator}/{v.denominator}"
    digits = 0
    scaled = v
    while scaled.denominator != 1:
        scaled *= 10
        digits += 1
    sign = "-" if v < 0 else ""
    whole, frac = divmod(abs(scaled.numerator), 10**digits)
    return f"{sign}{whole}.{frac:0{digits}d}"


def is_literal(e: Expr) -> bool:
    return isinstance(e, (BoolLit, IntLit, DoubleLit))


def literal_value(e: Expr) -> Value:
    """The value of a literal node."""
    if isinstance(e, (BoolLit, IntLit, DoubleLit)):
        return e.value
    raise TypeError(f"{type(e).__name__} is not a literal")


# tree utilities (children, map_children, iter_nodes) live with the syntax tree:
# posgmc/syntax/traversal.py; they are imported above for the walks below


def free_names(e: Expr) -> set[str]:
    """The identifiers occurring in ``e``."""
    return {n.name for n in iter_nodes(e) if isinstance(n, Ident)}


def substitute(
    expr: Expr, mapping: Mapping[str, Expr | Value], *, keep_span: bool = True
) -> Expr:
    """Replace identifiers by expressions or values.

    Args:
        expr: the expression.
        mapping: name -> replacement; a value becomes a literal. Replacements are inserted as
            they are (not substituted again).
        keep_span: give the replacement's top node the span of the identifier it replaces, so
            that an error about the use (e.g. "guard must be Boolean") points at the use, while
            errors inside an inlined formula still point into its definition.

    Returns:
        The new expression (``expr`` itself if no identifier was replaced).
    """

    def go(e: Expr) -> Expr:
        if isinstance(e, Ident):
            if e.name not in mapping:
                return e
            r = mapping[e.name]
            if not isinstance(r, Expr):
                return literal(r, span=e.span)
            return dataclasses.replace(r, span=e.span) if keep_span else r
        return map_children(e, go)

    return go(expr)


# ---------------------------------------------------------------------------------------------
# evaluation
# ---------------------------------------------------------------------------------------------


def _error(message: str, e: Expr) -> SemanticError:
    return SemanticError(message, span_or_none(e.span))


def _int_checked(value: Value, text: str, e: Expr) -> Value:
    """An int result must be a 64-bit integer (docs/language.md); doubles are unchecked."""
    if type(value) is int:
        try:
            ops.check_int(value, text)
        except ops.DomainFailure as failure:
            raise _error(failure.message, e) from None
    return value


def _static_type(e: Expr, env: Mapping[str, Value]) -> Type | None:
    def lookup(name: str) -> Symbol | None:
        if name in env:
            return Symbol(name, SymbolKind.CONSTANT, value_type(env[name]))
        return None

    errors: list[PosgmcError] = []
    return TypeChecker(lookup=lookup, errors=errors).check(e)


def evaluate(expr: Expr, env: Mapping[str, Value]) -> Value:
    """Evaluate a (type-correct) expression.

    Args:
        expr: a model expression: no labels, temporal operators or queries.
        env: values of the identifiers that occur (constants, variables); doubles as Fraction or
            float, ints as int.

    Returns:
        The value, typed as described in the module docstring.

    Raises:
        SemanticError: an identifier without a value, ``mod`` by a
            non-positive number, a negative integer exponent, or a non-finite value where an
            int is needed.
    """

    def num(e: Expr) -> int | Fraction | float:
        v = ev(e)
        if isinstance(v, bool):
            raise _error("a Boolean is used as a number", e)
        return v

    def boolean(e: Expr) -> bool:
        v = ev(e)
        if not isinstance(v, bool):
            raise _error("a number is used as a Boolean", e)
        return v

    def ev(e: Expr) -> Value:
        if isinstance(e, (BoolLit, IntLit, DoubleLit)):
            return e.value
        if isinstance(e, Ident):
            if e.name not in env:
                raise _error(f'"{e.name}" has no value here', e)
            return env[e.name]
        if isinstance(e, Unary):
            if e.op is UnaryOp.NOT:
                return not boolean(e.operand)
            a = num(e.operand)
            return _int_checked(-a, f"-({a})", e)
        if isinstance(e, Binary):
            return binary(e)
        if isinstance(e, Ite):
            chosen, other = (e.then, e.otherwise) if boolean(e.cond) else (e.otherwise, e.then)
            v = ev(chosen)
            if isinstance(v, int) and not isinstance(v, bool):
                # the "? :" is a double if either branch is: keep the typing invariant
                if _static_type(other, env) is Type.DOUBLE:
                    return Fraction(v)
            return v
        if isinstance(e, Call):
            return call(e)
        raise _error(f"{type(e).__name__} cannot be evaluated to a value", e)

    def binary(e: Binary) -> Value:
        op = e.op
        if op is BinaryOp.AND:
            return boolean(e.left) and boolean(e.right)
        if op is BinaryOp.OR:
            return boolean(e.left) or boolean(e.right)
        if op is BinaryOp.IMPLIES:
            return (not boolean(e.left)) or boolean(e.right)
        if op is BinaryOp.IFF:
            return boolean(e.left) == boolean(e.right)
        if op in (BinaryOp.EQ, BinaryOp.NE):
            a, b = ev(e.left), ev(e.right)
            if isinstance(a, bool) != isinstance(b, bool):
                raise _error(f'"{op.value}" compares a Boolean with a number', e)
            return (a == b) if op is BinaryOp.EQ else (a != b)
        a_n, b_n = num(e.left), num(e.right)
        if op is BinaryOp.LT:
            return a_n < b_n
        if op is BinaryOp.LE:
            return a_n <= b_n
        if op is BinaryOp.GT:
            return a_n > b_n
        if op is BinaryOp.GE:
            return a_n >= b_n
        if op is BinaryOp.ADD:
            return _int_checked(a_n + b_n, f"{a_n} + {b_n}", e)
        if op is BinaryOp.SUB:
            return _int_checked(a_n - b_n, f"{a_n} - {b_n}", e)
        if op is BinaryOp.MUL:
            return _int_checked(a_n * b_n, f"{a_n} * {b_n}", e)
        # DIV: always a double; exact while both are exact, IEEE otherwise
        try:
            return ops.scalar_divide(a_n, b_n)
        except ops.DomainFailure as failure:  # exact mode only
            raise _error(failure.message, e) from None

    def call(e: Call) -> Value:
        fn = e.function
        args = [num(a) for a in e.args]
        if fn in (Function.MIN, Function.MAX):
            if not args:
                raise _error(f"{fn.value}() needs at least one argument", e)
            r = min(args) if fn is Function.MIN else max(args)
            is_double = any(not isinstance(x, int) for x in args)
            return to_double(r) if is_double else r
        try:
            if len(args) == 1 and fn in (Function.FLOOR, Function.CEIL, Function.ROUND):
                return ops.scalar_to_int(args[0], fn.value)
            if len(args) != 2:
                raise _error(f"{fn.value}() takes 2 arguments, found {len(args)}", e)
            a, b = args
            if fn is Function.MOD:
                if not (isinstance(a, int) and isinstance(b, int)):
                    raise _error("mod() needs int arguments", e)
                return ops.scalar_mod(a, b)
            if fn is Function.POW:
                if isinstance(a, int) and isinstance(b, int):
                    return ops.scalar_int_pow(a, b)
                return ops.scalar_pow(a, b)
            return ops.scalar_log(a, b)
        except ops.DomainFailure as failure:
            raise _error(failure.message, e) from None

    return ev(expr)


def evaluate_constant(expr: Expr) -> Value:
    """Evaluate an expression without identifiers (e.g. a folded threshold or step bound).

    Raises:
        SemanticError: an identifier occurs, or the evaluation fails (see :func:`evaluate`).
    """
    return evaluate(expr, {})


# ---------------------------------------------------------------------------------------------
# constant folding
# ---------------------------------------------------------------------------------------------


def simplify(expr: Expr, *, variable_types: Mapping[str, Type] | None = None) -> Expr:
    """Fold every sub-expression without identifiers into a literal, and the Boolean units
    (``true & e`` -> ``e``, ``false & e`` -> ``false``, ``c ? a : b`` with a literal ``c``, ...).

    Args:
        expr: the expression; identifiers left are variables (constants already substituted).
        variable_types: the variables' types; lets ``c ? a : b`` with a literal ``c`` fold when the
            kept branch has the type of the whole (an int branch of a double ``? :`` stays put
            unless it is a literal).

    Returns:
        An equivalent expression (same type). Sub-expressions whose evaluation fails (e.g. a
        division by zero) are left unfolded, so that the error surfaces where they are used.
    """
    types = dict(variable_types or {})

    def lookup(name: str) -> Symbol | None:
        t = types.get(name)
        return None if t is None else Symbol(name, SymbolKind.VARIABLE, t)

    def static(e: Expr) -> Type | None:
        errors: list[PosgmcError] = []
        return TypeChecker(lookup=lookup, errors=errors, allow_queries=True).check(e)

    def fold(e: Expr) -> Expr:
        try:
            return literal(evaluate(e, {}), span=e.span)
        except (PosgmcError, ValueError, OverflowError, ZeroDivisionError):
            return e

    def go(e: Expr) -> Expr:
        e = map_children(e, go)
        if isinstance(e, (Unary, Binary, Ite, Call)) and all(is_literal(c) for c in children(e)):
            return fold(e)
        if isinstance(e, Binary) and e.op in (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES):
            return logic(e)
        if isinstance(e, Ite) and isinstance(e.cond, BoolLit):
            chosen, other = (e.then, e.otherwise) if e.cond.value else (e.otherwise, e.then)
            if isinstance(chosen, IntLit) and isinstance(other, DoubleLit):
                return DoubleLit(Fraction(chosen.value), span=chosen.span)
            t_chosen, t_other = static(chosen), static(other)
            if t_chosen is not None and t_chosen is t_other:
                return chosen
            if t_chosen is not None and t_other is not None and t_chosen is Type.DOUBLE:
                return chosen
            if isinstance(chosen, IntLit) and t_other is Type.DOUBLE:
                return DoubleLit(Fraction(chosen.value), span=chosen.span)
        return e

    def logic(e: Binary) -> Expr:
        left, right = e.left, e.right
        lv = left.value if isinstance(left, BoolLit) else None
        rv = right.value if isinstance(right, BoolLit) else None
        if e.op is BinaryOp.AND:
            if lv is False or rv is False:
                return BoolLit(False, span=e.span)
            if lv is True:
                return right
            if rv is True:
                return left
        elif e.op is BinaryOp.OR:
            if lv is True or rv is True:
                return BoolLit(True, span=e.span)
            if lv is False:
                return right
            if rv is False:
                return left
        else:  # IMPLIES
            if lv is False or rv is True:
                return BoolLit(True, span=e.span)
            if lv is True:
                return right
        return e

    return go(expr)
