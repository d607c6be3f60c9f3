"""The commands about results and strategies: ``test`` (PRISM's RESULT convention for CI),
``simulate`` and ``show-strategy``."""

from __future__ import annotations

import dataclasses
import json
from typing import TYPE_CHECKING, Any

import click

from posgmc.cli.constants import const_text, expand_constants, single_constants
from posgmc.cli.group import main
from posgmc.cli.options import (
    EXIT_OK,
    EXIT_PROPERTY_FALSE,
    common,
    effort_option,
    full_observation_option,
    memory_option,
    nonnegative_finite,
    seed_option,
    strategy_options,
    synthesis_options,
    timeout_option,
    zero_based_players_option,
)
from posgmc.cli.printing import fmt
from posgmc.cli.running import guard
from posgmc.errors import InputError

if TYPE_CHECKING:
    from posgmc.api import Session

__all__ = ["test", "simulate", "show_strategy"]


@main.command("test")
@click.argument("model", type=click.Path(dir_okay=False))
@click.argument("props", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--tolerance", type=float, default=1e-5, show_default=True,
              callback=lambda _c, _p, v: nonnegative_finite(v, "--tolerance"),
              help="Relative tolerance for numbers (PRISM's test mode: 1e-5).")
@click.option("--junit", "junit", type=click.Path(dir_okay=False), default=None,
              help="Also write a JUnit XML report (one test case per checked property).")
@click.option(
    "--exact", is_flag=True, help="PRISM's -exact: rational arithmetic, results compared exactly."
)
@full_observation_option
@click.option("--strategy", "strategy_files", multiple=True, metavar="PLAYER=FILE",
              help="A player's finite-state strategy (posgmc-fss/1 JSON); repeatable.")
@zero_based_players_option
@memory_option
@timeout_option
@effort_option
@seed_option
@common
def test(
    model: str,
    props: tuple[str, ...],
    tolerance: float,
    junit: str | None,
    exact: bool,
    full_observation: bool,
    strategy_files: tuple[str, ...],
    zero_based_players: bool,
    memory: tuple[str, ...],
    timeout: float | None,
    effort: float,
    seed: int,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Check every property of PROPS that has a // RESULT line against it (PRISM's -test)."""
    import time

    from posgmc import api
    from posgmc.checking.expected import expected_for, grade
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.compiler.options import BuildOptions
    from posgmc.io.junit import Case, write_junit

    def run() -> int:
        swept, combos = expand_constants(consts)
        strategies = strategy_options(strategy_files) or None
        passed = failed = unchecked = 0
        cases: list[Case] = []
        for i, constants in enumerate(combos or [{}]):
            texts = {n: const_text(v) for n, v in constants.items()}
            label = ",".join(f"{n}={texts[n]}" for n in swept)
            session = api.load(model, constants=constants)
            if i == 0:
                _check_result_lines(session, props)  # before any work: nothing half-reported
            built = api.build(
                session, allow_extra_constants=True, options=BuildOptions(exact=exact)
            )
            loaded = api.load_strategies(strategies, model=built.model) if strategies else None
            started = time.perf_counter()
            for prop, outcome in api.iter_check(
                session, property_files=props, built=built, full_observation=full_observation,
                zero_based_players=zero_based_players, strategies=loaded,
                synthesis=synthesis_options(memory, timeout, seed, effort=effort),
                options=CheckOptions(exact=exact),
            ):
                seconds, started = time.perf_counter() - started, time.perf_counter()
                where = f"{prop.span.file}:{prop.span.line}"
                name = (prop.text or "") + (f" ({label})" if label else "")
                exp = expected_for(prop, texts)
                if exp is None:
                    unchecked += 1
                    cases.append(Case(name, where, seconds, skipped="no RESULT line"))
                    continue
                try:
                    verdict = grade(exp, outcome, tolerance=tolerance, constants=texts)
                except ValueError as e:

                    raise InputError(str(e), exp.span) from None
                if verdict.passed is None:
                    unchecked += 1
                    cases.append(Case(name, where, seconds, skipped="RESULT: ?"))
                    continue
                what = f" ({exp.number})" if exp.number else ""
                if verdict.passed:
                    passed += 1
                    click.echo(f"PASS {where}: {name}: {verdict.actual}{what}")
                    cases.append(Case(name, where, seconds))
                else:
                    failed += 1
                    message = f"expected {verdict.expected}{what}, got {verdict.actual}"
                    click.echo(f"FAIL {where}: {name}: {message}")
                    cases.append(Case(name, where, seconds, failure=message))
        if junit is not None:
            write_junit(junit, model, cases)
        summary = f"{passed} passed, {failed} failed"
        click.echo(summary + (f", {unchecked} skipped" if unchecked else ""))
        return EXIT_PROPERTY_FALSE if failed else EXIT_OK

    guard(debug, run, consts=consts)


def _check_result_lines(session: Session, props: tuple[str, ...]) -> None:
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


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--prop", "prop_text", required=True, metavar="TEXT",
              help="P=? [F φ], P=? [a U b], their F<=k forms, or R=? [F φ].")
@click.option("--strategy", "strategy_files", multiple=True, metavar="PLAYER=FILE",
              help="A player's finite-state strategy; repeatable, one per player.")
@click.option("--runs", type=click.IntRange(min=1), default=10_000, show_default=True,
              help="How many runs to sample.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random seed of the sampled runs (a non-negative integer).")
@click.option("--max-steps", type=click.IntRange(min=0), default=10_000, show_default=True,
              help="A run still undecided after this many steps counts as undecided.")
@click.option(
    "--opponent",
    type=click.Choice(["uniform", "best"]),
    default="uniform",
    show_default=True,
    help="How players without a strategy play: uniformly, or their full-observation optimum.",
)
@click.option("--trace", is_flag=True, help="Also print one sampled path, step by step.")
@zero_based_players_option
@click.option(
    "--json", "as_json", is_flag=True, help='Print {"estimate", "lower", "upper", "runs", ...}.'
)
@common
def simulate(
    model: str,
    prop_text: str,
    strategy_files: tuple[str, ...],
    runs: int,
    seed: int,
    max_steps: int,
    opponent: str,
    trace: bool,
    zero_based_players: bool,
    as_json: bool,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Estimate a property of MODEL by simulating runs under the given strategies."""
    from posgmc import api

    def run() -> int:
        session = api.load(model, constants=single_constants(consts, what="simulate"))
        result = api.simulate(
            session, prop_text, strategies=strategy_options(strategy_files) or None, runs=runs,
            seed=seed, max_steps=max_steps, opponent=opponent, trace=trace,
            zero_based_players=zero_based_players,
        )
        if as_json:
            doc = result.to_json()
            if trace:
                doc["trace"] = [dataclasses.asdict(t) for t in result.trace]
            click.echo(json.dumps(doc))
            return EXIT_OK
        interval = "Wilson 95 %" if result.kind == "probability" else "normal 95 %, an estimate"
        click.echo(
            f"{result.property}: {fmt(result.estimate)}  "
            f"[{fmt(result.lower)}, {fmt(result.upper)}]"
            f"  ({interval}; {result.runs} runs, seed {result.seed})"
        )
        if result.undecided:
            click.echo(f"  {result.undecided} of {result.runs} runs reached --max-steps "
                       "undecided" + ("" if result.estimate is not None else
                                      ": no point estimate; the interval "
                                      + ("counts them both ways" if result.kind == "probability"
                                         else "has no upper end (their rewards are unknown)")))
        if trace:
            _print_trace(result.trace)
        return EXIT_OK

    guard(debug, run, as_json=as_json, consts=consts)


def _print_trace(steps: Any) -> None:
    rows = [("step", "owner", "state", "observations", "memory", "action")]
    for t in steps:
        rows.append((
            str(t.step), t.owner or "agent", t.state,
            "; ".join(f"{p}: {o}" for p, o in t.observations) or "-",
            ", ".join(f"{p}={n}" for p, n in t.memory) or "-",
            t.action,
        ))
    widths = [max(len(r[i]) for r in rows) for i in range(6)]
    for r in rows:
        click.echo("  ".join(r[i].ljust(widths[i]) for i in range(6)).rstrip())


@main.command("show-strategy")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--model", "model_file", type=click.Path(dir_okay=False), default=None,
              help="Check the strategy against this model (observables, labels).")
@click.option("--dot", "dot_file", type=click.Path(dir_okay=False), default=None,
              help="Also write the strategy as a DOT graph.")
@click.option("--observation", "observation", default=None, metavar="NAME=V,...",
              help="Only the rules of the observations with these observable values, e.g. "
              "x=0,beacon=2 (a DRN model's observation by its id: --observation 3).")
@click.option("--node", "nodes", multiple=True, type=click.IntRange(min=0), metavar="N",
              help="Only the rules of memory node N (repeatable).")
@click.option("--compact", is_flag=True,
              help="In each memory node, one line for the observations with the same action "
              "and next memory, as ranges of their values.")
@common
def show_strategy(
    file: str, model_file: str | None, dot_file: str | None, observation: str | None,
    nodes: tuple[int, ...], compact: bool, consts: tuple[str, ...], debug: bool
) -> None:
    """Print a finite-state strategy as a table (memory x observation -> action -> memory); a
    memoryless strategy file of check --export-strategy shows each player's."""
    from posgmc import api
    from posgmc.strategies.files import read_strategies
    from posgmc.strategies.render import matching_observations, strategy_dot, strategy_table

    def run() -> int:
        wanted = _observation_filter(observation)
        strategies = read_strategies(file)
        if model_file is not None:
            from posgmc.strategies.binding import bind
            from posgmc.strategies.files import read_strategy_for

            constants = single_constants(consts, what="show-strategy")
            built = api.build(api.load(model_file, constants=constants))
            strategies = tuple(read_strategy_for(file, built.model, player=fss.player)
                               for fss in strategies)
            for fss in strategies:
                for w in bind(built.model, fss).warnings:
                    click.echo(f"warning: {w}", err=True)
        for fss in strategies:
            for n in nodes:
                if n >= fss.memory_size:
                    raise InputError(f"--node {n}: the strategy of player {fss.player!r} has "
                                     f"memory nodes 0..{fss.memory_size - 1}")
        for fss in strategies:
            try:
                chosen = matching_observations(fss, wanted) if wanted else None
            except InputError as e:
                raise InputError(f"--observation {observation}: {e.message}") from None
            click.echo(strategy_table(fss, nodes=sorted(set(nodes)) or None,
                                      observations=chosen, compact=compact), nl=False)
        if dot_file is not None:
            from posgmc.io.atomic import atomic_write_text

            if len(strategies) > 1:
                raise InputError("--dot draws one strategy; the file holds "
                                 f"{len(strategies)} players' (give check --strategy one)")
            atomic_write_text(dot_file, strategy_dot(strategies[0]))
        return EXIT_OK

    guard(debug, run, consts=consts)


def _observation_filter(text: str | None) -> dict[str, int]:
    """``x=0,beacon=2`` -> {"x": 0, "beacon": 2} (true/false as 1/0); ``3`` -> {"": 3}, an
    observation id.

    Raises:
        InputError: naming --observation, for a part that is not NAME=INTEGER or NAME=true/false.
    """
    if text is None:
        return {}
    if text.strip().isdigit():
        return {"": int(text)}
    out: dict[str, int] = {}
    for part in text.split(","):
        name, eq, value = (x.strip() for x in part.partition("="))
        value = {"true": "1", "false": "0"}.get(value, value)
        if not eq or not name or not value.lstrip("-").isdigit():
            raise InputError(f"--observation {text}: {part.strip()!r} is not NAME=VALUE "
                             "(an integer, true or false)", hint="e.g. --observation x=0,beacon=2")
        out[name] = int(value)
    return out
