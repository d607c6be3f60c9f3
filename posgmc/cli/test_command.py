"""The ``test`` command: PRISM's test mode. Every property with a ``// RESULT`` line is checked
against it, over model files, folders and the argument files beside them
(:mod:`posgmc.cli.test_suite`); output per run and a total, ``--junit`` over everything, exit 1
when a RESULT fails."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import click

from posgmc.cli.constants import const_text, expand_constants
from posgmc.cli.group import main
from posgmc.cli.options import (
    EXIT_ERROR,
    EXIT_OK,
    EXIT_PROPERTY_FALSE,
    effort_option,
    executor_options,
    full_observation_option,
    memory_option,
    nonnegative_finite,
    placement_of,
    seed_option,
    select_option,
    selected,
    strategy_options,
    strict_option,
    synthesis_options,
    timeout_option,
    zero_based_players_option,
)
from posgmc.cli.running import guard
from posgmc.cli.test_suite import Run, discover
from posgmc.errors import InputError, PosgmcError
from posgmc.synthesis.fanout import each_result
from posgmc.synthesis.tasks import Placement

if TYPE_CHECKING:
    from posgmc.api import Session
    from posgmc.io.junit import Case

__all__ = ["test", "test_run"]

F = Callable[..., Any]

# the options a run takes, from the command line or from an argument file's line
_RUN_OPTIONS: list[Callable[[F], F]] = [
    click.option("--tolerance", type=float, default=1e-5, show_default=True,
                 callback=lambda _c, _p, v: nonnegative_finite(v, "--tolerance"),
                 help="Relative tolerance for numbers (PRISM's test mode: 1e-5)."),
    click.option("--exact", is_flag=True,
                 help="PRISM's -exact: rational arithmetic, decimal RESULT lines compared "
                 "exactly."),
    full_observation_option,
    click.option("--strategy", "strategy_files", multiple=True, metavar="PLAYER=FILE",
                 help="A player's finite-state strategy (posgmc-fss/1 JSON); repeatable."),
    zero_based_players_option,
    memory_option,
    timeout_option,
    effort_option,
    seed_option,
    select_option,
    strict_option,
    click.option("--const", "consts", multiple=True, metavar="N=4,p=0.9",
                 help="Values for undefined constants (PRISM syntax); ranges sweep."),
]


def _run_options(f: F) -> F:
    for option in reversed(_RUN_OPTIONS):
        f = option(f)
    return f


@click.command("args")
@_run_options
def _line(**_: Any) -> None:
    """An argument file's line, parsed with the same options as the command line."""


@main.command("test")
@click.argument("paths", nargs=-1, required=True, type=click.Path())
@click.option("--junit", "junit", type=click.Path(dir_okay=False), default=None,
              help="Also write a JUnit XML report (one test case per checked property, over "
              "every run).")
@_run_options
@executor_options
@click.option("--debug", is_flag=True, help="Show Python tracebacks for errors.")
@click.pass_context
def test(ctx: click.Context, /, paths: tuple[str, ...], junit: str | None, debug: bool,
         **given: Any) -> None:
    """Check every property with a // RESULT line (PRISM's test mode). PATHS: a model and its
    properties files, a model alone (its MODEL.props, MODEL.*.props and, in a folder of one
    model, every .props file), or a folder searched for models; FILE.args beside a model or
    properties file holds one run per line (PRISM's -const, -exact, -prop, or posgmc's options)."""
    from posgmc.io.junit import write_junit

    def run() -> int:
        where = placement_of(given.pop("jobs"), given.pop("executor"), given.pop("ray_address"))
        runs = discover(paths)
        if not runs:
            raise InputError(f"no model with a properties file under {', '.join(paths)}")
        # every argument line read before any work; then each run a task on the executor (a
        # single run gives it to its synthesis instead), their outputs printed in run order
        single = len(runs) == 1
        calls = [(r, _merged(ctx, given, r), where if single else Placement(), single)
                 for r in runs]
        outcomes = each_result(test_run, calls, Placement() if single else where,
                               labels=[_title(r) for r in runs])
        total = _Tally()
        try:
            for r, (lines, tally, error) in zip(runs, outcomes):
                if not single:
                    click.echo(f"== {_title(r)}")
                for line in lines:
                    click.echo(line)
                if error is not None:
                    click.echo(error.render(), err=True)
                if not single:
                    click.echo(f"   {tally.summary()}")
                total.add(tally)
        finally:
            outcomes.close()
        if junit is not None:
            write_junit(junit, "posgmc test", total.cases)
        click.echo(total.summary())
        if total.errors:
            return EXIT_ERROR
        return EXIT_PROPERTY_FALSE if total.failed else EXIT_OK

    guard(debug, run, consts=given.get("consts", ()))


def _title(r: Run) -> str:
    args = " ".join(r.args)
    return f"{r.model} {r.props.name}" + (f" {args}" if args else "") + (
        f"  ({r.origin})" if r.origin else ""
    )


@dataclass
class _Tally:
    passed: int = 0
    failed: int = 0
    skipped: int = 0
    errors: int = 0
    cases: list[Case] = field(default_factory=list)

    def add(self, other: _Tally) -> None:
        self.passed += other.passed
        self.failed += other.failed
        self.skipped += other.skipped
        self.errors += other.errors
        self.cases += other.cases

    def summary(self) -> str:
        text = f"{self.passed} passed, {self.failed} failed"
        if self.skipped:
            text += f", {self.skipped} skipped"
        if self.errors:
            text += f", {self.errors} error{'s' if self.errors != 1 else ''}"
        return text


def _case(name: str, where: str, seconds: float, **outcome: str) -> Case:
    from posgmc.io.junit import Case

    return Case(name, where, seconds, **outcome)


def _merged(ctx: click.Context, given: dict[str, Any], r: Run) -> dict[str, Any]:
    """The command line's options, overridden by those the run's argument line sets (its
    constants are added to the command line's)."""
    if not r.args:
        return dict(given)
    try:
        line = _line.make_context("args", list(r.args))
    except click.ClickException as e:
        raise InputError(f"{r.origin}: {e.format_message()}") from None
    out = dict(given)
    for name, value in line.params.items():
        if line.get_parameter_source(name) is not click.core.ParameterSource.COMMANDLINE:
            continue
        out[name] = _merged_constants(given.get(name, ()), value) if name == "consts" else value
    return out


def _merged_constants(given: Sequence[str], line: Sequence[str]) -> tuple[str, ...]:
    """The command line's ``--const`` settings without the names the line sets, then the
    line's."""
    named = {part.split("=", 1)[0].strip() for text in line for part in text.split(",")}
    kept = [
        ",".join(p for p in text.split(",") if p.split("=", 1)[0].strip() not in named)
        for text in given
    ]
    return tuple(k for k in kept if k) + tuple(line)


def test_run(r: Run, o: dict[str, Any], placement: Any,
             single: bool) -> tuple[list[str], _Tally, PosgmcError | None]:
    """One run of ``posgmc test``: the lines it prints, its tally, and the error that stopped it
    (counted in the tally); ``single``: the command's only run, whose error is raised instead.
    Synthesis's jobs go where ``placement`` says. Plain data in and out: a task on any
    executor."""
    lines: list[str] = []
    tally = _Tally()
    try:
        # the only run prints its verdicts as they come (it runs in this process)
        _run_one(r, o, tally, click.echo if single else lines.append, placement)
    except PosgmcError as e:
        if single:
            raise
        tally.errors += 1
        tally.cases.append(_case(str(r.props), str(r.model), 0.0, error=e.message))
        return lines, tally, e
    return lines, tally, None


def _run_one(r: Run, o: dict[str, Any], tally: _Tally, say: Callable[[str], Any],
             placement: Any) -> None:
    """Check one model against one properties file with options ``o``, counting into
    ``tally``, each verdict given to ``say``."""
    from posgmc import api
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.compiler.options import BuildOptions

    model, props = str(r.model), (str(r.props),)
    exact: bool = o["exact"]
    swept, combos = expand_constants(o["consts"])
    strategies = strategy_options(o["strategy_files"]) or None
    for i, constants in enumerate(combos or [{}]):
        texts = {n: const_text(v) for n, v in constants.items()}
        label = ",".join(f"{n}={texts[n]}" for n in swept)
        session = api.load(model, constants=constants, strict=o["strict"])
        if i == 0:
            _check_result_lines(session, props)  # before any work: nothing half-reported
        built = api.build(session, allow_extra_constants=True, options=BuildOptions(exact=exact))
        loaded = api.load_strategies(strategies, model=built.model) if strategies else None
        started = time.perf_counter()
        for prop, outcome in api.iter_check(
            session, property_files=props, built=built, full_observation=o["full_observation"],
            zero_based_players=o["zero_based_players"], strategies=loaded,
            synthesis=synthesis_options(
                o["memory"], o["timeout"], o["seed"], jobs=placement.workers,
                effort=o["effort"], executor=placement.executor, ray_address=placement.address,
            ),
            options=CheckOptions(exact=exact), select=selected(o["select"]),
        ):
            seconds, started = time.perf_counter() - started, time.perf_counter()
            _grade(prop, outcome, texts, label, seconds, o["tolerance"], tally, say)


def _grade(prop: Any, outcome: Any, texts: dict[str, str], label: str, seconds: float,
           tolerance: float, tally: _Tally, say: Callable[[str], Any]) -> None:
    """One property's outcome against its RESULT line, counted, its verdict given to
    ``say``."""
    from posgmc.checking.expected import expected_for, grade

    where = f"{prop.span.file}:{prop.span.line}"
    name = (prop.text or "") + (f" ({label})" if label else "")
    exp = expected_for(prop, texts)
    if exp is None:
        tally.skipped += 1
        tally.cases.append(_case(name, where, seconds, skipped="no RESULT line"))
        return
    try:
        verdict = grade(exp, outcome, tolerance=tolerance, constants=texts)
    except ValueError as e:
        raise InputError(str(e), exp.span) from None
    if verdict.passed is None:
        tally.skipped += 1
        tally.cases.append(_case(name, where, seconds, skipped="RESULT: ?"))
        return
    what = f" ({exp.number})" if exp.number else ""
    if verdict.passed:
        tally.passed += 1
        say(f"PASS {where}: {name}: {verdict.actual}{what}")
        tally.cases.append(_case(name, where, seconds))
    else:
        tally.failed += 1
        message = f"expected {verdict.expected}{what}, got {verdict.actual}"
        say(f"FAIL {where}: {name}: {message}")
        tally.cases.append(_case(name, where, seconds, failure=message))


def _check_result_lines(session: Session, props: Sequence[str]) -> None:
    """Every RESULT line of the property files is well formed (InputError with its position)."""
    from posgmc import api
    from posgmc.checking.expected import check_form

    parsed, _ = api.parse_properties(session, files=props)
    model_constants = [c.name for c in session.syntax.constants] if session.syntax else []
    for pf, _src in parsed:
        names = model_constants + [c.name for c in pf.constants]
        for prop in pf.properties:
            for exp in prop.expected:
                try:
                    check_form(exp.text.strip(), names)
                except ValueError as e:
                    raise InputError(str(e), exp.span) from None

