"""Tree traversal, defined once with the syntax tree: the direct sub-expressions of every node
(``children``), rebuilding a node from new sub-expressions (``map_children``), walking a whole tree
(``iter_nodes``) and asking whether some node occurs (``contains``).

Every pass that walks expressions (substitution, constant folding, type checks, the checker's
questions "is this a path formula?", "does this mention a query?") uses these instead of its own
``isinstance`` ladder, so a new node kind needs teaching here only.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator

from posgmc.syntax.ast import (
    Binary,
    Call,
    Expr,
    Ite,
    ProbQuery,
    RewardObjective,
    RewardQuery,
    Temporal,
    Threshold,
    TimeBound,
    Unary,
)

__all__ = ["children", "contains", "iter_nodes", "map_children"]


def children(e: Expr) -> tuple[Expr, ...]:
    """The direct sub-expressions of a node, including bounds and thresholds."""
    if isinstance(e, Unary):
        return (e.operand,)
    if isinstance(e, Binary):
        return (e.left, e.right)
    if isinstance(e, Ite):
        return (e.cond, e.then, e.otherwise)
    if isinstance(e, Call):
        return e.args
    if isinstance(e, Temporal):
        out = list(e.operands)
        if e.bound is not None:
            out += [x for x in (e.bound.lower, e.bound.upper) if x is not None]
        return tuple(out)
    if isinstance(e, ProbQuery):
        return ((e.threshold.value,) if e.threshold else ()) + (e.path,)
    if isinstance(e, RewardQuery):
        obj = e.objective
        parts = [e.threshold.value] if e.threshold else []
        parts += [x for x in (obj.target, obj.bound, obj.discount) if x is not None]
        return tuple(parts)
    return ()


def map_children(e: Expr, f: Callable[[Expr], Expr]) -> Expr:
    """``e`` with ``f`` applied to each direct sub-expression (``e`` itself if nothing changed)."""

    def opt(x: Expr | None) -> Expr | None:
        return None if x is None else f(x)

    def thr(t: Threshold | None) -> Threshold | None:
        if t is None:
            return None
        v = f(t.value)
        return t if v is t.value else dataclasses.replace(t, value=v)

    new: Expr
    if isinstance(e, Unary):
        new = dataclasses.replace(e, operand=f(e.operand))
    elif isinstance(e, Binary):
        new = dataclasses.replace(e, left=f(e.left), right=f(e.right))
    elif isinstance(e, Ite):
        new = dataclasses.replace(e, cond=f(e.cond), then=f(e.then), otherwise=f(e.otherwise))
    elif isinstance(e, Call):
        new = dataclasses.replace(e, args=tuple(f(a) for a in e.args))
    elif isinstance(e, Temporal):
        bound: TimeBound | None = e.bound
        if bound is not None:
            bound = dataclasses.replace(bound, lower=opt(bound.lower), upper=opt(bound.upper))
        new = dataclasses.replace(e, operands=tuple(f(a) for a in e.operands), bound=bound)
    elif isinstance(e, ProbQuery):
        new = dataclasses.replace(e, threshold=thr(e.threshold), path=f(e.path))
    elif isinstance(e, RewardQuery):
        obj: RewardObjective = e.objective
        obj = dataclasses.replace(
            obj, target=opt(obj.target), bound=opt(obj.bound), discount=opt(obj.discount)
        )
        new = dataclasses.replace(e, threshold=thr(e.threshold), objective=obj)
    else:
        return e
    return e if _same_children(new, e) else new


def _same_children(a: Expr, b: Expr) -> bool:
    # equality ignores spans; identity tells whether anything was actually replaced
    return all(x is y for x, y in zip(children(a), children(b)))


def iter_nodes(e: Expr, *, into_queries: bool = True) -> Iterator[Expr]:
    """Every node of the tree, parents before children.

    Args:
        e: the root.
        into_queries: also walk inside nested ``P``/``R`` queries (False: a query node is yielded
            but not entered, e.g. to ask about one path formula without its nested queries).
    """
    stack = [e]
    while stack:
        node = stack.pop()
        yield node
        if into_queries or not isinstance(node, (ProbQuery, RewardQuery)):
            stack.extend(reversed(children(node)))


def contains(
    e: Expr, kinds: type[Expr] | tuple[type[Expr], ...], *, into_queries: bool = True
) -> bool:
    """Whether a node of one of ``kinds`` occurs in ``e`` (``e`` itself included); see
    :func:`iter_nodes` for ``into_queries``."""
    return any(isinstance(n, kinds) for n in iter_nodes(e, into_queries=into_queries))
