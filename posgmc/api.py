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

import contextlib
import dataclasses
import functools
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

from posgmc.checking.property_checker import CheckOptions, PropertyChecker
from posgmc.checking.results import PropertyResult
from posgmc.compiler import BuildOptions, build_model
from posgmc.compiler.options import ProgressMode
from posgmc.deep_stack import deep_generator, deep_stack
from posgmc.engines import kernels, scc
from posgmc.errors import (
    InputError,
    LimitError,
    MultipleErrors,
    PosgmcError,
    SourceText,
    UnsupportedError,
)
from posgmc.model.actions import choices_by_index
from posgmc.model.explicit import ExplicitModel
from posgmc.model.origin import remember
from posgmc.semantics import operators as ops
from posgmc.semantics import stages as sem
from posgmc.semantics.evaluate import Value, evaluate_constant
from posgmc.semantics.flat import FlatModel
from posgmc.semantics.properties import QueryResolver, resolve_queries
from posgmc.semantics.references import inline_property_references
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser
from posgmc.syntax.ast import NO_SPAN, Expr, ModelFile, PropertiesFile, Property
from posgmc.syntax.printer import format_expr

if TYPE_CHECKING:
    from posgmc.strategies.fss import FiniteStateStrategy
    from posgmc.strategies.simulate import Simulation
    from posgmc.synthesis.checker import SynthesisChecker
    from posgmc.synthesis.options import SynthesisOptions

StrategySources = (
    Mapping[str, "FiniteStateStrategy | str | Path"]
    | Mapping[str | None, "FiniteStateStrategy | str | Path"]
)
"""Strategies by player name, as objects or ``posgmc-fss/1`` files; the key None stands for a
file's own player (``--strategy FILE``)."""

ConstantValues = Mapping[str, object]


__all__ = [
    "Session",
    "CheckReport",
    "PropertyError",
    "load",
    "lint",
    "build",
    "check",
    "iter_check",
    "parse_properties",
    "load_strategy",
    "save_strategy",
    "simulate",
]


def _is_drn(text: str, path: str | None = None) -> bool:
    """DRN or PRISM: a ``.drn`` file is DRN; otherwise the first token that is not in a ``//``
    comment decides (DRN files open with ``@type:``, possibly after comment lines)."""
    if path is not None and path.lower().endswith(".drn"):
        return True
    for line in text.lstrip("\ufeff").split("\n"):
        stripped = line.strip()
        if stripped and not stripped.startswith("//"):
            return stripped.startswith("@")
    return False


@dataclass(frozen=True, eq=False)
class Session:
    """A loaded model: its source, syntax tree (None for explicit DRN input) and constant values.

    ``strict``: PRISM's reading where Storm's differs (``semantics/dialect.py``): what only
    Storm accepts is an error instead of a warning."""

    path: str | None
    source: SourceText
    syntax: ModelFile | None
    constants: Mapping[str, object] = field(default_factory=dict)
    explicit: ExplicitModel | None = None  # set for DRN input
    strict: bool = False

    def with_constants(
        self, constants: ConstantValues | None = None, /, **values: object
    ) -> Session:
        """The same parsed model with other constant values (added to, or replacing, this
        session's), without reading or parsing the file again: what a sweep needs per point.

        ``session.with_constants({"N": 4})`` and ``session.with_constants(N=4)`` are the same.
        """
        if constants is not None and not isinstance(constants, Mapping):
            raise InputError(
                f"constants must be a mapping of names to values, got {type(constants).__name__}"
            )
        return dataclasses.replace(
            self, constants={**self.constants, **(constants or {}), **values}
        )

    @classmethod
    def of_model(cls, model: ExplicitModel, *, name: str | None = None) -> Session:
        """A session around a compiled model (read from DRN or built by hand with
        :func:`~posgmc.model.explicit.make_model`), so that :func:`check` can take it."""
        if not isinstance(model, ExplicitModel):
            raise InputError(f"expected an ExplicitModel, got {type(model).__name__}")
        return cls(name, SourceText("", name), None, {}, model.validate())


def _read(path: str | Path) -> str:
    from posgmc.io.reading import read_text

    return read_text(path)


def _attach(error: PosgmcError, source: SourceText) -> PosgmcError:
    if isinstance(error, MultipleErrors):
        for e in error.errors:
            if e.source is None and (e.span is None or e.span.file in (None, source.file)):
                e.with_source(source)
    if error.source is None and (error.span is None or error.span.file in (None, source.file)):
        error.with_source(source)
    return error


def _one_or_many(value: object, kinds: tuple[type, ...], expected: str) -> tuple[Any, ...]:
    """One item of ``kinds`` or a sequence of them (a single string is one item, never its
    characters); None is none. ``expected`` completes the error message."""
    if value is None:
        return ()
    if isinstance(value, kinds):
        return (value,)
    if isinstance(value, Sequence) and all(isinstance(v, kinds) for v in value):
        return tuple(value)
    raise InputError(f"{expected}, got {type(value).__name__}")


def _paths(value: object, what: str) -> tuple[str | Path, ...]:
    """One path or a sequence of them."""
    return _one_or_many(value, (str, Path), f"{what} must be a path or a list of paths")


def _texts(value: object, what: str) -> tuple[str, ...]:
    """One text or a sequence of them."""
    return _one_or_many(value, (str,), f"{what} must be a string or a list of strings")


def _property_items(value: object) -> tuple[str | Property, ...]:
    """One property (text or parsed) or a sequence of them."""
    return _one_or_many(
        value, (str, Property),
        "properties must be a string or a list of strings or parsed properties",
    )


def _session(value: object) -> Session:
    if isinstance(value, Session):
        return value
    if isinstance(value, ExplicitModel):
        return Session.of_model(value)
    hint = ("load the model first: session = api.load(path)" if isinstance(value, (str, Path))
            else "check() also takes a compiled ExplicitModel")
    raise InputError(
        f"expected a Session from api.load, got {type(value).__name__}",
        hint=hint,
    )


def _typed(value: object, kind: type, what: str) -> None:
    if not isinstance(value, kind):
        raise InputError(f"{what} must be a {kind.__name__}, got {type(value).__name__}")


@deep_stack
def load(
    path: str | Path | None = None,
    *,
    text: str | None = None,
    constants: ConstantValues | None = None,
    strict: bool = False,
) -> Session:
    """Parse a model file (PRISM language, or Storm's explicit DRN) without checking it further.

    Args:
        path: the model file; or None with ``text``.
        text: the model text when there is no file.
        constants: values for the model's undefined constants (names to values or strings).
        strict: keep PRISM's reading where Storm accepts more (an int variable given int/int,
            an observable named like a label): errors instead of warnings.

    Raises:
        ParseError, InputError: unreadable or unparsable input, with file/line/column.
    """
    if path is not None and not isinstance(path, (str, Path)):
        raise InputError(f"path must be a file path, got {type(path).__name__}")
    if text is not None and not isinstance(text, str):
        raise InputError(f"text must be a string, got {type(text).__name__}")
    if path is None and text is None:
        raise InputError("give the model's path or its text (text=...)")
    if constants is not None and not isinstance(constants, Mapping):
        raise InputError(
            f"constants must be a mapping of names to values, got {type(constants).__name__}"
        )
    if not isinstance(strict, bool):
        raise InputError(f"strict must be True or False, got {type(strict).__name__}")
    name = str(path) if path is not None else None
    if text is not None:
        content = text
    else:
        assert path is not None  # noqa: S101 - one of them is given (checked above)
        content = _read(path)
    source = SourceText(content, name)
    try:
        if _is_drn(content, name):
            from posgmc.io.drn import parse_drn

            # a byte-order mark is accepted as in PRISM files; the columns of errors stay right
            drn = parse_drn(content.removeprefix("\ufeff"), file=name)
            return Session(name, source, None, dict(constants or {}), drn, strict)
        syntax = parser.parse_model(content, file=name)
        return Session(name, source, syntax, dict(constants or {}), strict=strict)
    except PosgmcError as e:
        raise _attach(e, source) from None


@deep_stack
def parse_properties(
    session: Session,
    *,
    files: Sequence[str | Path] = (),
    texts: Sequence[str | Property] = (),
) -> tuple[list[tuple[PropertiesFile, SourceText]], list[Property]]:
    """Parse property files and property texts (raises ParseError with position).

    Returns the parsed files (each with its source) and the properties of ``texts``: reusable
    :class:`~posgmc.syntax.ast.Property` objects that :func:`check` accepts in ``properties``
    (already parsed ones in ``texts`` are passed through)."""
    files, texts = _paths(files, "files"), _property_items(texts)
    parsed: list[tuple[PropertiesFile, SourceText]] = []
    for f in files:
        content = _read(f)
        src = SourceText(content, str(f))
        try:
            pf = parser.parse_properties(content, file=str(f))
        except PosgmcError as e:
            raise _attach(e, src) from None
        if not pf.properties:
            raise InputError(f"{f} holds no property", hint="a properties file lists one or more "
                             "properties, e.g. Pmax=? [ F \"goal\" ];")
        parsed.append((pf, src))
    props: list[Property] = []
    for i, t in enumerate(texts):
        if isinstance(t, Property):
            props.append(t)
            continue
        src = SourceText(t, f"<--prop {i + 1}>")
        try:
            props.append(parser.parse_property(t, file=src.file))
        except PosgmcError as e:
            raise _attach(e, src) from None
    return parsed, props


@deep_stack
def lint(
    path: str | Path,
    property_files: Sequence[str | Path] = (),
    *,
    constants: ConstantValues | None = None,
    property_texts: Sequence[str] = (),
    zero_based_players: bool = False,
    strict: bool = False,
) -> list[PosgmcError]:
    """Every error in a model and its properties, without building anything.

    Constants without a value are not errors here: everything that does not depend on their values
    is checked, and with ``constants`` everything else too. ``strict``: see :func:`load`.
    """
    property_files = _paths(property_files, "property_files")
    property_texts = _texts(property_texts, "property_texts")
    errors: list[PosgmcError] = []
    try:
        session = load(path, constants=constants, strict=strict)
    except PosgmcError as e:
        return [e]
    src = session.source
    if session.syntax is not None:
        extra = bool(property_files or property_texts)  # property-file constants share --const
        errors += [
            _attach(e, src)
            for e in sem.check_model(
                session.syntax, constants=constants, allow_extra_constants=extra, strict=strict
            )
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


@deep_stack
def instantiate(session: Session, *, allow_extra_constants: bool = False) -> FlatModel:
    """Semantic checks and constant substitution: the model ready for the compiler.

    ``allow_extra_constants``: values for constants the model does not declare are allowed
    (they belong to property files checked later)."""
    if session.syntax is None:
        raise UnsupportedError("an explicit (DRN) model has no PRISM-language description")
    try:
        flat = sem.instantiate(
            session.syntax,
            constants=session.constants,
            allow_extra_constants=allow_extra_constants,
            strict=session.strict,
        )
        for w in flat.warnings:
            _attach(w, session.source)
        return flat
    except PosgmcError as e:
        raise _attach(e, session.source) from None


@dataclass(frozen=True, eq=False)
class BuiltModel:
    model: ExplicitModel
    seconds: float
    warnings: tuple[str, ...] = ()
    flat: FlatModel | None = None


@deep_stack
def build(
    session: Session, *, options: BuildOptions = BuildOptions(), allow_extra_constants: bool = False
) -> BuiltModel:
    """Explore the model's reachable state space into an :class:`ExplicitModel`.

    Choices that share their label within their state (unlabelled ones included: a DRN POMDP
    without choice labels) are named by their local index, ``#0``, ``#1``, ..., as Storm and
    PAYNT name them, so that strategies and strategy files can tell them apart."""
    session = _session(session)
    _typed(options, BuildOptions, "options")
    if session.explicit is not None:
        built = BuiltModel(_check_explicit(session, options), 0.0)
    else:
        with ops.exact_arithmetic() if options.exact else contextlib.nullcontext():
            flat = instantiate(session, allow_extra_constants=allow_extra_constants)
        try:
            result = build_model(flat, options=options, on_states=_warm_up_when_large)
        except PosgmcError as e:
            raise _attach(e, session.source) from None
        dialect = tuple(str(w) for w in flat.warnings)
        built = BuiltModel(result.model, result.seconds, dialect + tuple(result.warnings), flat)
    named = choices_by_index(
        built.model.choice_actions, built.model.row_groups, built.model.action_names
    )
    if named is not None:
        model = dataclasses.replace(built.model, choice_actions=named[0], action_names=named[1])
        built = dataclasses.replace(built, model=model)
    _warm_up_when_large(built.model.num_choices)
    if session.source.text:  # not a model handed over built (Session.of_model)
        # how to build this model again (a cluster's worker does, from the text): the options
        # without the build's own clock and progress, which do not change the model
        again = dataclasses.replace(options, deadline=None, progress=ProgressMode.NEVER)
        remember(built.model, functools.partial(_rebuilt, session.path, session.source.text,
                                                dict(session.constants), session.strict, again,
                                                allow_extra_constants))
    return built


def _rebuilt(path: str | None, text: str, constants: dict[str, object], strict: bool,
            options: BuildOptions, allow_extra_constants: bool) -> ExplicitModel:
    """The model :func:`build` built from this text, constants and options, built again (see
    :mod:`posgmc.model.origin`)."""
    session = load(path, text=text, constants=constants, strict=strict)
    return build(session, options=options, allow_extra_constants=allow_extra_constants).model


def _warm_up_when_large(size: int) -> None:
    """Start loading the engines' compiled kernels on a thread (once per process) as soon as the
    model being built reaches ``scc.COMPILED_MIN_SIZE`` states (or choices), so that they are
    ready when its analysis starts; a smaller model never loads numba, whose start-up
    (:mod:`posgmc.engines.kernels`) would cost more than the kernels save."""
    if size >= scc.COMPILED_MIN_SIZE:
        kernels.warm_up_in_background()


def _check_explicit(session: Session, options: BuildOptions) -> ExplicitModel:
    """A model read from DRN obeys the same options as a built one: the state limit holds, and
    constants (which a DRN file cannot have) are an error rather than silently ignored."""
    model = session.explicit
    assert model is not None  # noqa: S101 - the caller checked
    if session.constants:
        raise InputError(
            f"{session.path or 'the model'} is an explicit (DRN) model: it has no constants to set "
            f"({', '.join(sorted(session.constants))} given)",
            hint="drop --const for DRN input",
        )
    if model.num_states > options.state_limit:
        raise LimitError(
            f"the model has {model.num_states} states, more than the state limit "
            f"{options.state_limit}",
            hint="raise --state-limit",
        )
    return model


class PropertyError(NamedTuple):
    """A property that could not be checked (the others go on, as in PRISM): its text and the
    positioned error. A named tuple, so ``text, error = outcome`` works too."""

    property: str
    error: PosgmcError


@dataclass(frozen=True, eq=False)
class CheckReport:
    """The model's size and one outcome per property, in order.

    ``outcomes`` holds every property's :class:`PropertyResult` or :class:`PropertyError`;
    ``results`` and ``errors`` are the two kinds apart."""

    model: ExplicitModel
    build_seconds: float
    results: tuple[PropertyResult, ...]
    warnings: tuple[str, ...] = ()
    errors: tuple[PropertyError, ...] = ()
    outcomes: tuple[PropertyResult | PropertyError, ...] = ()  # all, in order


def _resolver(model: ExplicitModel, zero_based: bool) -> QueryResolver:
    """The semantic stage's resolution of coalitions and reward structures against the compiled
    model's players and reward structures: the FlatModel's for PRISM input (where the semantic
    stage has already resolved every query), the only ones for DRN input."""
    return QueryResolver(
        model.model_type,
        tuple(model.player_names),
        tuple(rm.name for rm in model.reward_models),
        zero_based,
    )


def _scalar(expr: Expr) -> Value:
    """A constant expression's value, a whole Fraction as an int."""
    value = evaluate_constant(expr)
    if isinstance(value, Fraction):
        return value if value.denominator != 1 else int(value)
    return value


@deep_generator
def iter_check(
    session: Session,
    *,
    property_files: Sequence[str | Path] = (),
    properties: Sequence[str | Property] = (),
    options: CheckOptions = CheckOptions(),
    full_observation: bool = False,
    zero_based_players: bool = False,
    built: BuiltModel,
    strategies: Mapping[str, FiniteStateStrategy] | None = None,
    synthesis: SynthesisOptions | None = None,
    select: Sequence[str | int] | None = None,
) -> Iterator[tuple[Property, PropertyResult | PosgmcError]]:
    """Check each property in turn; a property that fails yields its error and the others go on
    (as PRISM does). Errors that concern the whole input (unparsable files) are raised.

    ``select``: only these properties, by name (``"mission"`` for ``"mission": P=? [...]``) or
    by 1-based position among the files' properties and then ``properties`` (PRISM's ``-prop``,
    Storm's ``--propertyfilter``); an unknown name or position is an InputError before any
    property is checked.

    With ``strategies`` (player name -> strategy) every property is answered under them (see
    :mod:`posgmc.strategies.verify`): ``guaranteed``, ``vs_fss_adversary``, ``upper_bound``.
    A partially observable model without strategies and without ``full_observation`` is answered
    by synthesis (:mod:`posgmc.synthesis`), configured by ``synthesis``."""
    from posgmc.synthesis.budget import interrupted
    from posgmc.synthesis.options import SynthesisOptions

    synthesis = synthesis or SynthesisOptions()
    parsed, cli_props = parse_properties(session, files=property_files, texts=properties)
    model = built.model
    partial = model.model_type.is_partially_observable or bool(model.observations)
    if strategies and full_observation:
        raise InputError(
            "given strategies and --full-observation ask different questions",
            hint="drop --full-observation: the numbers under given strategies need none",
        )
    synthesising = partial and not full_observation and not strategies
    note = (
        "full-observation value: an upper bound for a maximising and a lower bound for a "
        "minimising partially observing player"
        if partial and full_observation
        else None
    )
    checker = _checker(model, options, zero_based_players, strategies,
                       synthesis if synthesising else None)
    files = _with_texts([pf for pf, _ in parsed], cli_props)
    sources: list[SourceText | None] = [src for _, src in parsed] + [None] * bool(cli_props)
    chosen = _selection(files, select)
    labels = _label_names(built)
    for k, (pf, src) in enumerate(zip(files, sources)):
        pf, cyclic = inline_property_references(pf, labels)
        for i, prop in enumerate(pf.properties):
            if chosen is not None and (k, i) not in chosen:
                continue
            outcome = cyclic.get(i) or _check_one(
                session, built, checker, pf, prop, zero_based_players
            )
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
            if synthesising and interrupted():
                return  # Ctrl-C: the property it cut short reported its best; no further ones


def _with_texts(files: list[PropertiesFile], texts: list[Property]) -> list[PropertiesFile]:
    """The properties files, then the property texts as one more file."""
    return files + [PropertiesFile(properties=tuple(texts))] if texts else files


def _selection(
    files: Sequence[PropertiesFile], select: Sequence[str | int] | None
) -> set[tuple[int, int]] | None:
    """(file, property) positions of the selected properties; None: all of them."""
    if select is None:
        return None
    if isinstance(select, (str, int)) or not isinstance(select, Sequence):
        raise InputError(
            f"select must be a list of property names or positions, got {type(select).__name__}"
        )
    where = [(k, i) for k, pf in enumerate(files) for i in range(len(pf.properties))]
    names: dict[str, tuple[int, int]] = {}
    for k, pf in enumerate(files):
        for i, prop in enumerate(pf.properties):
            if prop.name is not None:
                names.setdefault(prop.name, (k, i))
    out: set[tuple[int, int]] = set()
    for item in select:
        if isinstance(item, bool) or not isinstance(item, (str, int)):
            raise InputError(f"a selected property is a name or a position, got {item!r}")
        text = item.strip() if isinstance(item, str) else str(item)
        if text.isdigit():
            n = int(text)
            if not 1 <= n <= len(where):
                raise InputError(
                    f"there is no property {n}: the properties are numbered 1 to {len(where)}",
                    hint="--select takes property names or 1-based positions",
                )
            out.add(where[n - 1])
            continue
        name = text[1:-1] if len(text) > 1 and text[0] == text[-1] == '"' else text
        if name not in names:
            known = ", ".join(f'"{n}"' for n in names) or "none (write \"name\": before one)"
            raise InputError(
                f'no property is named "{name}"', hint=f"the named properties: {known}"
            )
        out.add(names[name])
    return out


def _label_names(built: BuiltModel) -> set[str]:
    """The quoted names a property may use as labels (model labels, observables)."""
    if built.flat is not None:
        return {name for name, _ in built.flat.labels}
    return set(built.model.labels)


def _checker(
    model: ExplicitModel,
    options: CheckOptions,
    zero_based_players: bool,
    strategies: Mapping[str, FiniteStateStrategy] | None,
    synthesis: SynthesisOptions | None = None,
) -> PropertyChecker | StrategyChecker | SynthesisChecker:
    """The checker that answers (each answers :class:`~posgmc.checking.protocols.Checker`'s
    ``check``), in :func:`check`'s order of precedence: exact mode, synthesis, given strategies,
    the plain checker."""
    coalition_of = _resolver(model, zero_based_players).coalition_of
    if options.exact:
        from posgmc.checking.exact_checker import ExactChecker

        return ExactChecker(model, coalition_of=coalition_of, scalar=_scalar, options=options)
    if synthesis is not None:
        from posgmc.synthesis.checker import SynthesisChecker

        return SynthesisChecker(model, coalition_of=coalition_of, scalar=_scalar, options=options,
                                synthesis=synthesis)
    if strategies:
        return StrategyChecker(
            model, strategies, coalition_of=coalition_of, scalar=_scalar, options=options
        )
    return PropertyChecker(model, coalition_of=coalition_of, scalar=_scalar, options=options)


def _check_one(
    session: Session,
    built: BuiltModel,
    checker: PropertyChecker | StrategyChecker | SynthesisChecker,
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
        else:
            # no semantic stage for an explicit model: its queries' references resolved here,
            # by the same resolver, before any engine runs
            resolve_queries(expr, _resolver(built.model, zero_based_players))
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


@deep_stack
def check(
    session: Session | ExplicitModel,
    *,
    property_files: Sequence[str | Path] = (),
    properties: Sequence[str | Property] = (),
    options: CheckOptions = CheckOptions(),
    build_options: BuildOptions = BuildOptions(),
    full_observation: bool = False,
    zero_based_players: bool = False,
    built: BuiltModel | None = None,
    strategies: StrategySources | None = None,
    synthesis: SynthesisOptions | None = None,
    on_start: Callable[[ExplicitModel, float, tuple[str, ...]], None] | None = None,
    on_outcome: Callable[[PropertyResult | PropertyError], None] | None = None,
    select: Sequence[str | int] | None = None,
) -> CheckReport:
    """Build the model (unless ``built`` is given) and check each property at the initial states.

    Args:
        session: from :func:`load`, or a compiled :class:`ExplicitModel` (read from DRN or built
            by hand), checked as it is.
        property_files: PRISM property files.
        properties: property texts (as given with ``--prop``) or properties parsed once with
            :func:`parse_properties`.
        options: numerical method, precision, what to keep.
        full_observation: on pomdp/posg models, answer the full-observation value (a bound on the
            partially observable value, labelled as such); without it such models are refused.
        zero_based_players: read numeric coalitions ``<<0>>`` as Storm/PAYNT do.
        strategies: finite-state strategies by player name (objects or ``posgmc-fss/1`` files);
            each result then carries ``guaranteed`` (the decision maker's strategies against an
            omniscient adversary), ``vs_fss_adversary`` (every player's strategy fixed) and
            ``upper_bound`` (the adversary's strategies against an omniscient decision maker),
            those that the given strategies determine.
        synthesis: how to synthesise strategies for a partially observable model checked
            without ``strategies`` and without ``full_observation`` (memory sizes, time budget,
            seed; :class:`~posgmc.synthesis.search.SynthesisOptions`). The first synthesised
            property's budget counts from ``synthesis.started``, or from this call: building
            the model is inside it.
        on_start: called once the model is built, with the model, its build time and the
            warnings, before any property is checked (to show progress).
        on_outcome: called with each outcome (as in ``outcomes``) as soon as it is computed, so
            a caller can print results while the next property is being checked.
        select: only the properties of these names or 1-based positions (see
            :func:`iter_check`).

    Which checker answers, in this order of precedence: exact mode (``options.exact``: rational
    arithmetic; given strategies and ``full_observation`` are refused with it), then synthesis (a
    partially observable model checked without ``strategies`` and without ``full_observation``),
    then the given ``strategies``, else the plain checker (a partially observable model read with
    ``full_observation``).

    Returns:
        The report; ``errors`` holds (property text, error) for properties that could not be
        checked, ``results`` the others, in order.

    Raises:
        InputError: bad model, unparsable property files or constants.
        UnsupportedError: a partially observable model without ``full_observation``.
    """
    session = _session(session)
    property_files, properties, build_options, synthesis = _check_arguments(
        options, property_files, properties, strategies, full_observation, build_options,
        synthesis,
    )
    if select is not None:  # before the build: nothing is reported for a wrong selection
        parsed, texts = parse_properties(session, files=property_files, texts=properties)
        _selection(_with_texts([pf for pf, _ in parsed], texts), select)
    built = built or _build_for_check(session, property_files, properties, build_options)
    loaded = load_strategies(strategies, model=built.model) if strategies else None
    warnings = built.warnings + _strategy_warnings(built.model, loaded)
    if on_start is not None:
        on_start(built.model, built.seconds, warnings)
    outcomes = _outcomes(
        iter_check(
            session,
            property_files=property_files,
            properties=properties,
            options=options,
            full_observation=full_observation,
            zero_based_players=zero_based_players,
            built=built,
            strategies=loaded,
            synthesis=synthesis,
            select=select,
        ),
        on_outcome,
    )
    return CheckReport(
        built.model,
        built.seconds,
        tuple(o for o in outcomes if not isinstance(o, PropertyError)),
        warnings,
        tuple(o for o in outcomes if isinstance(o, PropertyError)),
        tuple(outcomes),
    )


def _check_arguments(
    options: CheckOptions,
    property_files: Sequence[str | Path],
    properties: Sequence[str | Property],
    strategies: StrategySources | None,
    full_observation: bool,
    build_options: BuildOptions,
    synthesis: SynthesisOptions | None,
) -> tuple[tuple[str | Path, ...], tuple[str | Property, ...], BuildOptions,
           SynthesisOptions | None]:
    """:func:`check`'s arguments validated (InputError naming the argument), with exact mode's
    build options and the synthesis budget's start (here, unless the caller set it: building the
    model is inside the first synthesised property's budget)."""
    if synthesis is not None:
        from posgmc.synthesis.options import SynthesisOptions

        _typed(synthesis, SynthesisOptions, "synthesis")
    if synthesis is not None and synthesis.started is None:
        synthesis = dataclasses.replace(synthesis, started=time.perf_counter())
    _typed(options, CheckOptions, "options")
    files = _paths(property_files, "property_files")
    items = _property_items(properties)
    if strategies is not None:
        _strategy_sources(strategies)
    if options.exact:
        if strategies or full_observation:
            raise InputError(
                "exact mode checks dtmcs, mdps and smgs, not given strategies or full-observation "
                "bounds",
                hint="drop --exact, or drop --strategy / --full-observation",
            )
        build_options = dataclasses.replace(build_options, exact=True)
    return files, items, build_options, synthesis


def _build_for_check(
    session: Session,
    property_files: Sequence[str | Path],
    properties: Sequence[str | Property],
    build_options: BuildOptions,
) -> BuiltModel:
    """The model built for :func:`check`, after what can be reported without building it:
    constants no file declares, unreadable or unparsable property files."""
    _check_constant_names(session, property_files)
    parse_properties(session, files=property_files, texts=properties)
    return build(session, options=build_options, allow_extra_constants=True)


def _strategy_warnings(
    model: ExplicitModel, strategies: Mapping[str, FiniteStateStrategy] | None
) -> tuple[str, ...]:
    """What binding the given strategies to the model warns about (bound once here for the
    warnings; cheap whole-array work)."""
    if not strategies:
        return ()
    from posgmc.strategies.binding import bind

    return tuple(w for fss in strategies.values() for w in bind(model, fss).warnings)


def _outcomes(
    checked: Iterator[tuple[Property, PropertyResult | PosgmcError]],
    on_outcome: Callable[[PropertyResult | PropertyError], None] | None,
) -> list[PropertyResult | PropertyError]:
    """Each property's result, or its error with the property's text, in order; each handed to
    ``on_outcome`` as soon as it is known."""
    outcomes: list[PropertyResult | PropertyError] = []
    for prop, outcome in checked:
        outcomes.append(
            PropertyError(prop.text or format_expr(prop.expr), outcome)
            if isinstance(outcome, PosgmcError) else outcome
        )
        if on_outcome is not None:
            on_outcome(outcomes[-1])
    return outcomes


def _check_constant_names(session: Session, property_files: Sequence[str | Path]) -> None:
    """A value for a name that no file declares is reported once, before anything is built."""
    if session.syntax is None or not session.constants:
        return
    from posgmc.semantics.analysis import unknown_constant_errors

    decls = list(session.syntax.constants)
    for f in property_files:
        try:
            decls += list(parser.parse_properties(_read(f), file=str(f)).constants)
        except PosgmcError:
            return  # the file's own error is reported where it is parsed
    errors = unknown_constant_errors(
        session.constants,
        [c.name for c in decls],
        [c.name for c in decls if c.value is None],
        where="the model or the properties",
    )
    if errors:
        raise errors[0] if len(errors) == 1 else MultipleErrors(errors)


@deep_stack
def synthesize(
    session: Session,
    prop: str,
    *,
    memory: int | Sequence[int] | Mapping[str, int | Sequence[int]] | None = None,
    timeout: float | None = None,
    seed: int = 0,
    adversaries: int = 10,
    jobs: int = 1,
    effort: float = 1.0,
    executor: Literal["local", "ray"] = "local",
    ray_address: str | None = None,
    zero_based_players: bool = False,
    build_options: BuildOptions = BuildOptions(),
    built: BuiltModel | None = None,
    gap: float | str | None = None,
) -> PropertyResult:
    """Synthesise a finite-state strategy for the coalition of ``prop`` on a partially observable
    model, and verify it (docs/synthesis.md).

    Args:
        session: from :func:`load` (a ``pomdp`` or ``posg``, or a DRN POSMG).
        prop: one ``P`` or ``R`` query, e.g. ``'<<rover>> Pmax=? [ F "goal" ]'``.
        memory: the decision maker's memory sizes (``2`` or ``(1, 2, 3)``), or sizes by player
            name (``{"rover": (1, 2), "attacker": 2}``: the adversary's strategies are enumerated
            with its largest size). Default: 1..3 for the decision maker, 1 for the adversary,
            and on a pomdp a belief-based controller with as many nodes as it needs (sizes
            given bound the memory).
        timeout: a wall-clock cap in seconds on the whole synthesis of the property (None: none);
            when it binds, ``synthesis["cut"]`` is "timeout" and the numbers, still proven, may
            depend on the machine.
        seed: random seed (the search is deterministic given the model, the property, the
            options and the seed: its extent is a work budget, docs/synthesis.md).
        adversaries: how many of the strongest enumerated adversary strategies the defence is
            composed against (0: no adversary phases).
        jobs: workers for independent evaluations (the results do not depend on it).
        effort: the multiplier of every synthesis phase's work budget (1: the defaults).
        executor: where they run: ``"local"`` processes or ``"ray"`` actors on the Ray cluster
            at ``ray_address`` (``HOST:PORT``; None: Ray's ``RAY_ADDRESS``, else a Ray started
            for this process; ``pip install 'posgmc[ray]'``; docs/scale.md).
        gap: refine the optimum bracket until ``upper - lower`` is at most this (a number, or a
            percentage such as ``"5%"`` of the larger side) or the budget ends; the bound side
            then gets a share of ``timeout``. None: a little time on top of it.

    Returns:
        The result: ``guaranteed`` (against every adversary), ``vs_fss_adversary``,
        ``upper_bound``, ``full_observation``, each with proven bounds; ``optimum`` (proven
        bounds on the best value any strategy achieves, :class:`~posgmc.checking.results.
        Optimum`); ``strategies`` (the
        decision maker's, then the worst adversary strategy found, then — when
        ``vs_fss_adversary`` is about it — the composed defence); ``synthesis`` (statistics).

    Raises:
        PosgmcError: the model, the property, or an objective synthesis does not cover.
    """
    from posgmc.synthesis.options import Gap, SynthesisOptions, memory_sizes

    session = _session(session)
    if not isinstance(prop, str):
        raise InputError(f"prop must be a property text, got {type(prop).__name__}")
    # every argument checked (SynthesisOptions names the field: timeout, effort, seed, jobs, ...)
    # before anything is built
    if gap is None or isinstance(gap, str):
        requested = None if gap is None else Gap.parse(gap)
    elif isinstance(gap, (int, float)) and not isinstance(gap, bool):
        requested = Gap(float(gap))
    else:
        raise InputError(f"gap must be a number or a percentage string such as '5%', got {gap!r}")
    options = SynthesisOptions(timeout=timeout, seed=seed, adversaries=adversaries, jobs=jobs,
                               effort=effort, executor=executor, ray_address=ray_address,
                               belief=None if memory is None else False, gap=requested)
    if isinstance(memory, Mapping):
        for p in memory:
            if not isinstance(p, str):
                raise InputError(f"memory must map player names (strings) to sizes, got the key "
                                 f"{p!r}")
        options = dataclasses.replace(options, player_memory=tuple(sorted(
            (p, memory_sizes(v, f"memory[{p!r}]")) for p, v in memory.items())))
    elif memory is not None:
        options = dataclasses.replace(options, memory=memory_sizes(memory, "memory"))
    report = check(session, properties=[prop], build_options=build_options,
                   zero_based_players=zero_based_players, built=built, synthesis=options)
    outcome = report.outcomes[0]
    if isinstance(outcome, PropertyError):
        raise outcome.error
    if outcome.guaranteed is None:
        raise UnsupportedError(
            f"{session.path or 'the model'} is not partially observable: nothing to synthesise",
            hint="use check(): its value is the optimum, with a memoryless strategy",
        )
    return outcome


@deep_stack
def load_strategies(
    strategies: StrategySources, *, model: ExplicitModel | None = None
) -> dict[str, FiniteStateStrategy]:
    """Strategies by player name, files read (a file's own player must be the one it is given for).
    A file is ``posgmc-fss/1`` or the memoryless strategy of ``check --export-strategy``, read
    against ``model`` when given (:func:`~posgmc.strategies.files.read_strategy_for`).

    Raises:
        InputError, StrategyError: unreadable or invalid files, or a file for another player.
    """
    from posgmc.strategies.files import read_strategy, read_strategy_for
    from posgmc.strategies.fss import FiniteStateStrategy, StrategyError

    _strategy_sources(strategies)
    out: dict[str, FiniteStateStrategy] = {}
    for player, given in strategies.items():
        if isinstance(given, FiniteStateStrategy):
            fss = given
        elif model is not None:
            fss = read_strategy_for(given, model, player=player)
        else:
            fss = read_strategy(given, player=player)
        # a pomdp's one player has no name; its strategy file is written as agent.json and
        # given back as --strategy agent=...
        if player is not None and fss.player != player and not (
                player == "agent" and fss.player == ""):
            raise StrategyError(
                f"the strategy is player {fss.player!r}'s, given for player {player!r}",
                path="player",
                file=fss.source,
            )
        out[fss.player] = fss
    return out



def _strategy_sources(strategies: object) -> None:
    """``strategies`` maps player names (or None: the file's own player) to strategies or
    strategy files.

    Raises:
        InputError: anything else, naming the argument and the entry.
    """
    from posgmc.strategies.fss import FiniteStateStrategy

    if not isinstance(strategies, Mapping):
        raise InputError(
            f"strategies must map player names to strategies, got {type(strategies).__name__}",
            hint='e.g. strategies={"rover": "rover.json"}',
        )
    for player, given in strategies.items():
        if player is not None and not isinstance(player, str):
            raise InputError(f"strategies: a player is named by a string, got {player!r}")
        if not isinstance(given, (FiniteStateStrategy, str, Path)):
            raise InputError(
                f"strategies[{player!r}] must be a FiniteStateStrategy or a strategy file's path, "
                f"got {type(given).__name__}",
                hint="decode a bytes path first" if isinstance(given, bytes) else None,
            )


def _strategy_path(path: object, what: str) -> str | Path:
    if not isinstance(path, (str, Path)):
        raise InputError(f"{what} must be a file path (str or Path), got {type(path).__name__}",
                         hint="decode a bytes path first" if isinstance(path, bytes) else None)
    return path


# -- strategies: files, simulation ------------------------------------------------------------


def load_strategy(path: str | Path, *, player: str | None = None) -> FiniteStateStrategy:
    """Read a ``posgmc-fss/1`` strategy file, or the memoryless strategy file of ``check
    --export-strategy`` (``player``: whose, when it holds several players'); errors carry the
    file and JSON path.

    Raises:
        InputError: ``path`` is not a path, or the file cannot be read or is not JSON.
        StrategyError: not a valid strategy (with its JSON path).
    """
    from posgmc.strategies.files import read_strategy

    return read_strategy(_strategy_path(path, "path"), player=player)


def save_strategy(strategy: FiniteStateStrategy, path: str | Path) -> None:
    """Write a strategy as a ``posgmc-fss/1`` file (atomically).

    Raises:
        InputError: ``strategy`` is not a strategy or ``path`` not a path (a file named ``None``
            was written before), or the file cannot be written.
    """
    from posgmc.strategies.files import write_strategy
    from posgmc.strategies.fss import FiniteStateStrategy

    _typed(strategy, FiniteStateStrategy, "strategy")
    write_strategy(strategy, _strategy_path(path, "path"))


@deep_stack
def simulate(
    session: Session,
    prop: str,
    *,
    strategies: StrategySources | None = None,
    runs: int = 10_000,
    seed: int = 0,
    max_steps: int = 10_000,
    opponent: str = "uniform",
    trace: bool = False,
    zero_based_players: bool = False,
    build_options: BuildOptions = BuildOptions(),
) -> Simulation:
    """Estimate a property by simulation under the given strategies (see
    :mod:`posgmc.strategies.simulate`); players without one play uniformly, or their
    full-observation optimum with ``opponent="best"``.

    ``estimate`` is None when runs reached ``max_steps`` undecided (the interval covers them).

    Raises:
        InputError, StrategyError: bad arguments (naming them), model, property or strategy
            files.
        UnsupportedError: a property simulation does not estimate.
        LimitError: ``runs`` whose arrays would not fit in the memory available.
    """
    from posgmc.strategies.simulate import Simulation  # noqa: F401
    from posgmc.strategies.simulate import simulate as run

    session = _session(session)
    if not isinstance(prop, str):
        raise InputError(f"prop must be a property text, got {type(prop).__name__}")
    for name, value, least in (("runs", runs, 1), ("max_steps", max_steps, 0), ("seed", seed, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            raise InputError(f"{name} must be an int of at least {least}, got {value!r}")
    if opponent not in ("uniform", "best"):
        raise InputError(f"opponent must be 'uniform' or 'best', got {opponent!r}")
    if strategies is not None:
        _strategy_sources(strategies)
    built = build(session, options=build_options, allow_extra_constants=True)
    loaded = load_strategies(strategies, model=built.model) if strategies else {}
    _, (parsed,) = parse_properties(session, texts=[prop])
    src = SourceText(prop, "<--prop 1>")
    try:
        expr = parsed.expr
        if session.syntax is not None and built.flat is not None:
            (cp,) = sem.instantiate_properties(
                PropertiesFile(properties=(parsed,)), built.flat, model=session.syntax,
                constants=session.constants, zero_based_players=zero_based_players,
            )
            expr = cp.expr
        resolver = _resolver(built.model, zero_based_players)
        if expr is parsed.expr:
            resolve_queries(expr, resolver)  # an explicit model: see _check_one
        return run(
            built.model, expr, loaded, text=prop,
            coalition_of=resolver.coalition_of, scalar=_scalar,
            runs=runs, seed=seed, max_steps=max_steps, opponent=opponent, trace=trace,
        )
    except MultipleErrors as e:
        raise _attach(e.errors[0] if len(e.errors) == 1 else e, src) from None
    except PosgmcError as e:
        raise _attach(e, src) from None
