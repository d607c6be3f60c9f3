"""The ``check`` command: properties on a model, swept over constants, with synthesis, given
strategies, exports, JUnit and plots; the work happens in :mod:`posgmc.api`."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any, Literal

import click

from posgmc.checking.results import Bound, PropertyResult
from posgmc.cli.constants import const_json, const_text, expand_constants
from posgmc.cli.group import main
from posgmc.cli.model_commands import build_options
from posgmc.cli.options import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_PROPERTY_FALSE,
    common,
    effort_option,
    executor_options,
    full_observation_option,
    gap_option,
    memory_option,
    placement_of,
    positive_finite,
    progress_options,
    seed_option,
    select_option,
    selected,
    strategy_options,
    strict_option,
    synthesis_options,
    timeout_option,
    zero_based_players_option,
)
from posgmc.cli.printing import (
    fmt,
    interrupt_summary,
    json_report,
    outcome_json,
    print_header,
    print_outcome,
    print_report,
)
from posgmc.cli.progress_view import before_output, progress_mode, progress_view
from posgmc.cli.running import guard
from posgmc.cli.strategy_export import check_destination, point_of, synthesises, write_exports
from posgmc.errors import InputError
from posgmc.synthesis import progress
from posgmc.synthesis.budget import interrupted, interruptible
from posgmc.synthesis.fanout import Spread

__all__ = ["check", "check_point", "not_passed"]


BUILD_GRACE = 1.0
"""Seconds a model build may always take under a given --timeout."""


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.argument("props", nargs=-1, type=click.Path(dir_okay=False))
@click.option(
    "--prop", "prop_texts", multiple=True, metavar="TEXT", help="A property, as text (repeatable)."
)
@click.option(
    "--precision",
    type=float,
    callback=lambda _c, _p, v: positive_finite(v, "--precision"),
    default=1e-6,
    show_default=True,
    help="Stop iterating when the proven bounds are this close (absolute; see --relative).",
)
@click.option("--relative", is_flag=True, help="Precision is relative, not absolute.")
@click.option(
    "--method",
    type=click.Choice(["interval", "value", "policy", "exact"]),
    default="interval",
    show_default=True,
    help="interval: sound bounds; value: plain value iteration; policy/exact: exact solves.",
)
@click.option("--exact", is_flag=True,
              help="PRISM's -exact: build and solve in rational arithmetic; values as fractions "
              "(unbounded P[F]/P[U] and state formulas, small models).")
@full_observation_option
@click.option(
    "--strategy",
    "strategy_files",
    multiple=True,
    metavar="PLAYER=FILE",
    help="A player's finite-state strategy (posgmc-fss/1 JSON); repeatable, one per player.",
)
@zero_based_players_option
@memory_option
@click.option("--adversaries", type=click.IntRange(min=0), default=10, show_default=True,
              help="Synthesis: how many of the strongest enumerated adversary strategies the "
              "defence is composed against (0: no adversary phases).")
@executor_options
@timeout_option
@effort_option
@seed_option
@progress_options
@gap_option
@click.option("--export-strategy", type=click.Path(), default=None,
              help="Write the optimal memoryless strategy of the property's coalition as a "
              "posgmc-fss/1 .json file (one memory node; FILE.<player>.json each for a coalition "
              "of several); for a synthesised strategy, a directory receiving <player>.json. "
              "Several properties or sweep points get one each (FILE.prop2.N=5.json, "
              "DIR/prop2/N=5/), each printed.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (see docs/cli.md).")
@click.option("--json-lines", "json_lines", is_flag=True,
              help="Print one JSON object per line as soon as it is known: the model, then each "
              "result (see docs/cli.md).")
@click.option("--junit", "junit", type=click.Path(dir_okay=False), default=None,
              help="Also write a JUnit XML report: one test case per property.")
@click.option("--plot", "plot_file", type=click.Path(dir_okay=False), default=None,
              help="With one swept constant (--const B=0:4): draw each property against it "
              "(.png, .svg, .pdf; needs matplotlib).")
@click.option("--state-limit", type=click.IntRange(min=1), default=None,
              help="Stop building beyond this many states (an error naming the limit).")
@click.option("-v", "--verbose", is_flag=True,
              help="Synthesis: every number with its meaning, the search rounds, the phases' "
              "times and the adversary phases (the JSON always has them).")
@select_option
@strict_option
@common
def check(**settings: Any) -> None:
    """Check PROPS (files) and --prop properties on MODEL."""
    request = CheckRequest(**settings)

    def shown() -> int:
        mode = progress_mode(quiet=request.quiet, lines=request.progress_lines,
                             json_lines=request.json_lines)
        with progress_view(mode):
            return _run(request)

    with interruptible():
        guard(request.debug, shown, as_json=request.as_json or request.json_lines,
              consts=request.consts)


@dataclass(frozen=True)
class CheckRequest:
    """What ``check``'s command line asks for, one field per option (docs/cli.md)."""

    model: str
    props: tuple[str, ...]
    prop_texts: tuple[str, ...]
    precision: float
    relative: bool
    method: str
    exact: bool
    full_observation: bool
    strategy_files: tuple[str, ...]
    zero_based_players: bool
    memory: tuple[str, ...]
    adversaries: int
    jobs: int
    executor: Literal["local", "ray"]
    ray_address: str | None
    timeout: float | None
    effort: float
    seed: int
    progress_lines: bool
    quiet: bool
    gap: Any
    export_strategy: str | None
    as_json: bool
    json_lines: bool
    junit: str | None
    plot_file: str | None
    state_limit: int | None
    verbose: bool
    select: tuple[str, ...]
    strict: bool
    consts: tuple[str, ...]
    debug: bool


def _run(request: CheckRequest) -> int:
    """The command's phases: the options checked, each constant point checked (results shown as
    they come), then the reports that cover every point; the exit status."""
    swept, combos, strategies = _validated(request)
    # results are shown as they are computed (a killed run keeps what it printed), except
    # in the one-object --json and in sweep tables
    streaming = not request.as_json and len(combos or [{}]) == 1
    spread = Spread()
    rows, code = _check_points(request, swept, combos, strategies, streaming=streaming,
                               spread=spread)
    _write_reports(request, swept, rows, streaming=streaming, spread=spread)
    return code


def _validated(
    request: CheckRequest,
) -> tuple[list[str], list[dict[str, Any]], dict[str | None, str]]:
    """Every option checked before any work: (swept constants, one setting per point, the given
    strategies by player)."""
    r = request
    if not r.props and not r.prop_texts:
        raise click.UsageError("give a properties file or --prop TEXT")
    swept, combos = expand_constants(r.consts)
    if r.plot_file is not None:
        if not r.plot_file.lower().endswith((".png", ".svg", ".pdf")):
            raise InputError(f"{r.plot_file}: a plot is written as .png, .svg or .pdf")
        from posgmc.tradeoffs.plot import require_matplotlib

        require_matplotlib()  # before the sweep, not after it
        if len(swept) != 1:
            raise InputError("--plot draws properties against one swept constant; "
                             f"{len(swept)} are swept",
                             hint="give one constant a range, e.g. --const B=0:4")
    if r.export_strategy is not None:
        _check_export_extension(r.export_strategy, directory=None)
    strategies = strategy_options(r.strategy_files)
    if r.as_json and r.json_lines:
        raise click.UsageError("give --json or --json-lines, not both")
    if r.export_strategy is not None and strategies:
        raise click.UsageError("--export-strategy writes the strategy that check computes; "
                               "with --strategy the strategies are given, none is computed")
    return swept, [dict(c) for c in combos], strategies


def _check_points(
    request: CheckRequest,
    swept: list[str],
    combos: list[dict[str, Any]],
    strategies: dict[str | None, str],
    *,
    streaming: bool,
    spread: Spread,
) -> tuple[list[tuple[dict[str, Any], Any]], int]:
    """Each constant point checked, its strategies exported: (constants, report) per point, and
    the exit status so far. The points of a sweep are independent tasks on the executor
    (``--jobs``/``--executor``), their reports taken in sweep order, so that the output is that
    of one process; a single point gives the executor to its synthesis instead. Ctrl-C ends the
    loop after the point it cut short. ``spread``: filled in with where the points ran."""
    from posgmc import api
    from posgmc.synthesis.fanout import each_result
    from posgmc.synthesis.tasks import Placement

    r = request
    points = combos or [{}]
    where = placement_of(r.jobs, r.executor, r.ray_address)
    first = api.load(r.model, constants=points[0], strict=r.strict)
    if r.export_strategy is not None:
        # before any work: a destination that cannot be written is refused now, not after the
        # whole budget
        directory = synthesises(first, given_strategies=bool(strategies),
                                full_observation=r.full_observation)
        _check_export_extension(r.export_strategy, directory=directory)
        check_destination(r.export_strategy, directory=directory)
    # the model's text travels to the workers (a cluster's nodes need not see the file)
    text = first.source.text
    fanned = len(points) > 1
    inner = Placement() if fanned else where
    labels = [f"point {i + 1} of {len(points)} ("
              + ",".join(f"{n}={v}" for n, v in point_of(c, swept).items()) + ")"
              for i, c in enumerate(points)]
    rows: list[tuple[dict[str, Any], Any]] = []
    code = EXIT_OK
    reports = each_result(check_point, [(r, text, c, strategies, inner, streaming) for c in points],
                          where if fanned else Placement(), labels=labels, spread=spread,
                          phase="constant point")
    try:
        for constants, report in zip(points, reports):
            if report.errors:
                code = EXIT_ERROR
            elif code == EXIT_OK and any(not_passed(x) for x in report.results):
                code = EXIT_PROPERTY_FALSE
            rows.append((constants, report))
            if len(combos) > 1:
                # a sweep's table comes at the end: each point is reported as it completes
                label = ",".join(f"{n}={const_text(constants[n])}" for n in swept)
                progress.point_done(label, _headline(report), len(rows), len(combos))
            if r.export_strategy is not None and not report.errors:
                # a property that failed has said why; "no strategy to export" would hide it.
                # Each property and constant point gets its own destination
                for path in write_exports(r.export_strategy, report,
                                          point=point_of(constants, swept),
                                          several_points=len(combos) > 1,
                                          zero_based_players=r.zero_based_players):
                    click.echo(f"wrote {path.path}", err=r.as_json or r.json_lines)
                    if path.note:
                        click.echo(f"  note: {path.note}", err=r.as_json or r.json_lines)
    finally:
        reports.close()  # an early stop cancels the points still running
    if interrupted():
        # Ctrl-C: each property it cut short reported (and exported) its best verified defence;
        # no further property is checked, and a sweep's points not started (or, on Ray, running)
        # were cancelled: say which points finished, which were cut short, which not
        code = EXIT_INTERRUPTED
        if fanned:
            cancelled = [points[labels.index(name)] for name in spread.cancelled]
            click.echo(interrupted_points(rows, cancelled, swept), err=True)
    return rows, code


def interrupted_points(rows: list[tuple[dict[str, Any], Any]], cancelled: list[dict[str, Any]],
                       swept: list[str]) -> str:
    """What an interrupted sweep did: the points that finished (those the interrupt cut short
    report their best verified defence) and those cancelled."""
    def text(constants: dict[str, Any]) -> str:
        return ",".join(f"{n}={const_text(constants[n])}" for n in swept)

    cut = [text(c) for c, report in rows
           if any(not isinstance(o, tuple) and (o.synthesis or {}).get("cut") == "interrupt"
                  for o in report.outcomes)]
    return interrupt_summary([text(c) for c, _ in rows], cut, [text(c) for c in cancelled])


def check_point(request: CheckRequest, text: str, constants: dict[str, Any],
                strategies: dict[str | None, str], placement: Any, streaming: bool) -> Any:
    """One constant point of ``check``: the model (``text``, read from ``request.model``) with
    ``constants``, every property checked, the synthesis's jobs placed by ``placement``; its
    :class:`~posgmc.api.CheckReport`. Plain data in and out: a task of a sweep on any executor;
    ``streaming``: print the header and each result as they come (a single point, run here)."""
    from posgmc import api
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.engines.options import Method, SolverOptions

    r = request
    # the first synthesised property's --timeout counts from here: loading and building the
    # model are inside it
    loading = time.perf_counter()
    session = api.load(r.model, text=text, constants=constants, strict=r.strict)
    on_start, on_outcome = (
        _streamers(r.model, constants, r.json_lines, r.verbose) if streaming else (None, None)
    )
    return api.check(
        session,
        property_files=r.props,
        properties=r.prop_texts,
        options=CheckOptions(
            solver=SolverOptions(method=Method(r.method), precision=r.precision,
                                 relative=r.relative),
            keep_strategy=r.export_strategy is not None,
            exact=r.exact,
        ),
        build_options=build_options(
            r.state_limit, False, None,
            # a --timeout bounds the whole run, the build included, which is given at least
            # BUILD_GRACE: a tiny budget still reports what synthesis found on a small model
            # rather than no model at all
            deadline=None if r.timeout is None else loading + max(r.timeout, BUILD_GRACE)),
        full_observation=r.full_observation,
        zero_based_players=r.zero_based_players,
        strategies=strategies or None,
        synthesis=synthesis_options(r.memory, r.timeout, r.seed, r.adversaries,
                                    placement.workers, started=loading, effort=r.effort,
                                    executor=placement.executor,
                                    ray_address=placement.address, gap=r.gap),
        on_start=on_start,
        on_outcome=on_outcome,
        select=selected(r.select),
    )


def _write_reports(
    request: CheckRequest, swept: list[str], rows: list[tuple[dict[str, Any], Any]], *,
    streaming: bool, spread: Spread,
) -> None:
    """What covers every point: JUnit, the plot, and the one JSON object or the sweep table
    (a single point's results were shown as they came)."""
    r = request
    if not rows:  # interrupted before any point finished: nothing to report
        return
    if r.junit is not None:
        _write_check_junit(r.junit, r.model, swept, rows)
    if r.plot_file is not None:
        from posgmc.tradeoffs.plot import plot_sweeps
        from posgmc.tradeoffs.sweep import sweeps_of_check

        texts = [({n: const_text(v) for n, v in c.items()}, rep) for c, rep in rows]
        plot_sweeps(sweeps_of_check(swept[0], texts), r.plot_file)
    sweep = len(rows) + len(spread.cancelled) > 1
    if r.as_json or (r.json_lines and not streaming):
        click.echo(json.dumps(json_report(r.model, swept, rows, points=spread.to_json(),
                                          sweep=sweep)))
    elif not streaming:
        print_report(r.model, swept, rows, verbose=r.verbose, sweep=sweep)


def _headline(report: Any) -> Bound | None:
    """A point's headline number with its bounds, when it checked one property: the proven
    ``guaranteed`` of a synthesis or given strategies, else the numeric value."""
    if len(report.outcomes) != 1 or isinstance(report.outcomes[0], tuple):
        return None
    result: PropertyResult = report.outcomes[0]
    return result.headline


def _streamers(model: str, constants: dict[str, Any], json_lines: bool,  # type: ignore[no-untyped-def]
               verbose: bool = False):
    """(on_start, on_outcome) callbacks printing the header and each result as it comes (a
    note once per run)."""
    seen: set[str] = set()

    def start(built: Any, seconds: float, warnings: tuple[str, ...]) -> None:
        before_output()
        stats = built.statistics()
        if json_lines:
            click.echo(json.dumps({
                "model_file": model,
                "constants": {n: const_json(v) for n, v in constants.items()},
                "model": {k: stats[k] for k in ("type", "states", "choices", "transitions")},
                "build_seconds": round(seconds, 6),
                "warnings": list(warnings),
            }))
            return
        print_header(model, stats, seconds, warnings)

    def outcome(r: Any) -> None:
        before_output()
        if json_lines:
            click.echo(json.dumps(outcome_json(r)))
        else:
            print_outcome(r, verbose=verbose, seen=seen)

    return start, outcome


def _write_check_junit(
    path: str, model: str, swept: list[str], rows: list[tuple[dict[str, Any], Any]]
) -> None:
    """One test case per property (and constant setting): an error fails as an error, a false or
    undecided threshold or an unconverged result as a failure."""
    from posgmc.io.junit import Case, write_junit

    cases = []
    for constants, report in rows:
        label = ",".join(f"{n}={const_text(constants[n])}" for n in swept)
        for r in report.outcomes:
            if isinstance(r, tuple):
                cases.append(
                    Case(r[0] + (f" ({label})" if label else ""), model, error=r[1].message)
                )
                continue
            name = r.property + (f" ({label})" if label else "")
            failure = None
            if not_passed(r):
                failure = f"{r.property}: {fmt(r.value)}" + (
                    " (not converged)" if not r.converged
                    else " (not proven)" if r.guaranteed is not None and not r.sound else ""
                )
            cases.append(Case(name, model, r.seconds, failure=failure))
    write_junit(path, model, cases)


def _check_export_extension(path: str, *, directory: bool | None) -> None:
    """Strategies are written as JSON: a file named ``.json``, or a directory (no extension, or
    one that exists) for synthesised strategies; any other extension (``s.tra``) is refused before
    any work rather than given JSON, and so is a ``.json`` name where a synthesis writes a
    directory (``directory``: whether it does; None: not known yet).

    Raises:
        InputError: naming --export-strategy.
    """
    import os

    suffix = os.path.splitext(os.path.basename(path.rstrip("/" + os.sep)))[1].lower()
    if os.path.isdir(path) or not suffix:
        return
    if suffix != ".json":
        raise InputError(f"--export-strategy {path}: strategies are written as JSON, not "
                         f"{suffix}", hint="give a .json file (a model checker's memoryless "
                         "strategy) or a directory (synthesised strategies, <player>.json each)")
    if directory:
        raise InputError(f"--export-strategy {path}: a synthesis writes a directory (the "
                         "defence and the adversary strategy found, <player>.json each), not "
                         "one .json file", hint="give a directory name, e.g. --export-strategy "
                         f"{path[: -len(suffix)] or 'strategies'}/")


def not_passed(r: Any) -> bool:
    """A threshold that is false or undecided, a result whose iteration did not converge, or a
    printed number that is not proven (plain value iteration, an LP's floating-point optimum, a
    strategy number whose check was cut short): exit 0 only when every printed number is."""
    return (r.value is False or (r.value is None and r.kind.value == "boolean")
            or not r.converged or not r.sound)
