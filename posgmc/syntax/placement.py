"""Where temporal operators may stand: only directly inside ``P[..]``/``R[..]`` (and nested in
path formulas there), checked on the syntax tree as PRISM's parser does; and what an unparenthesised
unary temporal operator takes as its operand (:func:`binary`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from posgmc.errors import ParseError, SourceSpan
from posgmc.syntax.ast import (
    Binary,
    BinaryOp,
    Call,
    Expr,
    Filter,
    Ite,
    MultiQuery,
    PathQuantifier,
    ProbQuery,
    RewardKind,
    RewardQuery,
    Temporal,
    Unary,
)


def binary(op: BinaryOp, left: Expr, right: Expr, span: SourceSpan) -> Expr:
    """The node for ``left op right`` as the grammar reduced it, read as Storm reads an
    unparenthesised unary temporal operator on its left: ``X y=6`` (which PRISM's precedence
    makes ``(X y) = 6``, a type error there) is ``X (y=6)``, so ``F (y=5 & X y=6)`` means
    ``F (y=5 & X (y=6))``. Applied at each reduction, ``X y+1 = 6`` becomes ``X (y+1 = 6)``.
    Connectives keep PRISM's reading (``X a & b`` is ``(X a) & b`` in both tools), and so does
    a parenthesised ``(X y) = 6``, which stays an error."""
    if (
        op not in _CONNECTIVES
        and isinstance(left, Temporal)
        and len(left.operands) == 1
        and (left.span.line, left.span.column) == (span.line, span.column)
        and span.line > 0
    ):
        operand = left.operands[0]
        inner = SourceSpan(
            operand.span.line, operand.span.column, span.end_line, span.end_column, span.file
        )
        joined = Binary(op, operand, right, span=inner)
        return dataclasses.replace(left, operands=(joined,), span=span)
    return Binary(op, left, right, span=span)


def contains_temporal(expr: Expr) -> bool:
    """True if ``expr`` has a temporal operator outside any nested P/R query."""
    if isinstance(expr, Temporal):
        return True
    return any(contains_temporal(child) for child in _state_children(expr))


def _state_children(expr: Expr) -> Iterable[Expr]:
    """The operands of ``expr`` that belong to the same formula (nested queries excluded)."""
    if isinstance(expr, Unary):
        return (expr.operand,)
    if isinstance(expr, Binary):
        return (expr.left, expr.right)
    if isinstance(expr, Ite):
        return (expr.cond, expr.then, expr.otherwise)
    if isinstance(expr, Call):
        return expr.args
    if isinstance(expr, Filter):
        return (expr.operand,) if expr.states is None else (expr.operand, expr.states)
    if isinstance(expr, Temporal):
        return expr.operands
    if isinstance(expr, MultiQuery):
        return expr.objectives
    return ()


def check_temporal_placement(expr: Expr, *, allowed: bool) -> None:
    """Reject temporal operators outside ``P[..]``/``R[..]`` (PRISM rejects them while parsing).

    Args:
        expr: a property expression.
        allowed: whether ``expr`` itself stands where a path formula may.

    Raises:
        ParseError: at the first misplaced temporal operator.
    """
    if isinstance(expr, Temporal):
        if not allowed:
            raise ParseError(
                f"the temporal operator {expr.op.value} may only appear inside P[...] or R[...]",
                expr.span,
                hint='write e.g. Pmax=? [ F "goal" ] instead of F "goal"',
            )
        for operand in expr.operands:
            check_temporal_placement(operand, allowed=True)
        if expr.bound is not None:
            for b in (expr.bound.lower, expr.bound.upper):
                if b is not None:
                    check_temporal_placement(b, allowed=False)
        return
    if isinstance(expr, ProbQuery):
        if expr.threshold is not None:
            check_temporal_placement(expr.threshold.value, allowed=False)
        check_temporal_placement(expr.path, allowed=True)
        return
    if isinstance(expr, PathQuantifier):
        check_temporal_placement(expr.path, allowed=True)
        return
    if isinstance(expr, RewardQuery):
        if expr.threshold is not None:
            check_temporal_placement(expr.threshold.value, allowed=False)
        obj = expr.objective
        for part in (obj.bound, obj.discount):
            if part is not None:
                check_temporal_placement(part, allowed=False)
        if obj.target is not None:
            check_temporal_placement(obj.target, allowed=obj.kind is RewardKind.LTL)
        return
    if allowed and isinstance(expr, Binary) and expr.op not in _CONNECTIVES:
        _check_not_compared(expr)
    for child in _state_children(expr):
        check_temporal_placement(child, allowed=allowed)


_CONNECTIVES = (BinaryOp.AND, BinaryOp.OR, BinaryOp.IMPLIES, BinaryOp.IFF)


def _check_not_compared(expr: Binary) -> None:
    """Storm reads ``a & X x=1`` as ``a & X (x=1)``; posgmc's grammar (PRISM's precedence for the
    unparenthesised operand) gives ``(X x) = 1``, which means nothing: say where the parentheses
    go."""
    from posgmc.syntax.printer import format_expr

    for side in (expr.left, expr.right):
        if isinstance(side, Temporal) and len(side.operands) == 1:
            if side is expr.left:
                inner = dataclasses.replace(expr, left=side.operands[0])
            else:
                inner = dataclasses.replace(expr, right=side.operands[0])
            suggestion = format_expr(dataclasses.replace(side, operands=(inner,)))
            raise ParseError(
                f"the temporal formula {format_expr(side)} cannot be an operand of "
                f'"{expr.op.value}"',
                side.span,
                hint=f"an unparenthesised temporal operand takes one operand only; "
                f"write {suggestion} (parenthesise the state formula the operator applies to)",
            )
