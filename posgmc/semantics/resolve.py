"""Name resolution for a model file: formulas expanded, renamed modules expanded, and the table of
what every name means, with duplicate and cyclic definitions reported.

PRISM's order (``ModulesFile.tidyUp``) is followed where it changes meaning: formulas are expanded
*before* module renaming, so a formula used inside a base module is inlined there and then renamed
with the module (``module m2 = m1 [x1=x2] endmodule`` turns an inlined ``x1 > 0`` into ``x2 > 0``).
PRISM therefore rejects renaming a formula ("cannot be renamed since formulas are expanded before
module renaming"); Storm accepts it (its ``createRenamedModule`` substitutes the formula's
placeholder), and PAYNT's ``rocks-12`` relies on it (``normdistr1=normdistr2``). posgmc follows
Storm there: the renamed formula's uses in the base module become uses of the new name (whose body
is not renamed); all other formulas are expanded and renamed as in PRISM. A renamed formula in a
module renamed from a renamed module is not supported.

Namespaces (PRISM's ``IdentUsage``): constants, formulas and variables share one; module names,
action names, player names and reward-structure names each have their own; labels share theirs with
observables (checked in ``observations.py``). A name defined twice is reported at the later
definition in source order. Variable declarations of a renamed module carry the span of the
``old=new`` entry that introduced them, so errors about them point into the renamed module.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

from posgmc.errors import PosgmcError, SourceSpan
from posgmc.semantics.constants import find_cycles
from posgmc.semantics.evaluate import free_names, substitute
from posgmc.semantics.symbols import Symbol, SymbolKind, Type, line_of, report
from posgmc.syntax.ast import (
    Assignment,
    Command,
    ConstantDecl,
    Expr,
    Ident,
    LabelDecl,
    ModelFile,
    Module,
    NamedObservable,
    Observable,
    PlayerDecl,
    RenamedModule,
    Renaming,
    RewardItem,
    RewardStructDecl,
    Update,
    VariableDecl,
)
from posgmc.syntax.traversal import map_children

__all__ = [
    "RESERVED_LABELS",
    "ResolvedModel",
    "inline_observable",
    "position",
    "resolve_model",
    "variable_types",
]

RESERVED_LABELS = ("init", "deadlock")


def position(span: SourceSpan) -> tuple[int, int]:
    """Sort key for source order."""
    return (span.line, span.column)


@dataclass(frozen=True)
class ResolvedModel:
    """A model file with its names resolved; every expression has formulas inlined.

    ``symbols``: constants, formulas and variables by name (the first definition of a name).
    ``formulas``: fully expanded formula bodies (formulas on a cycle are absent; uses of them stay
    identifiers, typed as errors already reported). ``modules``: every module, renamed ones
    expanded, in file order. ``broken_modules``: renamed modules whose expansion failed (their
    contents are not checked further, to avoid follow-up errors). ``variables``: globals then each
    module's variables (Storm's order), with the owning module (None: global). ``actions``: action
    labels in order of first appearance.
    """

    model: ModelFile
    symbols: Mapping[str, Symbol]
    formulas: Mapping[str, Expr]
    constants: tuple[ConstantDecl, ...]
    globals: tuple[VariableDecl, ...]
    modules: tuple[Module, ...]
    broken_modules: frozenset[str]
    variables: tuple[tuple[VariableDecl, str | None], ...]
    labels: tuple[LabelDecl, ...]
    rewards: tuple[RewardStructDecl, ...]
    observables: tuple[Observable, ...]
    players: tuple[PlayerDecl, ...]
    init: Expr | None
    actions: tuple[str, ...]

    def lookup(self, name: str) -> Symbol | None:
        return self.symbols.get(name)

    def module(self, name: str) -> Module | None:
        for m in self.modules:
            if m.name == name:
                return m
        return None


# ---------------------------------------------------------------------------------------------
# formulas
# ---------------------------------------------------------------------------------------------


def _expand_formulas(model: ModelFile, errors: list[PosgmcError]) -> dict[str, Expr]:
    bodies: dict[str, Expr] = {}
    spans: dict[str, SourceSpan] = {}
    for f in sorted(model.formulas, key=lambda f: position(f.span)):
        if f.name not in bodies:  # duplicates are reported with the identifier namespace
            bodies[f.name] = f.expr
            spans[f.name] = f.span
    deps = {n: sorted(free_names(b) & bodies.keys()) for n, b in bodies.items()}
    cyclic: set[str] = set()
    for path in find_cycles(list(bodies), deps):
        cyclic.update(path)
        report(
            errors,
            f'cyclic definition of formula "{path[0]}" ({" -> ".join(path)})',
            spans[path[0]],
        )
    expanded: dict[str, Expr] = {}

    def expand(name: str) -> Expr:
        if name not in expanded:
            inner = {d: expand(d) for d in deps[name] if d not in cyclic}
            expanded[name] = substitute(bodies[name], inner)
        return expanded[name]

    return {n: expand(n) for n in bodies if n not in cyclic}


def inline_observable(obs: Observable, formulas: Mapping[str, Expr]) -> Observable:
    """An observable declaration with formulas inlined into its expression."""
    if isinstance(obs, NamedObservable):
        return dataclasses.replace(obs, expr=substitute(obs.expr, formulas))
    return obs


def _inline_var(v: VariableDecl, f: Mapping[str, Expr]) -> VariableDecl:
    return dataclasses.replace(
        v,
        low=None if v.low is None else substitute(v.low, f),
        high=None if v.high is None else substitute(v.high, f),
        init=None if v.init is None else substitute(v.init, f),
    )


def _inline_module(m: Module, f: Mapping[str, Expr]) -> Module:
    commands = tuple(
        dataclasses.replace(
            c,
            guard=substitute(c.guard, f),
            updates=tuple(
                dataclasses.replace(
                    u,
                    probability=None if u.probability is None else substitute(u.probability, f),
                    assignments=tuple(
                        dataclasses.replace(a, value=substitute(a.value, f)) for a in u.assignments
                    ),
                )
                for u in c.updates
            ),
        )
        for c in m.commands
    )
    return dataclasses.replace(
        m, variables=tuple(_inline_var(v, f) for v in m.variables), commands=commands
    )


# ---------------------------------------------------------------------------------------------
# renaming
# ---------------------------------------------------------------------------------------------


def _rename_expr(e: Expr, table: Mapping[str, Renaming]) -> Expr:
    if isinstance(e, Ident):
        r = table.get(e.name)
        # the renamed identifier points at the "old=new" entry that produced it
        return e if r is None else Ident(r.new, span=r.span)
    return map_children(e, lambda c: _rename_expr(c, table))


def _rename_module(
    base: Module, rm: RenamedModule, table: Mapping[str, Renaming], errors: list[PosgmcError]
) -> tuple[Module, bool]:
    """The renamed copy of ``base`` and whether every variable was renamed."""
    ok = True

    def rn(e: Expr | None) -> Expr | None:
        return None if e is None else _rename_expr(e, table)

    variables = []
    for v in base.variables:
        r = table.get(v.name)
        if r is None:
            report(
                errors,
                f'module "{rm.name}" must rename variable "{v.name}" of module "{rm.base}"',
                rm.span,
                hint=f'add "{v.name}=<new name>" to the renaming of module "{rm.name}"',
            )
            ok = False
            continue
        variables.append(
            dataclasses.replace(
                v, name=r.new, low=rn(v.low), high=rn(v.high), init=rn(v.init), span=r.span
            )
        )
    commands = []
    for c in base.commands:
        action = c.action
        if action is not None and action in table:
            action = table[action].new
        updates = tuple(
            Update(
                rn(u.probability),
                tuple(
                    Assignment(
                        table[a.variable].new if a.variable in table else a.variable,
                        _rename_expr(a.value, table),
                        span=a.span,
                    )
                    for a in u.assignments
                ),
                span=u.span,
            )
            for u in c.updates
        )
        commands.append(
            Command(action, _rename_expr(c.guard, table), updates, span=c.span)
        )
    return Module(rm.name, tuple(variables), tuple(commands), span=rm.span), ok


def _expand_modules(
    model: ModelFile, formulas: Mapping[str, Expr], errors: list[PosgmcError]
) -> tuple[list[Module], set[str]]:
    """Every module with formulas inlined and renamings expanded, in file order."""
    broken: set[str] = set()
    by_name: dict[str, Module | RenamedModule] = {}
    for m in model.modules:
        by_name.setdefault(m.name, m)
    done: dict[int, Module] = {}  # by position in model.modules
    first_index: dict[str, int] = {}
    for i, m in enumerate(model.modules):
        first_index.setdefault(m.name, i)
    active: set[int] = set()

    def expand(i: int) -> Module:
        if i in done:
            return done[i]
        m = model.modules[i]
        if isinstance(m, Module):
            done[i] = _inline_module(m, formulas)
            return done[i]
        if m.base not in by_name:
            report(errors, f'no module "{m.base}" to rename in module "{m.name}"', m.span)
            broken.add(m.name)
            done[i] = Module(m.name, (), (), span=m.span)
            return done[i]
        j = first_index[m.base]
        if j in active or j == i:
            report(errors, f'module "{m.name}" is defined by a cyclic renaming', m.span)
            broken.add(m.name)
            done[i] = Module(m.name, (), (), span=m.span)
            return done[i]
        table: dict[str, Renaming] = {}
        renamed_formulas: set[str] = set()
        for r in m.renamings:
            if r.old in table:
                report(errors, f'"{r.old}" is renamed twice in module "{m.name}"', r.span)
                continue
            table[r.old] = r
            if any(f.name == r.old for f in model.formulas):
                renamed_formulas.add(r.old)
        base_decl = model.modules[j]
        if renamed_formulas and not isinstance(base_decl, Module):
            report(
                errors,
                f'module "{m.name}" renames a formula of a module that is itself defined by '
                "renaming; this is not supported",
                table[min(renamed_formulas)].span,
                hint="rename the formula in the first renaming, or rename the variables it uses",
            )
            broken.add(m.name)
            done[i] = Module(m.name, (), (), span=m.span)
            return done[i]
        active.add(i)
        try:
            base = expand(j)
        finally:
            active.discard(i)
        if base_decl.name in broken:
            broken.add(m.name)
        if renamed_formulas:
            # Storm's reading of a renamed formula (PRISM-games rejects it): the formula's uses in
            # the base module become uses of the new name; every other formula is expanded first
            # and renamed with the module, as in PRISM
            assert isinstance(base_decl, Module)
            keep = {n: b for n, b in formulas.items() if n not in renamed_formulas}
            base = _inline_module(base_decl, keep)
        renamed, ok = _rename_module(base, m, table, errors)
        # formulas named by the renaming itself (a renamed formula, or "c=f" with f a formula)
        renamed = _inline_module(renamed, formulas)
        if not ok:
            broken.add(m.name)
        done[i] = renamed
        return renamed

    return [expand(i) for i in range(len(model.modules))], broken


# ---------------------------------------------------------------------------------------------
# the name table
# ---------------------------------------------------------------------------------------------


def _var_type(v: VariableDecl) -> Type:
    return Type.of(v.type)


def resolve_model(model: ModelFile, errors: list[PosgmcError]) -> ResolvedModel:
    """Resolve the names of a model file.

    Args:
        model: the parsed file.
        errors: where duplicate definitions, cyclic formulas and renaming errors are appended.

    Returns:
        The resolved model (see :class:`ResolvedModel`); expressions are not type-checked yet.
    """
    formulas = _expand_formulas(model, errors)
    modules, broken = _expand_modules(model, formulas, errors)
    globals_ = tuple(_inline_var(v, formulas) for v in model.globals)

    # one namespace for constants, formulas and variables; the earlier definition in source order
    # keeps the name
    entries: list[tuple[SourceSpan, Symbol]] = []
    for c in model.constants:
        entries.append((c.span, Symbol(c.name, SymbolKind.CONSTANT, Type.of(c.type), c.span)))
    for f in model.formulas:
        entries.append((f.span, Symbol(f.name, SymbolKind.FORMULA, None, f.span)))
    for v in globals_:
        entries.append((v.span, Symbol(v.name, SymbolKind.VARIABLE, _var_type(v), v.span, None)))
    for m in modules:
        for v in m.variables:
            sym = Symbol(v.name, SymbolKind.VARIABLE, _var_type(v), v.span, m.name)
            entries.append((v.span, sym))
    symbols: dict[str, Symbol] = {}
    for span, sym in sorted(entries, key=lambda e: position(e[0])):
        first = symbols.get(sym.name)
        if first is None:
            symbols[sym.name] = sym
            continue
        report(
            errors,
            f'{sym.kind.value} "{sym.name}" is already defined as a {first.kind.value}'
            f"{line_of(first.span)}",
            span,
        )

    # modules
    seen_modules: dict[str, Module] = {}
    for m in sorted(modules, key=lambda m: position(m.span)):
        if m.name in seen_modules:
            report(
                errors,
                f'module "{m.name}" is already defined{line_of(seen_modules[m.name].span)}',
                m.span,
            )
        else:
            seen_modules[m.name] = m
    if not model.modules:
        span = model.span if model.span.line else SourceSpan(1, 1)
        report(errors, "the model has no modules", span)

    # labels: reserved names, duplicates (clashes with observables are checked with them)
    labels = tuple(dataclasses.replace(d, expr=substitute(d.expr, formulas)) for d in model.labels)
    seen_labels: dict[str, LabelDecl] = {}
    for d in sorted(labels, key=lambda d: position(d.span)):
        if d.name in RESERVED_LABELS:
            report(errors, f'"{d.name}" is a built-in label and cannot be defined', d.span)
        elif d.name in seen_labels:
            report(
                errors,
                f'label "{d.name}" is already defined{line_of(seen_labels[d.name].span)}',
                d.span,
            )
        else:
            seen_labels[d.name] = d

    # reward structures
    rewards = tuple(
        dataclasses.replace(
            r,
            items=tuple(
                RewardItem(
                    it.is_action,
                    it.action,
                    substitute(it.guard, formulas),
                    substitute(it.value, formulas),
                    span=it.span,
                )
                for it in r.items
            ),
        )
        for r in model.rewards
    )
    seen_rewards: dict[str, RewardStructDecl] = {}
    for r in sorted(rewards, key=lambda r: position(r.span)):
        if r.name is None or r.name == "":
            continue
        if r.name in seen_rewards:
            report(
                errors,
                f'reward structure "{r.name}" is already defined'
                + line_of(seen_rewards[r.name].span),
                r.span,
            )
        else:
            seen_rewards[r.name] = r

    actions: dict[str, None] = {}
    for m in modules:
        for command in m.commands:
            if command.action is not None:
                actions.setdefault(command.action, None)

    variables: list[tuple[VariableDecl, str | None]] = [(v, None) for v in globals_]
    for m in modules:
        variables.extend((v, m.name) for v in m.variables)

    players = tuple(
        dataclasses.replace(
            p, observables=tuple(inline_observable(o, formulas) for o in p.observables)
        )
        for p in model.players
    )
    return ResolvedModel(
        model=model,
        symbols=symbols,
        formulas=formulas,
        constants=tuple(
            c if c.value is None else dataclasses.replace(c, value=substitute(c.value, formulas))
            for c in model.constants
        ),
        globals=globals_,
        modules=tuple(modules),
        broken_modules=frozenset(broken),
        variables=tuple(variables),
        labels=labels,
        rewards=rewards,
        observables=tuple(inline_observable(o, formulas) for o in model.observables),
        players=players,
        init=None if model.init is None else substitute(model.init, formulas),
        actions=tuple(actions),
    )


def variable_types(resolved: ResolvedModel) -> dict[str, Type]:
    """Variable name -> type (first declaration of each name)."""
    return {
        s.name: s.type
        for s in resolved.symbols.values()
        if s.kind is SymbolKind.VARIABLE and s.type is not None
    }
