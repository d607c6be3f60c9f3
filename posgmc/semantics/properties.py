"""Properties checked against a model, and their resolved form for the engines.

Checks: every identifier is a variable, a constant or a formula of the model or of the properties
file; every quoted name is a label of the model, a label of the properties file, an observable of
the model (PRISM lets properties use observables as labels, ``FindAllObsRefs``), or ``"init"`` /
``"deadlock"``; expressions are well typed (``types.py``; a path formula must sit inside
``P``/``R``); reward structures exist (by name or 1-based index; none given = the first);
coalitions name existing players. Properties-file constants and formulas share the identifier
namespace with the model's; its labels share the quoted namespace with the model's labels and
observables.

Coalitions and reward structures are resolved by :class:`~posgmc.semantics.queries.QueryResolver`
(PRISM-games' 1-based player numbers unless ``zero_based_players=True``, Storm and PAYNT's 0-based
ones with it). A query without a coalition on a game is left as is (``coalition`` None):
PRISM-games then lets all players cooperate (``coins.prism.props``: ``Pmax=? [F "correct"]`` has
the RESULT 0.75 of ``<<1,2,3>>``); the engines decide.

The resolved form (:class:`CheckedProperty`):

* ``expr``: the property with formulas inlined, properties-file labels inlined, constants
  replaced by literals and constant sub-expressions folded; identifiers left are state variables.
  Quoted names left (:class:`~posgmc.syntax.ast.LabelRef`) are ``"init"``, ``"deadlock"``, labels of
  :attr:`FlatModel.labels` (model labels and Boolean observables); a non-Boolean observable is
  replaced by its expression.
* ``queries``: one :class:`ResolvedQuery` per ``P``/``R`` node of ``expr``, in tree order (parents
  first), with the coalition as a frozenset of **0-based** player indices into
  :attr:`FlatModel.players` (``<<*>>`` = all) and the reward structure as a 0-based index into
  :attr:`FlatModel.rewards`. :meth:`CheckedProperty.query` finds the record of a node.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from posgmc.errors import PosgmcError, SourceSpan
from posgmc.semantics.analysis import (
    ModelAnalysis,
    analyse_model,
    check_constant_definition,
    raise_errors,
    sort_errors,
    undefined_constants_error,
    unknown_constant_errors,
)
from posgmc.semantics.constants import ConstantValues, find_cycles, resolve_constants
from posgmc.semantics.evaluate import (
    Value,
    evaluate,
    format_value,
    free_names,
    simplify,
    substitute,
)
from posgmc.semantics.flat import FlatModel
from posgmc.semantics.multi import check_multi
from posgmc.semantics.observations import ObservableInfo
from posgmc.semantics.queries import QueryResolver, ResolvedQuery
from posgmc.semantics.resolve import RESERVED_LABELS, position, variable_types
from posgmc.semantics.symbols import Symbol, SymbolKind, Type, line_of, report
from posgmc.semantics.types import TypeChecker
from posgmc.syntax.ast import (
    ConstantDecl,
    Expr,
    FormulaDecl,
    LabelDecl,
    LabelRef,
    ModelFile,
    ModelType,
    MultiQuery,
    ProbQuery,
    PropertiesFile,
    Property,
    RewardQuery,
    Temporal,
)
from posgmc.syntax.traversal import iter_nodes, map_children

__all__ = [
    "CheckedProperty",
    "QueryResolver",
    "ResolvedQuery",
    "check_properties",
    "instantiate_properties",
    "resolve_queries",
]

BUILTIN_LABELS = RESERVED_LABELS


@dataclass(frozen=True)
class CheckedProperty:
    """A property ready for the engines (see the module docstring). ``type`` is the property's
    value type (BOOL, INT or DOUBLE); ``constants`` the properties-file constants' values."""

    prop: Property
    expr: Expr
    type: Type
    queries: tuple[ResolvedQuery, ...]
    constants: tuple[tuple[str, Value], ...] = ()

    @property
    def name(self) -> str | None:
        return self.prop.name

    def query(self, node: Expr) -> ResolvedQuery:
        """The resolution of a ``P``/``R`` node of :attr:`expr`.

        Raises:
            KeyError: ``node`` is not a query of this property.
        """
        for q in self.queries:
            if q.node is node:
                return q
        for q in self.queries:
            if q.node == node:
                return q
        raise KeyError(node)

    # last in the class body: the name shadows the builtin decorator from here on
    @property
    def property(self) -> Property:
        """The property as parsed (same as :attr:`prop`)."""
        return self.prop


def replace_labels(e: Expr, mapping: Mapping[str, Expr]) -> Expr:
    """Replace quoted names by expressions (the replacement takes the reference's span)."""
    if isinstance(e, LabelRef):
        r = mapping.get(e.name)
        return e if r is None else dataclasses.replace(r, span=e.span)
    return map_children(e, lambda c: replace_labels(c, mapping))


def _label_names(e: Expr) -> set[str]:
    return {n.name for n in iter_nodes(e) if isinstance(n, LabelRef)}


def _as_file(props: PropertiesFile | Sequence[Property]) -> PropertiesFile:
    if isinstance(props, PropertiesFile):
        return props
    return PropertiesFile(properties=tuple(props))


# ---------------------------------------------------------------------------------------------
# the analysis
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _PropsAnalysis:
    model: ModelAnalysis
    constants: ConstantValues
    props: list[tuple[Property, Expr, Type | None]]
    errors: list[PosgmcError]


def _used_names(exprs: Sequence[Expr], decls: Sequence[ConstantDecl]) -> set[str]:
    """The identifiers the expressions use, directly or through the definitions of constants."""
    definitions = {c.name: c.value for c in decls if c.value is not None}
    used: set[str] = set()
    todo = [n for e in exprs for n in free_names(e)]
    while todo:
        name = todo.pop()
        if name in used:
            continue
        used.add(name)
        value = definitions.get(name)
        if value is not None:
            todo.extend(free_names(value))
    return used


def _analyse(
    props: PropertiesFile | Sequence[Property],
    model: ModelFile,
    constants: Mapping[str, object] | None,
    zero_based_players: bool,
) -> _PropsAnalysis:
    """Every check of a properties file against a model, in the order of its sections: the
    file's constants and formulas beside the model's names, its formulas, its labels, the types
    of all of them, the constants' values, then the properties. Errors are collected."""
    pf = _as_file(props)
    ma = analyse_model(model, constants=constants, allow_extra_constants=True)
    errors: list[PosgmcError] = []
    symbols, accepted = _declare(pf, ma, errors)
    bodies, formulas = _expand_formulas(accepted, ma, errors)
    labels = _expand_labels(pf, ma, formulas, errors)
    tc = TypeChecker(
        lookup=symbols.get,
        errors=errors,
        labels=labels.type_of,
        allow_queries=True,
        unknown_label_hint=lambda name: labels.hint(name, symbols),
    )
    for n, body in formulas.items():
        if n in bodies:
            tc.check(body)
    for name, e in labels.expanded.items():
        tc.expect(e, Type.BOOL, f'label "{name}"')
    values = _file_constants(accepted, ma, formulas, tc, constants, errors)
    resolver = QueryResolver(
        model.model_type,
        tuple(p.name for p in ma.players),
        tuple(r.name for r in ma.resolved.rewards),
        zero_based_players,
    )
    seen_names: dict[str, Property] = {}
    checked: list[tuple[Property, Expr, Type | None]] = []
    for prop in pf.properties:
        _check_property_name(prop, seen_names, errors)
        checked.append(
            _check_property(
                prop, model.model_type, formulas, labels.expanded, tc, resolver, values, errors
            )
        )
    return _PropsAnalysis(ma, values, checked, errors)


def _declare(
    pf: PropertiesFile, ma: ModelAnalysis, errors: list[PosgmcError]
) -> tuple[dict[str, Symbol], list[ConstantDecl | FormulaDecl]]:
    """The identifiers: the file's constants and formulas beside the model's names. Returns the
    whole namespace and the file's accepted declarations (the first definition of each name)."""
    symbols: dict[str, Symbol] = dict(ma.resolved.symbols)
    entries: list[tuple[ConstantDecl | FormulaDecl, Symbol]] = []
    for c in pf.constants:
        entries.append((c, Symbol(c.name, SymbolKind.CONSTANT, Type.of(c.type), c.span)))
    for f in pf.formulas:
        entries.append((f, Symbol(f.name, SymbolKind.FORMULA, None, f.span)))
    accepted: list[ConstantDecl | FormulaDecl] = []
    for decl, sym in sorted(entries, key=lambda x: position(x[0].span)):
        first = symbols.get(sym.name)
        if first is not None:
            where = "" if any(d.name == sym.name for d in accepted) else " in the model"
            report(
                errors,
                f'{sym.kind.value} "{sym.name}" is already defined as a {first.kind.value}'
                f"{where}{line_of(first.span)}",
                decl.span,
            )
            continue
        symbols[sym.name] = sym
        accepted.append(decl)
    return symbols, accepted


def _expand_formulas(
    accepted: Sequence[ConstantDecl | FormulaDecl], ma: ModelAnalysis, errors: list[PosgmcError]
) -> tuple[dict[str, Expr], dict[str, Expr]]:
    """The formulas, the model's (expanded) and the file's, each expanded (cycles reported and
    left unexpanded). Returns the file's formula bodies as written and every expanded formula."""
    resolved = ma.resolved
    bodies = {d.name: d.expr for d in accepted if isinstance(d, FormulaDecl)}
    spans = {d.name: d.span for d in accepted}
    deps = {n: sorted(free_names(b) & bodies.keys()) for n, b in bodies.items()}
    cyclic: set[str] = set()
    for path in find_cycles(sorted(bodies, key=lambda n: position(spans[n])), deps):
        cyclic.update(path)
        msg = f'cyclic definition of formula "{path[0]}" ({" -> ".join(path)})'
        report(errors, msg, spans[path[0]])
    formulas: dict[str, Expr] = dict(resolved.formulas)

    def expand(name: str) -> Expr:
        if name not in formulas:
            inner = {d: expand(d) for d in deps[name] if d not in cyclic}
            formulas[name] = substitute(substitute(bodies[name], resolved.formulas), inner)
        return formulas[name]

    for n in bodies:
        if n not in cyclic:
            expand(n)
    return bodies, formulas


@dataclass(frozen=True)
class _Labels:
    """The quoted names a property may use: the model's labels (by name, with their spans) and
    observables, the file's label declarations (the first of each name), those on a cycle, and
    the file's labels expanded."""

    model_labels: Mapping[str, SourceSpan]
    observables: Mapping[str, ObservableInfo]
    declared: Mapping[str, LabelDecl]
    cyclic: frozenset[str]
    expanded: Mapping[str, Expr]

    def type_of(self, name: str) -> Type | None:
        """The type of a quoted name (None: unknown)."""
        if name in BUILTIN_LABELS or name in self.model_labels or name in self.cyclic:
            return Type.BOOL
        if name in self.expanded:
            return Type.BOOL
        o = self.observables.get(name)
        if o is not None:
            return o.type if o.type is not None else Type.BOOL
        return None

    def hint(self, name: str, symbols: Mapping[str, Symbol]) -> str | None:
        """What to say about an unknown quoted name."""
        known = list(self.model_labels) + [
            n for n in self.observables if n not in self.model_labels
        ]
        known += [n for n in self.declared if n not in known]
        if name in symbols:
            return f'"{name}" is a {symbols[name].kind.value}; write it without quotes'
        listed = ", ".join(f'"{n}"' for n in known)
        return f"the labels are {listed} (and \"init\", \"deadlock\")" if known else (
            'the model defines no labels (only "init" and "deadlock" are built in)'
        )


def _expand_labels(
    pf: PropertiesFile, ma: ModelAnalysis, formulas: Mapping[str, Expr], errors: list[PosgmcError]
) -> _Labels:
    """The quoted names: the model's labels and observables, then the file's labels, which must
    not redefine any of them; the file's labels expanded (cycles reported)."""
    model_labels = {d.name: d.span for d in ma.resolved.labels}
    observables = ma.observations.by_name
    label_decls: dict[str, LabelDecl] = {}
    for d in sorted(pf.labels, key=lambda d: position(d.span)):
        if d.name in BUILTIN_LABELS:
            report(errors, f'"{d.name}" is a built-in label and cannot be defined', d.span)
        elif d.name in model_labels:
            where = line_of(model_labels[d.name])
            report(errors, f'label "{d.name}" is already defined in the model{where}', d.span)
        elif d.name in observables:
            report(
                errors,
                f'label "{d.name}" has the name of an observable of the model'
                f"{line_of(observables[d.name].span)}",
                d.span,
            )
        elif d.name in label_decls:
            where = line_of(label_decls[d.name].span)
            report(errors, f'label "{d.name}" is already defined{where}', d.span)
        else:
            label_decls[d.name] = d
    label_deps = {
        n: sorted(_label_names(d.expr) & label_decls.keys()) for n, d in label_decls.items()
    }
    cyclic_labels: set[str] = set()
    for path in find_cycles(list(label_decls), label_deps):
        cyclic_labels.update(path)
        msg = f'cyclic definition of label "{path[0]}" ({" -> ".join(path)})'
        report(errors, msg, label_decls[path[0]].span)
    labels: dict[str, Expr] = {}

    def expand_label(name: str) -> Expr:
        if name not in labels:
            inner = {d: expand_label(d) for d in label_deps[name] if d not in cyclic_labels}
            labels[name] = replace_labels(substitute(label_decls[name].expr, formulas), inner)
        return labels[name]

    for n in label_decls:
        if n not in cyclic_labels:
            expand_label(n)
    return _Labels(model_labels, observables, label_decls, frozenset(cyclic_labels), labels)


def _file_constants(
    accepted: Sequence[ConstantDecl | FormulaDecl],
    ma: ModelAnalysis,
    formulas: Mapping[str, Expr],
    tc: TypeChecker,
    constants: Mapping[str, object] | None,
    errors: list[PosgmcError],
) -> ConstantValues:
    """The values of the file's constants (after the model's), their definitions type-checked;
    values given for names that neither file declares are reported."""
    decls = tuple(
        c if c.value is None else dataclasses.replace(c, value=substitute(c.value, formulas))
        for c in accepted
        if isinstance(c, ConstantDecl)
    )
    for c in decls:
        if c.value is not None:
            check_constant_definition(c, tc)
    settings = dict(constants or {})
    values = resolve_constants(decls, settings=settings, errors=errors, base=ma.constants)
    all_decls = list(ma.resolved.constants) + list(decls)
    errors.extend(
        unknown_constant_errors(
            settings,
            [c.name for c in all_decls],
            [c.name for c in all_decls if c.value is None],
            where="the model or the properties",
        )
    )
    return values


def _check_property_name(
    prop: Property, seen: dict[str, Property], errors: list[PosgmcError]
) -> None:
    """A property name is defined once (``seen``: the names so far)."""
    if prop.name is None:
        return
    if prop.name in seen:
        report(
            errors,
            f'property "{prop.name}" is already defined' + line_of(seen[prop.name].span),
            prop.span,
        )
    else:
        seen[prop.name] = prop


def _check_property(
    prop: Property,
    model_type: ModelType,
    formulas: Mapping[str, Expr],
    labels: Mapping[str, Expr],
    tc: TypeChecker,
    resolver: QueryResolver,
    values: ConstantValues,
    errors: list[PosgmcError],
) -> tuple[Property, Expr, Type | None]:
    """One property: formulas and the file's labels expanded, its type, its multi-objective
    form, the coalitions and reward structures of its queries, the constant values of its
    thresholds, step bounds and discount factors."""
    e = replace_labels(substitute(prop.expr, formulas), labels)
    # a path formula outside P/R is reported by the type checker ("temporal operator ...")
    t = tc.check(e)
    check_multi(e, model_type=model_type, errors=errors)
    if isinstance(e, MultiQuery) and e.coalition is not None and model_type.is_game:
        resolver.coalition(e.coalition, errors)
    for node in iter_nodes(e):
        if isinstance(node, (ProbQuery, RewardQuery)):
            resolver.resolve(node, errors)
            _check_query_values(node, values, errors)
        elif isinstance(node, Temporal) and node.bound is not None:
            for b in (node.bound.lower, node.bound.upper):
                if b is not None:
                    what = f'the step bound of "{node.op.value}"'
                    _check_nonnegative(b, values, what, errors)
    return prop, e, t


def _value_of(e: Expr, values: ConstantValues) -> Value | None:
    if any(n not in values.values for n in free_names(e)):
        return None
    try:
        return evaluate(e, values.values)
    except PosgmcError:
        return None


def _check_nonnegative(
    e: Expr, values: ConstantValues, what: str, errors: list[PosgmcError]
) -> None:
    v = _value_of(e, values)
    if v is not None and not isinstance(v, bool) and v < 0:
        report(errors, f"{what} must not be negative, found {format_value(v)}", e.span)


def _check_query_values(
    q: ProbQuery | RewardQuery, values: ConstantValues, errors: list[PosgmcError]
) -> None:
    if q.threshold is not None:
        v = _value_of(q.threshold.value, values)
        if isinstance(q, ProbQuery) and v is not None and not isinstance(v, bool):
            if not 0 <= v <= 1:
                msg = f"the probability bound {format_value(v)} is not in [0, 1]"
                report(errors, msg, q.threshold.value.span)
    if isinstance(q, RewardQuery):
        obj = q.objective
        if obj.bound is not None:
            _check_nonnegative(obj.bound, values, f'the step bound of "{obj.kind.value}"', errors)
        if obj.discount is not None:
            v = _value_of(obj.discount, values)
            if v is not None and not isinstance(v, bool) and not 0 <= v < 1:
                msg = f"the discount factor {format_value(v)} is not in [0, 1)"
                report(errors, msg, obj.discount.span)


# ---------------------------------------------------------------------------------------------
# entry points
# ---------------------------------------------------------------------------------------------


def check_properties(
    props: PropertiesFile | Sequence[Property],
    model: ModelFile,
    *,
    constants: Mapping[str, object] | None = None,
    zero_based_players: bool = False,
) -> list[PosgmcError]:
    """Lint properties against a model: every error in the properties, in source order.

    Errors of the model itself are not repeated here (``check_model`` reports them).

    Args:
        props: a parsed properties file, or properties.
        model: the parsed model file.
        constants: values of undefined constants of the model and of the properties file.
        zero_based_players: read coalition numbers as Storm/PAYNT do (``<<0>>`` = first player);
            by default they are PRISM-games' 1-based numbers.

    Returns:
        The errors (empty: the properties are valid for this model).
    """
    return sort_errors(_analyse(props, model, constants, zero_based_players).errors)


def instantiate_properties(
    props: PropertiesFile | Sequence[Property],
    flat_model: FlatModel,
    *,
    model: ModelFile,
    constants: Mapping[str, object] | None = None,
    zero_based_players: bool = False,
) -> tuple[CheckedProperty, ...]:
    """Check properties and resolve them for the engines (see the module docstring).

    Args:
        props: a parsed properties file, or properties.
        flat_model: the instantiated model (from :func:`posgmc.semantics.stages.instantiate`,
            with the same ``constants``).
        model: the model file ``flat_model`` was made from (for its formulas and constants).
        constants: values of undefined constants of the model and of the properties file.
        zero_based_players: see :func:`check_properties`.

    Returns:
        One :class:`CheckedProperty` per property, in file order.

    Raises:
        PosgmcError: the first error, or MultipleErrors for several.
        ConstantError: constants of the model or the properties file still undefined.
    """
    a = _analyse(props, model, constants, zero_based_players)
    raise_errors(a.errors)
    pf = _as_file(props)
    # PRISM asks only for the properties-file constants the checked properties use
    # (UndefinedConstants: getUndefinedConstantsUsedInProperties); the model's are always needed
    used = _used_names([e for _, e, _ in a.props], pf.constants)
    undefined = list(a.model.constants.undefined) + [
        c for c in a.constants.undefined if c.name in used
    ]
    if undefined:
        raise undefined_constants_error(undefined)

    values = a.constants.values
    var_types = variable_types(a.model.resolved)
    label_names = {name for name, _ in flat_model.labels}
    # non-Boolean observables are not labels of the FlatModel: use their expressions
    obs_exprs = {
        name: simplify(substitute(o.expr, values), variable_types=var_types)
        for name, o in a.model.observations.by_name.items()
        if name not in label_names and o.type is not Type.BOOL
    }
    resolver = QueryResolver(
        flat_model.model_type,
        tuple(p.name for p in flat_model.players),
        tuple(r.name for r in flat_model.rewards),
        zero_based_players,
    )
    prop_constants = tuple((c.name, values[c.name]) for c in pf.constants if c.name in values)
    out: list[CheckedProperty] = []
    for prop, e, t in a.props:
        assert t is not None  # no errors were found
        e = replace_labels(e, obs_exprs)
        e = simplify(substitute(e, values), variable_types=var_types)
        out.append(CheckedProperty(prop, e, t, resolve_queries(e, resolver), prop_constants))
    return tuple(out)


def resolve_queries(expr: Expr, resolver: QueryResolver) -> tuple[ResolvedQuery, ...]:
    """One :class:`ResolvedQuery` per ``P``/``R`` node of ``expr``, in tree order (parents
    first).

    Raises:
        PosgmcError: the first error, or MultipleErrors for several.
    """
    errors: list[PosgmcError] = []
    out = tuple(
        resolver.resolve(node, errors)
        for node in iter_nodes(expr)
        if isinstance(node, (ProbQuery, RewardQuery))
    )
    raise_errors(errors)
    return out
