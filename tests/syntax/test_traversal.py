"""syntax/traversal.py: the one definition of children, rebuilding and walking expression trees."""

from __future__ import annotations

from posgmc.syntax.ast import BinaryOp, Ident, IntLit, LabelRef, ProbQuery, Temporal
from posgmc.syntax.parser import parse_property
from posgmc.syntax.traversal import children, contains, iter_nodes, map_children


def test_iter_nodes_parents_first_and_queries_optional() -> None:
    e = parse_property('P=? [ F "a" ] + P=? [ F x=1 ] * 2').expr
    kinds = [type(n).__name__ for n in iter_nodes(e)]
    assert kinds[0] == "Binary" and kinds.count("ProbQuery") == 2 and "Temporal" in kinds
    shallow = list(iter_nodes(e, into_queries=False))
    assert not any(isinstance(n, (Temporal, LabelRef)) for n in shallow)
    assert sum(isinstance(n, ProbQuery) for n in shallow) == 2


def test_contains_stops_at_queries_when_asked() -> None:
    path = parse_property('P=? [ F "a" & P>0.5 [ X "b" ] ]').expr.path  # type: ignore[attr-defined]
    assert contains(path, Temporal)
    inner = path.operands[0].right  # the nested P>0.5 [ X "b" ]
    assert contains(inner, Temporal) and not contains(inner, Temporal, into_queries=False)


def test_map_children_keeps_identity_when_nothing_changes() -> None:
    e = parse_property("x + 1 > 2").expr
    assert map_children(e, lambda c: c) is e
    renamed = map_children(e.left, lambda c: Ident("y") if c == Ident("x") else c)  # type: ignore[attr-defined]
    assert renamed.left == Ident("y") and renamed.op is BinaryOp.ADD and children(renamed)[1] == IntLit(1)
