"""The library's front door: load, lint, build and check models, each stage a function.

Typical use::

    from posgmc import api
    session = api.load("models/robot.posg", constants={"N": 4})
    report = api.check(session, properties=['<<robot>> Pmax=? [ F "goal" ]'])
    for r in report.results:
        print(r.property, r.value, r.lower, r.upper)

Stages are kept apart (parse -> semantic check -> build -> check) with small typed records passed
between them, so that a caller can stop after any of them. Every input error raised here is a
:class:`~posgmc.errors.PosgmcError` with the source text attached for rendering.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

from posgmc.build import BuildOptions, build_model
from posgmc.checking.dispatch import CheckOptions, PropertyChecker
from posgmc.checking.results import PropertyResult
from posgmc.errors import (
    InputError,
    SourceSpan,
    MultipleErrors,
    PosgmcError,
    SemanticError,
    SourceText,
    UnsupportedError,
)
from posgmc.model.explicit import ExplicitModel
from posgmc.semantics import checker as sem
from posgmc.semantics.evaluate import evaluate_constant
from posgmc.semantics.flat import FlatModel
from posgmc.syntax import parser
from posgmc.syntax.ast import NO_SPAN, Coalition, ModelFile, Property, PropertiesFile
from posgmc.syntax.printer import format_expr

ConstantValues = Mapping[str, object]

__all__ = [
    "Session",
    "CheckReport",
    "load",
    "lint",
    "build",
    "check",
    "iter_check",
    "parse_properties",
]


def _is_drn(text: str) -> bool:
    head = "\n".join(text.splitlines()[:40])
    return "@type:" in head


@dataclass(frozen=True, eq=False)
class Session:
    """A loaded model: its source, syntax tree (None for explicit DRN input) and constant values."""

    path: str | None
    source: SourceText
    syntax: ModelFile | None
    constants: Mapping[str, object] = field(default_factory=dict)
    explicit: ExplicitModel | None = None  # set for DRN input


def _read(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except UnicodeDecodeError as e:
        raise InputError(f"{path} is not UTF-8 text ({e.reason} at byte {e.start})") from None
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror}") from None


def _attach(error: PosgmcError, source: SourceText) -> PosgmcError:
    if isinstance(error, MultipleErrors):
        for e in error.errors:
            if e.source is None and (e.span is None or e.span.file in (None, source.file)):
                e.with_source(source)
    if error.source is None and (error.span is None or error.span.file in (None, source.file)):
        error.with_source(source)
    return error


def load(
    path: str | Path | None = None,
    *,
    text: str | None = None,
    constants: ConstantValues | None = None,
) -> Session:
    """Parse a model file (PRISM language, or Storm's explicit DRN) without checking it further.

    Args:
        path: the model file; or None with ``text``.
        text: the model text when there is no file.
        constants: values for the model's undefined constants (names to values or strings).

    Raises:
        ParseError, InputError: unreadable or unparsable input, with file/line/column.
    """
    name = str(path) if path is not None else None
    content = text if text is not None else _read(path)  # type: ignore[arg-type]
    source = SourceText(content, name)
    try:
        if _is_drn(content):
            from posgmc.io.drn import parse_drn

            return Session(name, source, None, dict(constants or {}), parse_drn(content, file=name))
        return Session(name, source, parser.parse_model(content, file=name), dict(constants or {}))
    except PosgmcError as e:
        raise _attach(e, source) from None


def parse_properties(
    session: Session, *, files: Sequence[str | Path] = (), texts: Sequence[str] = ()
) -> tuple[list[tuple[PropertiesFile, SourceText]], list[Property]]:
    """Parse property files and command-line properties (raises ParseError with position)."""
    parsed: list[tuple[PropertiesFile, SourceText]] = []
    for f in files:
        content = _read(f)
        src = SourceText(content, str(f))
        try:
            parsed.append((parser.parse_properties(content, file=str(f)), src))
        except PosgmcError as e:
            raise _attach(e, src) from None
    props: list[Property] = []
    for i, t in enumerate(texts):
        src = SourceText(t, f"<--prop {i + 1}>")
        try:
            props.append(parser.parse_property(t, file=src.file))
        except PosgmcError as e:
            raise _attach(e, src) from None
    return parsed, props


def lint(
    path: str | Path,
    property_files: Sequence[str | Path] = (),
    *,
    constants: ConstantValues | None = None,
    property_texts: Sequence[str] = (),
    zero_based_players: bool = False,
) -> list[PosgmcError]:
    """Every error in a model and its properties, without building anything.

    Constants without a value are not errors here: everything that does not depend on their values
    is checked, and with ``constants`` everything else too.
    """
    errors: list[PosgmcError] = []
    try:
        session = load(path, constants=constants)
    except PosgmcError as e:
        return [e]
    src = session.source
    if session.syntax is not None:
        extra = bool(property_files or property_texts)  # property-file constants share --const
        errors += [
            _attach(e, src)
            for e in sem.check_model(session.syntax, constants=constants, allow_extra_constants=extra)
        ]
    for f in property_files:
        try:
            parsed, _ = parse_properties(session, files=[f])
        except PosgmcError as e:
            errors.append(e)
            continue
        pf, psrc = parsed[0]
        if session.syntax is not None and not errors:
            errs = sem.check_properties(
                pf, session.syntax, constants=constants, zero_based_players=zero_based_players
            )
            errors += [_attach(e, psrc) for e in errs]
    for i, t in enumerate(property_texts):
        try:
            _, props = parse_properties(session, texts=[t])
        except PosgmcError as e:
            errors.append(e)
            continue
        if session.syntax is not None and not errors:
            errs = sem.check_properties(
                props, session.syntax, constants=constants, zero_based_players=zero_based_players
            )
            errors += [_attach(e, SourceText(t, f"<--prop {i + 1}>")) for e in errs]
    return errors


def instantiate(session: Session, *, allow_extra_constants: bool = False) -> FlatModel:
    """Semantic checks and constant substitution: the model ready for the compiler.

    ``allow_extra_constants``: values for constants the model does not declare are allowed
    (they belong to property files checked later)."""
    if session.syntax is None:
        raise UnsupportedError("an explicit (DRN) model has no PRISM-language description")
    try:
        return sem.instantiate(
            session.syntax, constants=session.constants, allow_extra_constants=allow_extra_constants
        )
    except PosgmcError as e:
        raise _attach(e, session.source) from None


@dataclass(frozen=True, eq=False)
class BuiltModel:
    model: ExplicitModel
    seconds: float
    warnings: tuple[str, ...] = ()
    flat: FlatModel | None = None


def build(
    session: Session, *, options: BuildOptions = BuildOptions(), allow_extra_constants: bool = False
) -> BuiltModel:
    """Explore the model's reachable state space into an :class:`ExplicitModel`."""
    if session.explicit is not None:
        return BuiltModel(session.explicit, 0.0)
    flat = instantiate(session, allow_extra_constants=allow_extra_constants)
    try:
        result = build_model(flat, options=options)
    except PosgmcError as e:
        raise _attach(e, session.source) from None
    return BuiltModel(result.model, result.seconds, tuple(result.warnings), flat)


@dataclass(frozen=True, eq=False)
class CheckReport:
    """The model's size and one result per property, in order."""

    model: ExplicitModel
    build_seconds: float
    results: tuple[PropertyResult, ...]
    warnings: tuple[str, ...] = ()
    errors: tuple[tuple[str, PosgmcError], ...] = ()
    outcomes: tuple[PropertyResult | tuple[str, PosgmcError], ...] = ()  # all, in order


def _coalition_resolver(model: ExplicitModel, zero_based: bool):  # type: ignore[no-untyped-def]
    names = model.player_names

    def resolve(c: Coalition | None) -> frozenset[int] | None:
        if c is None:
            return None
        if c.all_players:
            return frozenset(range(len(names)))
        out: set[int] = set()
        for p in c.players:
            if p.name is not None:
                if p.name not in names:
                    raise SemanticError(f"no player named '{p.name}'", p.span)
                out.add(names.index(p.name))
            else:
                assert p.number is not None  # noqa: S101 - a PlayerRef is a name or a number
                index = p.number if zero_based else p.number - 1
                if not 0 <= index < len(names):
                    raise _no_such_player(p.number, names, zero_based, p.span)
                out.add(index)
        return frozenset(out)

    return resolve


def _no_such_player(
    number: int, names: Sequence[str], zero_based: bool, span: SourceSpan
) -> SemanticError:
    """A coalition number out of range, with both numberings of the players and the option that
    switches between them (PAYNT's POSMG files and ``sketch.props`` count from 0)."""
    one = ", ".join(f"{i + 1}: {n}" for i, n in enumerate(names))
    zero = ", ".join(f"{i}: {n}" for i, n in enumerate(names))
    if zero_based:
        hint = f"numbers count from 0 here (--zero-based-players): {zero}; PRISM-games' 1-based numbers are {one}"
    else:
        hint = (
            f"numbers count from 1 as in PRISM-games: {one}; Storm and PAYNT count from 0 ({zero}): "
            "pass --zero-based-players (zero_based_players=True in Python) to read them so"
        )
    n = len(names)
    return SemanticError(
        f"player number {number} does not exist: the model has {n} player{'s' if n != 1 else ''}",
        span,
        hint=hint,
    )


def _scalar(expr):  # type: ignore[no-untyped-def]
    value = evaluate_constant(expr)
    if isinstance(value, Fraction):
        return value if value.denominator != 1 else int(value)
    return value


def iter_check(
    session: Session,
    *,
    property_files: Sequence[str | Path] = (),
    properties: Sequence[str] = (),
    options: CheckOptions = CheckOptions(),
    full_observation: bool = False,
    zero_based_players: bool = False,
    built: BuiltModel,
) -> Iterator[tuple[Property, PropertyResult | PosgmcError]]:
    """Check each property in turn; a property that fails yields its error and the others go on
    (as PRISM does). Errors that concern the whole input (unparsable files) are raised."""
    parsed, cli_props = parse_properties(session, files=property_files, texts=properties)
    model = built.model
    partial = model.model_type.is_partially_observable or bool(model.observations)
    if partial and not full_observation:
        raise UnsupportedError(
            f"this is a partially observable model ({model.model_type.value}); partially observable "
            "synthesis is not available in this build",
            hint="pass --full-observation (full_observation=True) to get the fully observable value, "
            "which bounds the partially observable one",
        )
    note = (
        "full-observation value: an upper bound for a maximising and a lower bound for a minimising "
        "partially observing player"
        if partial
        else None
    )
    checker = PropertyChecker(
        model,
        coalition_of=_coalition_resolver(model, zero_based_players),
        scalar=_scalar,
        options=options,
    )
    groups: list[tuple[Sequence[Property], SourceText | None]] = [
        (pf.properties, src) for pf, src in parsed
    ]
    files = [pf for pf, _ in parsed]
    if cli_props:
        groups.append((cli_props, None))
        files.append(PropertiesFile(properties=tuple(cli_props)))
    for (props, src), pf in zip(groups, files):
        for prop in props:
            outcome = _check_one(session, built, checker, pf, prop, zero_based_players)
            if isinstance(outcome, PosgmcError):
                own = src
                if own is None and outcome.span is not None and outcome.span.file and prop.text:
                    # a --prop text: its own one-line source (the span names it "<--prop i>")
                    own = SourceText(prop.text, outcome.span.file)
                if own is not None:
                    _attach(outcome, own)
            elif note:
                outcome = dataclasses.replace(outcome, note=note)
            yield prop, outcome


def _check_one(
    session: Session,
    built: BuiltModel,
    checker: PropertyChecker,
    pf: PropertiesFile,
    prop: Property,
    zero_based_players: bool,
) -> PropertyResult | PosgmcError:
    try:
        expr = prop.expr
        if session.syntax is not None and built.flat is not None:
            # the file's constants, formulas and labels apply to each of its properties
            single = dataclasses.replace(pf, properties=(prop,))
            (cp,) = sem.instantiate_properties(
                single,
                built.flat,
                model=session.syntax,
                constants=session.constants,
                zero_based_players=zero_based_players,
            )
            expr = cp.expr
        text = prop.text or format_expr(prop.expr)
        return checker.check(expr, text=text, name=prop.name)
    except MultipleErrors as e:
        return e.errors[0] if len(e.errors) == 1 else e
    except PosgmcError as e:
        # an engine refusing the property (e.g. negative rewards it cannot handle) knows no
        # position: point at the property it was asked to check
        if e.span is None:
            span = prop.span if prop.span != NO_SPAN else prop.expr.span
            e.span = span if span != NO_SPAN else None
        return e


def check(
    session: Session,
    *,
    property_files: Sequence[str | Path] = (),
    properties: Sequence[str] = (),
    options: CheckOptions = CheckOptions(),
    build_options: BuildOptions = BuildOptions(),
    full_observation: bool = False,
    zero_based_players: bool = False,
    built: BuiltModel | None = None,
) -> CheckReport:
    """Build the model (unless ``built`` is given) and check each property at the initial states.

    Args:
        session: from :func:`load`.
        property_files: PRISM property files.
        properties: property texts (as given with ``--prop``).
        options: numerical method, precision, what to keep.
        full_observation: on pomdp/posg models, answer the full-observation value (a bound on the
            partially observable value, labelled as such); without it such models are refused.
        zero_based_players: read numeric coalitions ``<<0>>`` as Storm/PAYNT do.

    Returns:
        The report; ``errors`` holds (property text, error) for properties that could not be
        checked, ``results`` the others, in order.

    Raises:
        InputError: bad model, unparsable property files or constants.
        UnsupportedError: a partially observable model without ``full_observation``.
    """
    built = built or build(session, options=build_options, allow_extra_constants=True)
    results: list[PropertyResult] = []
    errors: list[tuple[str, PosgmcError]] = []
    outcomes: list[PropertyResult | tuple[str, PosgmcError]] = []
    for prop, outcome in iter_check(
        session,
        property_files=property_files,
        properties=properties,
        options=options,
        full_observation=full_observation,
        zero_based_players=zero_based_players,
        built=built,
    ):
        if isinstance(outcome, PosgmcError):
            errors.append((prop.text or format_expr(prop.expr), outcome))
            outcomes.append(errors[-1])
        else:
            results.append(outcome)
            outcomes.append(outcome)
    return CheckReport(
        built.model, built.seconds, tuple(results), built.warnings, tuple(errors), tuple(outcomes)
    )
