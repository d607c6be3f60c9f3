"""The model passes run together: one record (:class:`ModelAnalysis`) holding what each pass found,
and the construction of the :class:`FlatModel` from an error-free analysis.

The passes, in order: names (``resolve.py``: formulas, renaming, duplicates) -> types of every
expression (``types.py``) -> constant values (``constants.py``) -> checks that need values (ranges,
initial values) -> players (``players.py``) -> observables (``observations.py``). Errors are
collected, never raised, so that ``lint`` can list all of them; the entry points in
``checker.py`` sort them or raise.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import TypeGuard

from posgmc.errors import (
    ConstantError,
    MultipleErrors,
    PosgmcError,
    SemanticError,
    SourceSpan,
    UnsupportedError,
)
from posgmc.semantics.constants import ConstantValues, ConstRange, ConstSetting, resolve_constants
from posgmc.semantics.dialect import INT_DIVISION, Dialect
from posgmc.semantics.evaluate import Value, evaluate, free_names, simplify, substitute
from posgmc.semantics.flat import (
    FlatAssignment,
    FlatCommand,
    FlatModel,
    FlatModule,
    FlatObservable,
    FlatPlayer,
    FlatRewardItem,
    FlatRewardStruct,
    FlatUpdate,
    Variable,
)
from posgmc.semantics.observations import ObservableInfo, Observations, check_observables
from posgmc.semantics.players import PlayerInfo, check_players
from posgmc.semantics.resolve import ResolvedModel, position, resolve_model, variable_types
from posgmc.semantics.symbols import SymbolKind, Type, report, span_or_none
from posgmc.semantics.types import TypeChecker
from posgmc.syntax.ast import (
    ConstantDecl,
    DoubleLit,
    Expr,
    ModelFile,
    Module,
    VariableDecl,
    VarType,
)

__all__ = [
    "ModelAnalysis",
    "analyse_model",
    "build_flat_model",
    "raise_errors",
    "sort_errors",
    "undefined_constants_error",
    "unknown_constant_errors",
]


# ---------------------------------------------------------------------------------------------
# shared helpers
# ---------------------------------------------------------------------------------------------


def sort_errors(errors: Sequence[PosgmcError]) -> list[PosgmcError]:
    """Errors in source order (errors without a position last), duplicates removed (a renamed
    module repeats its base module's expressions, and so their errors)."""
    seen: set[tuple[type, str, SourceSpan | None]] = set()
    unique: list[PosgmcError] = []
    for e in errors:
        key = (type(e), e.message, e.span)
        if key not in seen:
            seen.add(key)
            unique.append(e)

    def k(e: PosgmcError) -> tuple[int, str, int, int]:
        if e.span is None:
            return (1, "", 0, 0)
        return (0, e.span.file or "", e.span.line, e.span.column)

    return sorted(unique, key=k)


def raise_errors(errors: Sequence[PosgmcError]) -> None:
    """Raise the single error, or :class:`MultipleErrors` for several; nothing for none."""
    errors = sort_errors(errors)
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise MultipleErrors(list(errors))


def _setting_span(v: object) -> SourceSpan | None:
    return v.span if isinstance(v, (ConstSetting, ConstRange)) else None


def unknown_constant_errors(
    settings: Mapping[str, object],
    declared: Sequence[str],
    undefined: Sequence[str],
    *,
    where: str = "the model",
) -> list[PosgmcError]:
    """Errors for user values given to names that are not constants of the files."""
    out: list[PosgmcError] = []
    known = set(declared)
    for name, v in settings.items():
        if name in known:
            continue
        if undefined:
            hint = "the undefined constants are: " + ", ".join(undefined)
        else:
            hint = "the files declare no undefined constants"
        out.append(
            ConstantError(f'"{name}" is not a constant of {where}', _setting_span(v), hint=hint)
        )
    return out


# ---------------------------------------------------------------------------------------------
# the model analysis
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelAnalysis:
    """Everything the model passes found out (internal record shared with ``properties.py``)."""

    resolved: ResolvedModel
    constants: ConstantValues
    players: tuple[PlayerInfo, ...]
    observations: Observations
    errors: list[PosgmcError] = field(default_factory=list)
    warnings: list[PosgmcError] = field(default_factory=list)  # DialectWarning, source order

    def value(self, e: Expr) -> Value | None:
        """The value of a constant expression, or None if it depends on an unknown constant or
        cannot be evaluated (the error, if any, is reported elsewhere)."""
        if any(n not in self.constants.values for n in free_names(e)):
            return None
        try:
            return evaluate(e, self.constants.values)
        except PosgmcError:
            return None


def _undefined_hint(resolved: ResolvedModel) -> Callable[[str], str | None]:
    labels = {d.name for d in resolved.labels}
    modules = {m.name for m in resolved.modules}
    players = {p.name for p in resolved.players}
    actions = set(resolved.actions)

    def hint(name: str) -> str | None:
        if name in labels:
            return f'"{name}" is a label; labels are written in quotes and only used in properties'
        if name in modules:
            return f'"{name}" is a module name, not a value'
        if name in players:
            return f'"{name}" is a player name, not a value'
        if name in actions:
            return f'"{name}" is an action name, not a value'
        return None

    return hint


def check_constant_definition(c: ConstantDecl, tc: TypeChecker) -> None:
    """Type-check a constant's definition: it must not use variables and must fit the declared
    type, except that an int constant may be given a double expression whose value turns out to
    be whole (see ``constants.py``)."""
    assert c.value is not None
    expected = Type.DOUBLE if c.type is VarType.INT else Type.of(c.type)
    tc.expect(
        c.value,
        expected,
        f'the value of constant "{c.name}"',
        constant=f'the definition of constant "{c.name}"',
    )


@dataclass(frozen=True)
class _Typing:
    """The model's type checker, one that types int/int as int (Storm's typing), and the
    dialect that decides what a difference between the two means."""

    tc: TypeChecker
    storm: TypeChecker
    dialect: Dialect

    def int_value(
        self, expr: Expr, found: Type | None, message: str, errors: list[PosgmcError]
    ) -> bool:
        """Does ``expr``, typed ``found`` by PRISM's rules, go where an int is needed? A double
        that Storm types as int (int/int) does, with a warning (an error when strict); the
        caller reports any other mismatch."""
        if found is not Type.DOUBLE or self.storm.check(expr) is not Type.INT:
            return found is None or Type.INT.accepts(found)
        self.dialect.storm_only(errors, message, span_or_none(expr.span), INT_DIVISION)
        return True


def _check_variable(
    v: VariableDecl, typing: _Typing, errors: list[PosgmcError], *, has_init_block: bool
) -> None:
    tc = typing.tc
    if v.type is VarType.DOUBLE:
        errors.append(
            UnsupportedError(
                f'variable "{v.name}" is a double; only int and bool variables are supported',
                span_or_none(v.span),
            )
        )
        return
    if v.type is VarType.INT:
        if v.low is None or v.high is None:
            errors.append(
                UnsupportedError(
                    f'variable "{v.name}" has no range; unbounded ints are not supported',
                    span_or_none(v.span),
                    hint=f"declare it as {v.name} : [low..high]",
                )
            )
        else:
            what = f'the lower bound of variable "{v.name}"'
            tc.expect(v.low, Type.INT, what, constant=what)
            what = f'the upper bound of variable "{v.name}"'
            tc.expect(v.high, Type.INT, what, constant=what)
    if v.init is not None:
        what = f'the initial value of variable "{v.name}"'
        if v.type is VarType.INT:
            t = tc.check(v.init, constant=what)
            message = f'the initial value of int variable "{v.name}" divides ints'
            if not typing.int_value(v.init, t, message, errors):
                report(errors, f"{what} must be an int, found {t.value if t else '?'}",
                       v.init.span)
        else:
            tc.expect(v.init, Type.of(v.type), what, constant=what)
        if has_init_block:
            report(
                errors,
                f'variable "{v.name}" has an initial value, but the model has an '
                "init...endinit block",
                v.init.span,
                hint="use either init...endinit or initial values of variables, not both",
            )


def _check_module(
    m: Module, resolved: ResolvedModel, typing: _Typing, errors: list[PosgmcError]
) -> None:
    tc = typing.tc
    own = {v.name: Type.of(v.type) for v in m.variables}
    for c in m.commands:
        tc.expect(c.guard, Type.BOOL, "a guard")
        for u in c.updates:
            if u.probability is not None:
                tc.expect(u.probability, Type.DOUBLE, "the probability of an update")
            assigned: set[str] = set()
            for a in u.assignments:
                vt = tc.check(a.value)
                if a.variable in assigned:
                    msg = f'variable "{a.variable}" is set twice in the same update'
                    report(errors, msg, a.span)
                assigned.add(a.variable)
                if a.variable in own:
                    # the module's own variable, even if its name clashes with another
                    # definition (reported as a duplicate)
                    target = own[a.variable]
                    _check_assignment(typing, errors, vt, target, a.variable, a.value)
                    continue
                sym = resolved.lookup(a.variable)
                if sym is None:
                    report(errors, f'unknown variable "{a.variable}" in update', a.span)
                    continue
                if sym.kind is not SymbolKind.VARIABLE:
                    report(
                        errors,
                        f'cannot assign to {sym.kind.value} "{a.variable}"; '
                        "only variables can be updated",
                        a.span,
                    )
                    continue
                if sym.module is not None and sym.module != m.name:
                    report(
                        errors,
                        f'module "{m.name}" cannot modify variable "{a.variable}" of module '
                        f'"{sym.module}"',
                        a.span,
                        hint="a module may only update its own variables and global ones",
                    )
                if sym.type is not None:
                    _check_assignment(typing, errors, vt, sym.type, a.variable, a.value)


def _check_assignment(
    typing: _Typing,
    errors: list[PosgmcError],
    value: Type | None,
    target: Type,
    name: str,
    expr: Expr,
) -> None:
    if value is None or target.accepts(value):
        return
    if target is Type.INT:
        message = f'the value assigned to int variable "{name}" divides ints'
        if typing.int_value(expr, value, message, errors):
            return
    _assign_error(errors, value, target, name, expr.span)


def _assign_error(
    errors: list[PosgmcError], value: Type, target: Type, name: str, span: SourceSpan
) -> None:
    article = "an" if value is Type.INT else "a"
    msg = f'cannot assign {article} {value.value} value to {target.value} variable "{name}"'
    report(errors, msg, span)


def _value_checks(analysis: ModelAnalysis, errors: list[PosgmcError]) -> None:
    """Checks that need constant values: ranges, initial values, finite constants."""
    for v, _module in analysis.resolved.variables:
        if v.type is not VarType.INT or v.low is None or v.high is None:
            continue
        for bound in (v.low, v.high, v.init):
            # a bound that fails to evaluate (pow(10, 400)) is an error build would meet too
            if bound is not None and not any(
                n not in analysis.constants.values for n in free_names(bound)
            ):
                try:
                    evaluate(bound, analysis.constants.values)
                except PosgmcError as err:
                    errors.append(err)
        low, high = analysis.value(v.low), analysis.value(v.high)
        if not (_is_int(low) and _is_int(high)):
            continue
        assert isinstance(low, int) and isinstance(high, int)
        if low > high:
            report(errors, f'the range [{low}..{high}] of variable "{v.name}" is empty', v.span)
            continue
        if v.init is not None:
            init = _whole(analysis.value(v.init))
            typed = not any(e.span == span_or_none(v.init.span) for e in errors)
            if typed and isinstance(init, (Fraction, float)):  # int/int, as Storm types it
                report(
                    errors,
                    f'the initial value {init} of int variable "{v.name}" is not a whole number',
                    v.init.span,
                    hint="Storm would truncate it toward zero; write floor(...), ceil(...) or "
                    "round(...) to say which whole number is meant",
                )
            elif _is_int(init) and not low <= init <= high:
                report(
                    errors,
                    f'the initial value {init} of variable "{v.name}" is outside its range '
                    f"[{low}..{high}]",
                    v.init.span,
                )
    for c in analysis.resolved.constants:
        val = analysis.constants.values.get(c.name)
        if isinstance(val, float) and not math.isfinite(val):
            report(errors, f'the value of constant "{c.name}" is not finite ({val})', c.span)


def _whole(v: Value | None) -> Value | None:
    """A number that is whole as an int (Storm's int/int gives one); anything else as it is."""
    if isinstance(v, Fraction) and v.denominator == 1:
        return int(v)
    if isinstance(v, float) and v.is_integer():
        return int(v)
    return v


def _is_int(v: object) -> TypeGuard[int]:
    return isinstance(v, int) and not isinstance(v, bool)


def analyse_model(
    model: ModelFile,
    *,
    constants: Mapping[str, object] | None = None,
    allow_extra_constants: bool = False,
    strict: bool = False,
) -> ModelAnalysis:
    """Run every model pass and collect the errors (unsorted) in the returned record.

    Args:
        model: the parsed model file.
        constants: user values for undefined constants (text, Python values, ConstSetting).
        allow_extra_constants: do not report names in ``constants`` that the model does not
            declare (they may be properties-file constants).
        strict: PRISM's reading where Storm's differs (``dialect.py``): errors instead of
            warnings.
    """
    errors: list[PosgmcError] = []
    resolved = resolve_model(model, errors)
    hint = _undefined_hint(resolved)
    tc = TypeChecker(lookup=resolved.lookup, errors=errors, undefined_hint=hint)
    dialect = Dialect(strict)
    # its errors are the model checker's, already reported: only its types are wanted
    storm_tc = TypeChecker(lookup=resolved.lookup, errors=[], int_division=True)
    typing = _Typing(tc, storm_tc, dialect)

    for c in resolved.constants:
        if c.value is not None:
            check_constant_definition(c, tc)
    for body in resolved.formulas.values():
        tc.check(body)
    has_init_block = resolved.init is not None
    for v in resolved.globals:
        _check_variable(v, typing, errors, has_init_block=has_init_block)
    for m in resolved.modules:
        if m.name in resolved.broken_modules:
            continue
        for v in m.variables:
            _check_variable(v, typing, errors, has_init_block=has_init_block)
        _check_module(m, resolved, typing, errors)
    for d in resolved.labels:
        tc.expect(d.expr, Type.BOOL, f'label "{d.name}"')
    actions = set(resolved.actions)
    for r in resolved.rewards:
        for it in r.items:
            tc.expect(it.guard, Type.BOOL, "the guard of a reward item")
            tc.expect(it.value, Type.DOUBLE, "a reward")
            if it.is_action and it.action is not None and it.action not in actions:
                report(
                    errors,
                    f'unknown action "{it.action}" in reward structure',
                    it.span,
                    hint="no command is labelled with this action",
                )
    if resolved.init is not None:
        tc.expect(resolved.init, Type.BOOL, "the init...endinit predicate")

    settings = dict(constants or {})
    values = resolve_constants(resolved.constants, settings=settings, errors=errors)
    if not allow_extra_constants:
        errors.extend(
            unknown_constant_errors(
                settings,
                [c.name for c in resolved.constants],
                [c.name for c in resolved.constants if c.value is None],
            )
        )
    players = check_players(resolved, errors)
    observations = check_observables(resolved, tc, errors, dialect)
    analysis = ModelAnalysis(
        resolved, values, players, observations, errors, dialect.warnings
    )
    _value_checks(analysis, errors)
    return analysis


def undefined_constants_error(decls: Sequence[ConstantDecl]) -> ConstantError:
    """The error for constants still undefined (PRISM: 'Undefined constant "N" must be defined'),
    naming all of them and pointing at the first."""
    names = [d.name for d in decls]
    quoted = [f'"{n}"' for n in names]
    if len(quoted) == 1:
        msg = f"undefined constant {quoted[0]} must be given a value"
    else:
        msg = f"undefined constants {', '.join(quoted[:-1])} and {quoted[-1]} must be given values"
    example = ",".join(f"{n}=..." for n in names)
    return ConstantError(
        msg,
        span_or_none(decls[0].span),
        hint=f"give them with --const {example} (constants={{...}} in Python)",
    )


class _Instantiator:
    """Substitutes constant values and folds; one per FlatModel."""

    def __init__(self, analysis: ModelAnalysis) -> None:
        self.values = analysis.constants.values
        self.types = variable_types(analysis.resolved)

    def expr(self, e: Expr) -> Expr:
        return simplify(substitute(e, self.values), variable_types=self.types)

    def int_value(self, e: Expr) -> int:
        v = _whole(evaluate(e, self.values))  # a whole int/int (Storm's typing) is an int
        if isinstance(v, bool):
            return int(v)
        if not isinstance(v, int):
            raise SemanticError(f"expected an int, found {v}", span_or_none(e.span))
        return v


def _flat_observables(
    infos: Sequence[ObservableInfo], inst: _Instantiator
) -> tuple[FlatObservable, ...]:
    return tuple(FlatObservable(o.name, inst.expr(o.expr), o.span) for o in infos)


def build_flat_model(analysis: ModelAnalysis) -> FlatModel:
    """The FlatModel of an error-free analysis with every constant known."""
    resolved = analysis.resolved
    model = resolved.model
    inst = _Instantiator(analysis)

    variables: list[Variable] = []
    for v, module in resolved.variables:
        if v.type is VarType.BOOL:
            low, high = 0, 1
            init = int(bool(evaluate(v.init, inst.values))) if v.init is not None else 0
        else:
            assert v.low is not None and v.high is not None  # checked: bounded ints only
            low, high = inst.int_value(v.low), inst.int_value(v.high)
            init = inst.int_value(v.init) if v.init is not None else low
        variables.append(Variable(v.name, v.type, low, high, init, module, v.span))

    modules: list[FlatModule] = []
    for m in resolved.modules:
        commands = tuple(
            FlatCommand(
                m.name,
                c.action,
                inst.expr(c.guard),
                tuple(
                    FlatUpdate(
                        DoubleLit(Fraction(1), span=u.span)
                        if u.probability is None
                        else inst.expr(u.probability),
                        tuple(
                            FlatAssignment(a.variable, inst.expr(a.value), a.span)
                            for a in u.assignments
                        ),
                        u.span,
                    )
                    for u in c.updates
                ),
                c.span,
            )
            for c in m.commands
        )
        actions = frozenset(c.action for c in m.commands if c.action is not None)
        modules.append(
            FlatModule(m.name, tuple(v.name for v in m.variables), commands, actions, m.span)
        )

    obs = analysis.observations
    players = tuple(
        FlatPlayer(
            p.name,
            p.modules,
            p.actions,
            _flat_observables(obs.players[p.name], inst) if p.name in obs.players else None,
            p.span,
        )
        for p in analysis.players
    )
    labels: list[tuple[str, Expr]] = [(d.name, inst.expr(d.expr)) for d in resolved.labels]
    label_names = {d.name for d in resolved.labels}
    for name, o in obs.by_name.items():
        if o.type is Type.BOOL and name not in label_names:
            labels.append((name, inst.expr(o.expr)))
    rewards = tuple(
        FlatRewardStruct(
            r.name or None,
            tuple(
                FlatRewardItem(
                    it.is_action, it.action, inst.expr(it.guard), inst.expr(it.value), it.span
                )
                for it in r.items
            ),
            r.span,
        )
        for r in resolved.rewards
    )
    return FlatModel(
        model_type=model.model_type,
        variables=tuple(variables),
        modules=tuple(modules),
        players=players,
        observables=None if obs.top is None else _flat_observables(obs.top, inst),
        labels=tuple(labels),
        rewards=rewards,
        init=None if resolved.init is None else inst.expr(resolved.init),
        constants=tuple(
            (c.name, analysis.constants.values[c.name])
            for c in sorted(resolved.constants, key=lambda c: position(c.span))
            if c.name in analysis.constants.values
        ),
        file=model.file,
        warnings=tuple(sort_errors(analysis.warnings)),
    )


