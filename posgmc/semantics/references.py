"""PRISM's references to other properties: ``"name"`` inside a property stands for the property
of the same file named ``name``, when no label of that name exists (PRISM's
``PropertiesFile.findAllPropRefs``: ``"six": P=? [ F d=6 ] + "x"`` adds property ``"x"``).

Labels win: a quoted name that is a label of the model or of the file, an observable, or a built-in
label keeps its meaning; only the remaining names are looked up among the properties.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection

from posgmc.errors import SemanticError
from posgmc.semantics.resolve import RESERVED_LABELS
from posgmc.syntax.ast import Expr, LabelRef, PropertiesFile
from posgmc.syntax.traversal import map_children

__all__ = ["inline_property_references"]


def inline_property_references(
    pf: PropertiesFile, labels: Collection[str]
) -> tuple[PropertiesFile, dict[int, SemanticError]]:
    """``pf`` with every reference to a named property replaced by that property's expression.

    Args:
        pf: a parsed properties file.
        labels: the quoted names of the model (labels and observables usable as labels).

    Returns:
        The file with its properties' expressions inlined (``pf`` itself when nothing refers),
        and for each property (by index) that refers to itself, directly or through others, the
        error naming the cycle (that property is left as written).
    """
    taken = set(labels) | {d.name for d in pf.labels} | set(RESERVED_LABELS)
    named = {p.name: p for p in pf.properties if p.name and p.name not in taken}
    if not named:
        return pf, {}
    done: dict[str, Expr] = {}

    def inline(e: Expr, path: tuple[str, ...]) -> Expr:
        if isinstance(e, LabelRef) and e.name in named:
            if e.name in path:
                cycle = " -> ".join(f'"{n}"' for n in (*path[path.index(e.name):], e.name))
                raise SemanticError(f"property {cycle} refers to itself", e.span,
                                    hint="a property may use other properties by name, not itself")
            if e.name not in done:
                done[e.name] = inline(named[e.name].expr, (*path, e.name))
            return done[e.name]
        return map_children(e, lambda c: inline(c, path))

    props = []
    errors: dict[int, SemanticError] = {}
    for i, p in enumerate(pf.properties):
        try:
            props.append(dataclasses.replace(p, expr=inline(p.expr, (p.name,) if p.name else ())))
        except SemanticError as err:
            errors[i] = err
            props.append(p)
    return dataclasses.replace(pf, properties=tuple(props)), errors
