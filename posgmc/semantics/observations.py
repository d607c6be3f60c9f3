"""Observables: what the agent of a pomdp, or each player of a posg, observes.

Where observables may be declared (decisions, with the PRISM-games evidence):

* ``pomdp``: top-level ``observables x, y endobservables`` / ``observable "n" = e;``, and at least
  one (PRISM-games ``ModulesFile.checkObservables``: "pomdps must specify observables").
* ``smg``: top-level observables are accepted, as in PAYNT's POSMG sources (``posmg/prism-models``):
  they describe what the player of the property's coalition observes. PRISM-games itself rejects
  them ("smgs cannot specify observables"); posgmc keeps PAYNT's reading. Observables inside a
  player block are an error in an smg (hint: use ``posg``), so that the per-player reading is
  never silently lost.
* ``posg``: observables live inside player blocks (a player without any observes the whole
  state); top-level observables are an error (hint: move them into the observing player's block);
  a posg without any observables is an error (hint: use ``smg``), by analogy with PRISM's rule
  for pomdps.
* ``dtmc``/``mdp``: no observables (hint: use ``pomdp``).

Names (PRISM-games ``ModulesFile.addObservable`` -> ``checkAndAddQuotedIdentifier``): an
observable's name lives in the *quoted* namespace it shares with labels, not in the namespace of
variables. Hence ``observable "d1y" = d1y;`` and even ``observable "p2x" = p1x;`` beside a variable
``p2x`` are legal, as PRISM-games accepts them (the ``attacker-defender*`` and ``pursuit-evasion``
models listed in benchmarks' LINT_EXCEPTIONS; Storm rejects them); two observables of one name in
one scope are an error. An observable named like a label is PRISM's error too, but Storm keeps the
two apart (PAYNT's ``maze-10``): it is accepted with a warning, the label keeping the name in
properties, and refused with ``strict`` (``dialect.py``). An ``observables`` list names
variables only ("Observable variables list can only contain variables"); its entries are
observables named after the variables. The same name may be declared by several posg players only
with the same definition, so that it means one thing when a property uses it as a label.

Observables are usable in properties as labels (PRISM's ``FindAllObsRefs``), with their own type;
Boolean ones are also put in :attr:`FlatModel.labels`. Observables must be int or bool (the
compiled model stores observation values as int64); a double observable is unsupported.
"""

from __future__ import annotations

from dataclasses import dataclass

from posgmc.errors import PosgmcError, SourceSpan, UnsupportedError
from posgmc.semantics.dialect import LABEL_OBSERVABLE, Dialect
from posgmc.semantics.resolve import ResolvedModel, position
from posgmc.semantics.symbols import (
    SymbolKind,
    Type,
    line_of,
    model_type_phrase,
    report,
    span_or_none,
)
from posgmc.semantics.types import TypeChecker
from posgmc.syntax.ast import Expr, ModelType, NamedObservable, Observable, ObservableVars

__all__ = ["ObservableInfo", "Observations", "check_observables"]


@dataclass(frozen=True)
class ObservableInfo:
    """One observable: its name, expression (an ``Ident`` for an observed variable; formulas
    inlined, constants not yet substituted) and type (None if its expression has an error)."""

    name: str
    expr: Expr
    type: Type | None
    span: SourceSpan


@dataclass(frozen=True)
class Observations:
    """The checked observables. ``top``: top-level ones (pomdp, PAYNT-style smg), None when the
    model declares none; ``players``: per player name, posg only (a player absent from the mapping
    observes the whole state); ``by_name``: every observable by name (first declaration), for
    properties that use observables as labels."""

    top: tuple[ObservableInfo, ...] | None
    players: dict[str, tuple[ObservableInfo, ...]]
    by_name: dict[str, ObservableInfo]


def _entries(
    decls: tuple[Observable, ...],
    resolved: ResolvedModel,
    tc: TypeChecker,
    errors: list[PosgmcError],
) -> list[ObservableInfo]:
    out: list[ObservableInfo] = []
    for d in decls:
        if isinstance(d, ObservableVars):
            for ident in d.variables:
                sym = resolved.lookup(ident.name)
                if sym is None:
                    report(errors, f'undefined name "{ident.name}"', ident.span)
                    continue
                if sym.kind is not SymbolKind.VARIABLE:
                    report(
                        errors,
                        f'observable "{ident.name}" is not a variable (it is a {sym.kind.value}); '
                        f'use observable "{ident.name}" = expr;',
                        ident.span,
                        hint="an observables list names variables only",
                    )
                    continue
                out.append(ObservableInfo(ident.name, ident, sym.type, ident.span))
        else:
            assert isinstance(d, NamedObservable)
            t = tc.check(d.expr)
            if t is Type.DOUBLE:
                errors.append(
                    UnsupportedError(
                        f'observable "{d.name}" is a double; observables must be int or bool',
                        span_or_none(d.expr.span),
                        hint="observe a rounded or scaled int expression instead",
                    )
                )
                t = None
            out.append(ObservableInfo(d.name, d.expr, t, d.span))
    return out


def _check_scope(
    infos: list[ObservableInfo],
    labels: dict[str, SourceSpan],
    errors: list[PosgmcError],
    dialect: Dialect,
) -> tuple[ObservableInfo, ...]:
    seen: dict[str, ObservableInfo] = {}
    for o in sorted(infos, key=lambda o: position(o.span)):
        if o.name in labels and o.name not in seen:
            dialect.storm_only(
                errors,
                f'observable "{o.name}" has the name of label "{o.name}"{line_of(labels[o.name])}',
                span_or_none(o.span),
                LABEL_OBSERVABLE,
            )
        if o.name in seen:
            report(
                errors,
                f'observable "{o.name}" is already declared{line_of(seen[o.name].span)}',
                o.span,
            )
        else:
            seen[o.name] = o
    return tuple(o for o in infos if seen.get(o.name) is o)


def check_observables(
    resolved: ResolvedModel, tc: TypeChecker, errors: list[PosgmcError], dialect: Dialect
) -> Observations:
    """Check where observables are declared, what they name, and their types.

    Args:
        resolved: the resolved model (observable expressions have formulas inlined).
        tc: the model's type checker (model expressions: no labels, no queries).
        errors: where errors are appended.
        dialect: what a name shared with a label means (Storm: nothing; PRISM: an error).

    Returns:
        The checked observables (see :class:`Observations`).
    """
    mtype = resolved.model.model_type
    labels = {d.name: d.span for d in resolved.labels}
    top_decls = resolved.observables
    top: tuple[ObservableInfo, ...] | None = None
    if top_decls:
        if mtype in (ModelType.DTMC, ModelType.MDP):
            report(
                errors,
                f"{model_type_phrase(mtype)} cannot declare observables",
                top_decls[0].span,
                hint="declare the model as pomdp to make it partially observable",
            )
        elif mtype is ModelType.POSG:
            report(
                errors,
                "a posg declares observables inside player blocks, not at the top level",
                top_decls[0].span,
                hint="move them into the block of the player who observes them",
            )
        else:
            top = _check_scope(_entries(top_decls, resolved, tc, errors), labels, errors, dialect)
    elif mtype is ModelType.POMDP:
        span = resolved.model.span if resolved.model.span.line else SourceSpan(1, 1)
        report(
            errors,
            "a pomdp must declare observables",
            span,
            hint='add "observables x, y endobservables" or "observable \\"name\\" = expr;"',
        )

    per_player: dict[str, tuple[ObservableInfo, ...]] = {}
    for p in resolved.players:
        if not p.observables:
            continue
        if mtype is not ModelType.POSG:
            report(
                errors,
                "observables inside a player block are only allowed in a posg, not in "
                + model_type_phrase(mtype),
                p.observables[0].span,
                hint="declare the model as posg to give each player its own observations",
            )
            continue
        if p.name in per_player:
            continue  # doubly defined player: reported by the player checks
        per_player[p.name] = _check_scope(
            _entries(p.observables, resolved, tc, errors), labels, errors, dialect
        )
    if mtype is ModelType.POSG and resolved.players and not per_player:
        report(
            errors,
            "a posg must declare observables in at least one player block",
            resolved.players[0].span,
            hint="a game in which every player sees the whole state is an smg",
        )

    by_name: dict[str, ObservableInfo] = {}
    owner: dict[str, str] = {}
    for o in top or ():
        by_name.setdefault(o.name, o)
    for pname, infos in per_player.items():
        for o in infos:
            first = by_name.get(o.name)
            if first is None:
                by_name[o.name] = o
                owner[o.name] = pname
            elif first.expr != o.expr:
                report(
                    errors,
                    f'observable "{o.name}" of player "{pname}" differs from observable '
                    f'"{o.name}" of player "{owner.get(o.name, "?")}"{line_of(first.span)}',
                    o.span,
                    hint="observables of the same name must have the same definition; rename one",
                )
    return Observations(top, per_player, by_name)
