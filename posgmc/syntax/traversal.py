"""Traversal of expression trees, defined once: a node's children, a rebuild with new children,
and every node in order. Every walk over expressions (checks, substitution, dispatch) uses these."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator

from posgmc.syntax.ast import (
    Binary,
    Call,
    Expr,
    Filter,
    Ite,
    MultiQuery,
    PathQuantifier,
    ProbQuery,
    RewardObjective,
    RewardQuery,
    SteadyQuery,
    Temporal,
    Threshold,
    TimeBound,
    Unary,
)

__all__ = ["any_node", "children", "iter_nodes", "map_children", "is_temporal",
           "contains_query"]



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
    if isinstance(e, Filter):
        return (e.operand,) if e.states is None else (e.operand, e.states)
    if isinstance(e, PathQuantifier):
        return (e.path,)
    if isinstance(e, SteadyQuery):
        return ((e.threshold.value,) if e.threshold else ()) + (e.operand,)
    if isinstance(e, Temporal):
        out = list(e.operands)
        if e.bound is not None:
            out += [x for x in (e.bound.lower, e.bound.upper) if x is not None]
        return tuple(out)
    if isinstance(e, MultiQuery):
        return e.objectives
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
    elif isinstance(e, Filter):
        new = dataclasses.replace(e, operand=f(e.operand), states=opt(e.states))
    elif isinstance(e, PathQuantifier):
        new = dataclasses.replace(e, path=f(e.path))
    elif isinstance(e, SteadyQuery):
        new = dataclasses.replace(e, threshold=thr(e.threshold), operand=f(e.operand))
    elif isinstance(e, Temporal):
        bound: TimeBound | None = e.bound
        if bound is not None:
            bound = dataclasses.replace(bound, lower=opt(bound.lower), upper=opt(bound.upper))
        new = dataclasses.replace(e, operands=tuple(f(a) for a in e.operands), bound=bound)
    elif isinstance(e, MultiQuery):
        new = dataclasses.replace(e, objectives=tuple(f(o) for o in e.objectives))
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


def iter_nodes(e: Expr) -> Iterator[Expr]:
    """Every node of the tree, parents before children."""
    stack = [e]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(children(node)))


def any_node(
    e: Expr, test: Callable[[Expr], bool], *, into: Callable[[Expr], bool] = lambda _: True
) -> bool:
    """Whether ``test`` holds for some node of ``e``, descending only into nodes for which
    ``into`` holds (e.g. not into nested queries)."""
    stack = [e]
    while stack:
        node = stack.pop()
        if test(node):
            return True
        if into(node):
            stack.extend(children(node))
    return False


def is_temporal(e: Expr) -> bool:
    """Whether a path formula contains a temporal operator outside nested queries."""
    return any_node(
        e,
        lambda n: isinstance(n, Temporal),
        into=lambda n: isinstance(n, (Unary, Binary)),
    )


def contains_query(e: Expr) -> bool:
    """Whether a state expression contains a ``P``/``R`` query."""
    return any_node(
        e,
        lambda n: isinstance(n, (ProbQuery, RewardQuery, Filter, PathQuantifier, SteadyQuery)),
        into=lambda n: not isinstance(n, (ProbQuery, RewardQuery, Temporal)),
    )
