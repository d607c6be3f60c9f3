"""The ``posgmc`` command: options become typed configuration, the work happens in
:mod:`posgmc.api`.

Exit status (fixed, documented in docs/cli.md):

* 0 — success; for ``check``, every threshold property holds at the initial state(s);
* 1 — ``check`` only: some threshold property does not hold or is undecided (``unknown``), or a
  result did not converge;
* 2 — bad input (model, properties, constants, options) or any other error;
* 130 — interrupted (Ctrl-C), as shells report it.
"""

from __future__ import annotations

import json
import sys
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import click

from posgmc import __version__
from posgmc.errors import InputError, MultipleErrors, PosgmcError

if TYPE_CHECKING:
    from posgmc.api import CheckReport
    from posgmc.semantics.constants import ConstRange, ConstSetting, UserConstant

EXIT_OK = 0
EXIT_PROPERTY_FALSE = 1
EXIT_ERROR = 2
EXIT_INTERRUPTED = 130

F = TypeVar("F", bound=Callable[..., Any])


def _fail(error: PosgmcError | Exception, *, debug: bool) -> NoReturn:
    if isinstance(error, PosgmcError):
        click.echo(error.render(), err=True)
    else:
        click.echo(f"internal error: {type(error).__name__}: {error}", err=True)
        click.echo(
            "  hint: this is a bug in posgmc; rerun with --debug for the traceback", err=True
        )
    if debug:
        traceback.print_exception(error, file=sys.stderr)
    sys.exit(EXIT_ERROR)


def _show_const_text(error: PosgmcError, consts: Sequence[str]) -> None:
    """Errors that point into a --const option get its text to show under the caret."""
    from posgmc.errors import SourceText

    names = ["--const"] if len(consts) == 1 else [f"--const #{i + 1}" for i in range(len(consts))]
    sources = {n: SourceText(t, n) for n, t in zip(names, consts)}
    for e in error.errors if isinstance(error, MultipleErrors) else [error]:
        if e.span is not None and e.span.file in sources and e.source is None:
            e.with_source(sources[e.span.file])


def error_json(error: PosgmcError) -> list[dict[str, Any]]:
    """The machine-readable form of an input error: one object per error, with its position."""
    errors = error.errors if isinstance(error, MultipleErrors) else [error]
    out = []
    for e in errors:
        span = e.span
        out.append({
            "file": span.file if span else None,
            "line": span.line if span else None,
            "column": span.column if span else None,
            "message": e.message,
            "hint": e.hint,
        })
    return out


def _guard(
    debug: bool, fn: Callable[[], int], *, as_json: bool = False, consts: Sequence[str] = ()
) -> NoReturn:
    from posgmc.deep import deep_call

    try:
        code = deep_call(fn)
    except PosgmcError as e:
        _show_const_text(e, consts)
        if as_json:  # machines get the errors on stdout too, in the shape of docs/cli.md
            click.echo(json.dumps({"errors": error_json(e)}))
        _fail(e, debug=debug)
    except (click.exceptions.Exit, click.ClickException):
        raise
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly, as Unix tools do
        sys.stderr.close()
        sys.exit(EXIT_OK)
    except Exception as e:  # noqa: BLE001 - the CLI never shows a bare traceback
        _fail(e, debug=debug)
    sys.exit(code)


# -- constants: PRISM's --const N=4,p=0.9 and sweeps N=1:1:5 -----------------------------------


def expand_constants(
    values: Sequence[str],
) -> tuple[list[str], list[dict[str, ConstSetting | UserConstant]]]:
    """``("N=4,p=0.9", "k=0:5")`` -> (swept names, one name->setting dict per combination).

    Raises:
        ConstantError: malformed text, a name given twice (with the position in the option's text).
    """
    from posgmc.errors import ConstantError
    from posgmc.semantics.constants import ConstRange, expand_sweep, parse_const_assignments

    merged: dict[str, ConstSetting | ConstRange] = {}
    for i, text in enumerate(values):
        source = "--const" if len(values) == 1 else f"--const #{i + 1}"
        for name, setting in parse_const_assignments(text, source=source).items():
            if name in merged:
                raise ConstantError(f"constant '{name}' is given twice", setting.span)
            merged[name] = setting
    swept = [n for n, v in merged.items() if isinstance(v, ConstRange)]
    return swept, expand_sweep(merged) if merged else []


def _const_text(setting: Any) -> str:
    from posgmc.semantics.evaluate import format_value

    value = getattr(setting, "value", setting)
    return value if isinstance(value, str) else format_value(value)


def _const_json(setting: Any) -> Any:
    """A constant's value in JSON: a number or a Boolean as JSON has them (``"start": 3``, not
    ``"3"``), text only for what is neither (e.g. a fraction ``1/3``)."""
    import math

    value = getattr(setting, "value", setting)
    if not isinstance(value, str):
        return value if isinstance(value, (bool, int, float)) else _const_text(value)
    text = value.strip()
    if text in ("true", "false"):
        return text == "true"
    for parse in (int, float):
        try:
            number = parse(text)
        except ValueError:
            continue
        if isinstance(number, int) or math.isfinite(number):
            return number
    return text


def _positive_finite(value: float, option: str) -> float:
    """A precision must be a positive finite number (nan and inf would never stop iterating)."""
    import math

    if not (math.isfinite(value) and value > 0):
        raise click.BadParameter(f"{value!r} is not a positive finite number", param_hint=option)
    return value


# -- shared options --------------------------------------------------------------------------------


def _common(f: F) -> F:
    f = click.option("--debug", is_flag=True, help="Show Python tracebacks for errors.")(f)
    f = click.option(
        "--const",
        "consts",
        multiple=True,
        metavar="N=4,p=0.9",
        help="Values for undefined constants (PRISM syntax); ranges N=1:5 or N=1:1:5 sweep.",
    )(f)
    return f


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="posgmc")
def main() -> None:
    """posgmc: model checking and strategy synthesis for partially observable stochastic games."""


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.argument("props", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--prop", "prop_texts", multiple=True, metavar="TEXT", help="A property, as text.")
@click.option(
    "--zero-based-players", is_flag=True, help="Numeric coalitions count from 0 (Storm/PAYNT)."
)
@click.option(
    "--each",
    is_flag=True,
    help="Every argument is a model (as pre-commit passes changed files); a properties file "
    "beside it with the same name and .props is checked with it; .props arguments are skipped.",
)
@_common
def lint(
    model: str,
    props: tuple[str, ...],
    prop_texts: tuple[str, ...],
    zero_based_players: bool,
    each: bool,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Parse and check MODEL and PROPS files without building; print every error."""
    from pathlib import Path

    from posgmc import api

    jobs: list[tuple[str, tuple[str, ...]]] = [(model, props)]
    if each:
        jobs = []
        for path in (model, *props):
            if path.endswith(".props"):
                continue
            beside = Path(path).with_suffix(".props")
            jobs.append((path, (str(beside),) if beside.exists() else ()))

    def run() -> int:
        _, combos = expand_constants(consts)
        errors: list[PosgmcError] = []
        for constants in combos or [{}]:
            for job_model, job_props in jobs:
                for e in api.lint(
                    job_model,
                    job_props,
                    constants=constants,
                    property_texts=prop_texts,
                    zero_based_players=zero_based_players,
                ):
                    errors += e.errors if isinstance(e, MultipleErrors) else [e]
        seen = set()
        for e in errors:
            text = e.render()
            if text not in seen:
                seen.add(text)
                click.echo(text, err=True)
        if errors:
            click.echo(f"{len(seen)} error(s)", err=True)
            return EXIT_ERROR
        for job_model, _ in jobs:
            click.echo(f"{job_model}: ok")
        return EXIT_OK

    _guard(debug, run)


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option(
    "--export",
    nargs=2,
    type=(click.Choice(["drn", "prism", "dot"]), click.Path(dir_okay=False)),
    metavar="FORMAT FILE",
    help="Write the explicit model: drn (Storm), prism (.tra/.sta/.lab...), dot.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the statistics as one JSON object.")
@click.option(
    "--state-limit", type=click.IntRange(min=1), default=None, help="Stop beyond this many states."
)
@click.option(
    "--no-fix-deadlocks", is_flag=True, help="Deadlock states are an error instead of self-loops."
)
@click.option("--progress/--no-progress", default=None, help="Report build progress on stderr.")
@_common
def build(
    model: str,
    export: tuple[str, str] | None,
    as_json: bool,
    state_limit: int | None,
    no_fix_deadlocks: bool,
    progress: bool | None,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Build MODEL's explicit state space and print its statistics."""
    from posgmc import api

    def run() -> int:
        _, combos = expand_constants(consts)
        if len(combos) > 1:
            raise click.BadParameter(
                "build takes single constant values, not ranges", param_hint="'--const'"
            )
        session = api.load(model, constants=combos[0] if combos else {})
        built = api.build(session, options=_build_options(state_limit, no_fix_deadlocks, progress))
        stats = built.model.statistics()
        stats["build_seconds"] = round(built.seconds, 6)
        if export is not None:
            _export(built.model, export[0], export[1])
            stats["exported"] = {"format": export[0], "file": export[1]}
        for w in built.warnings:
            click.echo(f"warning: {w}", err=True)
        if as_json:
            click.echo(json.dumps(stats))
        else:
            _print_stats(model, stats)
        return EXIT_OK

    _guard(debug, run, as_json=as_json, consts=consts)


def _build_options(state_limit: int | None, no_fix_deadlocks: bool, progress: bool | None):  # type: ignore[no-untyped-def]
    from posgmc.compiler import BuildOptions, ProgressMode

    kwargs: dict[str, Any] = {"fix_deadlocks": not no_fix_deadlocks}
    if state_limit is not None:
        kwargs["state_limit"] = state_limit
    if progress is not None:
        kwargs["progress"] = ProgressMode.ALWAYS if progress else ProgressMode.NEVER
    return BuildOptions(**kwargs)


def _export(model: Any, fmt: str, path: str) -> None:
    if fmt == "drn":
        from posgmc.io.drn import write_drn

        write_drn(model, path)
    elif fmt == "prism":
        from posgmc.io.prism_explicit import write_prism_explicit

        base = path
        for ext in (".tra", ".sta", ".lab"):
            if base.endswith(ext):
                base = base[: -len(ext)]
        write_prism_explicit(model, base)
    else:
        from posgmc.io.dot import write_dot

        write_dot(model, path)


def _print_stats(model: str, stats: dict[str, Any]) -> None:
    click.echo(f"Model:        {model}")
    click.echo(f"Type:         {stats['type']}")
    click.echo(
        f"States:       {stats['states']}  (initial: {stats['initial_states']}, deadlocks fixed: "
        f"{stats['deadlocks']})"
    )
    click.echo(f"Choices:      {stats['choices']}")
    click.echo(f"Transitions:  {stats['transitions']}")
    if "players" in stats:
        players = ", ".join(f"{n}: {c} states" for n, c in stats["players"].items())
        click.echo(f"Players:      {players}")
    if "observations" in stats:
        obs = ", ".join(f"{n}: {c}" for n, c in stats["observations"].items())
        click.echo(f"Observations: {obs}")
    click.echo(f"Labels:       {', '.join(stats['labels'])}")
    rewards = ", ".join(str(n) if n is not None else "(unnamed)" for n in stats["reward_models"])
    click.echo(f"Rewards:      {rewards or '-'}")
    click.echo(f"Build time:   {stats['build_seconds']:.3f} s")
    if "exported" in stats:
        click.echo(f"Exported:     {stats['exported']['format']} -> {stats['exported']['file']}")


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.argument("props", nargs=-1, type=click.Path(dir_okay=False))
@click.option(
    "--prop", "prop_texts", multiple=True, metavar="TEXT", help="A property, as text (repeatable)."
)
@click.option(
    "--precision",
    type=float,
    callback=lambda _c, _p, v: _positive_finite(v, "--precision"),
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
@click.option(
    "--full-observation", is_flag=True, help="pomdp/posg: answer the full-observation bound."
)
@click.option(
    "--strategy",
    "strategy_files",
    multiple=True,
    metavar="PLAYER=FILE",
    help="A player's finite-state strategy (posgmc-fss/1 JSON); repeatable, one per player.",
)
@click.option(
    "--zero-based-players", is_flag=True, help="Numeric coalitions count from 0 (Storm/PAYNT)."
)
@click.option("--memory", "memory", multiple=True, metavar="[PLAYER=]K|K1..K2|auto",
              help="Synthesis: memory sizes of the decision maker's strategy (default auto: 1..3, "
              "and for a pomdp a belief-based controller with as many nodes as it needs; "
              "sizes above 1 alone, e.g. 2, are warm-started from a memoryless defence); "
              "PLAYER=... for a named player, e.g. --memory rover=2 --memory attacker=1 (the "
              "adversary's strategies enumerated with that memory). Repeatable.")
@click.option("--adversaries", type=click.IntRange(min=0), default=10, show_default=True,
              help="Synthesis: how many of the strongest enumerated adversary strategies the "
              "defence is composed against (0: no adversary phases).")
@click.option("--jobs", type=click.IntRange(min=1), default=1, show_default=True,
              help="Synthesis: worker processes for independent evaluations (results do not "
              "depend on it).")
@click.option(
    "--timeout",
    type=click.FloatRange(min=0, min_open=True),
    default=30.0,
    show_default=True,
    help="Synthesis: seconds per property, the first counted from the start (loading "
    "included); anytime: the best defence so far is verified.",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Synthesis: random seed.")
@click.option("--export-strategy", type=click.Path(), default=None,
              help="Write the optimal memoryless strategy of the (single) property as JSON; for a "
              "synthesised strategy, a directory receiving <player>.json.")
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
@_common
def check(
    model: str,
    props: tuple[str, ...],
    prop_texts: tuple[str, ...],
    precision: float,
    relative: bool,
    method: str,
    exact: bool,
    full_observation: bool,
    strategy_files: tuple[str, ...],
    zero_based_players: bool,
    memory: tuple[str, ...],
    adversaries: int,
    jobs: int,
    timeout: float,
    seed: int,
    export_strategy: str | None,
    as_json: bool,
    json_lines: bool,
    junit: str | None,
    plot_file: str | None,
    state_limit: int | None,
    verbose: bool,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Check PROPS (files) and --prop properties on MODEL."""
    from posgmc import api
    from posgmc.checking.dispatch import CheckOptions
    from posgmc.engines.options import Method, SolverOptions

    def run() -> int:
        if not props and not prop_texts:
            raise click.UsageError("give a properties file or --prop TEXT")
        swept, combos = expand_constants(consts)
        if plot_file is not None:
            if not plot_file.lower().endswith((".png", ".svg", ".pdf")):
                raise InputError(f"{plot_file}: a plot is written as .png, .svg or .pdf")
            if len(swept) != 1:
                raise InputError("--plot draws properties against one swept constant; "
                                 f"{len(swept)} are swept",
                                 hint="give one constant a range, e.g. --const B=0:4")
        strategies = strategy_options(strategy_files)
        options = CheckOptions(
            solver=SolverOptions(method=Method(method), precision=precision, relative=relative),
            keep_strategy=export_strategy is not None,
            exact=exact,
        )
        if as_json and json_lines:
            raise click.UsageError("give --json or --json-lines, not both")
        rows = []
        code = EXIT_OK
        # results are shown as they are computed (a killed run keeps what it printed), except
        # in the one-object --json and in sweep tables
        streaming = not as_json and len(combos or [{}]) == 1
        for constants in combos or [{}]:
            # the first synthesised property's --timeout counts from here: loading and
            # building the model are inside it
            loading = time.perf_counter()
            session = api.load(model, constants=constants)
            on_start, on_outcome = (
                _streamers(model, constants, json_lines, verbose) if streaming else (None, None)
            )
            report = api.check(
                session,
                property_files=props,
                properties=prop_texts,
                options=options,
                build_options=_build_options(state_limit, False, None),
                full_observation=full_observation,
                zero_based_players=zero_based_players,
                strategies=strategies or None,
                synthesis=_synthesis_options(memory, timeout, seed, adversaries, jobs,
                                             started=loading),
                on_start=on_start,
                on_outcome=on_outcome,
            )
            if report.errors:
                code = EXIT_ERROR
            elif code == EXIT_OK and any(_not_passed(r) for r in report.results):
                code = EXIT_PROPERTY_FALSE
            rows.append((constants, report))
            if export_strategy is not None and not report.errors:
                # a property that failed has said why; "needs exactly one query" would hide it
                if any(getattr(r, "strategies", ()) for r in report.results):
                    written = _write_synthesised(export_strategy, report)
                else:
                    _write_strategy(export_strategy, report)
                    written = [export_strategy]
                for path in written:  # on stderr when stdout is one JSON document
                    click.echo(f"wrote {path}", err=as_json or json_lines)
        if junit is not None:
            _write_check_junit(junit, model, swept, rows)
        if plot_file is not None:
            from posgmc.tradeoffs.plot import plot_sweeps
            from posgmc.tradeoffs.sweep import sweeps_of_check

            texts = [({n: _const_text(v) for n, v in c.items()}, r) for c, r in rows]
            plot_sweeps(sweeps_of_check(swept[0], texts), plot_file)
        if as_json or (json_lines and not streaming):
            click.echo(json.dumps(_json_report(model, swept, rows)))
        elif not streaming:
            _print_report(model, swept, rows, verbose=verbose)
        return code

    _guard(debug, run, as_json=as_json or json_lines, consts=consts)


def _streamers(model: str, constants: dict[str, Any], json_lines: bool,  # type: ignore[no-untyped-def]
               verbose: bool = False):
    """(on_start, on_outcome) callbacks printing the header and each result as it comes (a
    note once per run)."""
    seen: set[str] = set()

    def start(built: Any, seconds: float, warnings: tuple[str, ...]) -> None:
        stats = built.statistics()
        if json_lines:
            click.echo(json.dumps({
                "model_file": model,
                "constants": {n: _const_json(v) for n, v in constants.items()},
                "model": {k: stats[k] for k in ("type", "states", "choices", "transitions")},
                "build_seconds": round(seconds, 6),
                "warnings": list(warnings),
            }))
            return
        _print_header(model, stats, seconds, warnings)

    def outcome(r: Any) -> None:
        if json_lines:
            click.echo(json.dumps(_outcome_json(r)))
        else:
            _print_outcome(r, verbose=verbose, seen=seen)

    return start, outcome


def _outcome_json(r: Any) -> dict[str, Any]:
    if isinstance(r, tuple):
        return {"property": r[0], "error": r[1].render()}
    return r.to_json()  # type: ignore[no-any-return]


def _write_check_junit(
    path: str, model: str, swept: list[str], rows: list[tuple[dict[str, Any], Any]]
) -> None:
    """One test case per property (and constant setting): an error fails as an error, a false or
    undecided threshold or an unconverged result as a failure."""
    from posgmc.io.junit import Case, write_junit

    cases = []
    for constants, report in rows:
        label = ",".join(f"{n}={_const_text(constants[n])}" for n in swept)
        for r in report.outcomes:
            if isinstance(r, tuple):
                cases.append(
                    Case(r[0] + (f" ({label})" if label else ""), model, error=r[1].message)
                )
                continue
            name = r.property + (f" ({label})" if label else "")
            failure = None
            if _not_passed(r):
                failure = f"{r.property}: {_fmt(r.value)}" + (
                    "" if r.converged else " (not converged)"
                )
            cases.append(Case(name, model, r.seconds, failure=failure))
    write_junit(path, model, cases)


def _memory_sizes(text: str, given: str) -> tuple[int, ...]:
    try:
        if text == "auto":
            sizes: tuple[int, ...] = (1, 2, 3)
        elif ".." in text:
            lo, hi = (int(t) for t in text.split("..", 1))
            sizes = tuple(range(lo, hi + 1))
        else:
            sizes = (int(text),)
    except ValueError:
        raise click.BadParameter(f"{given!r}: give K, K1..K2 or auto, optionally after PLAYER=",
                                 param_hint="'--memory'") from None
    if not sizes or min(sizes) < 1:
        raise click.BadParameter(f"{given!r}: memory sizes start at 1", param_hint="'--memory'")
    return sizes


def _synthesis_options(memory: Sequence[str] | str, timeout: float, seed: int,
                       adversaries: int = 10, jobs: int = 1, started: float | None = None) -> Any:
    """``--memory`` settings as memory sizes: ``2``, ``1..3``, ``auto`` (1..3) for the property's
    coalition, or ``PLAYER=...`` for a named player (the decision maker or the adversary);
    ``started``: where the first property's budget starts (``SynthesisOptions.started``)."""
    from posgmc.synthesis.search import SynthesisOptions

    settings = [memory] if isinstance(memory, str) else list(memory)
    unnamed: tuple[int, ...] = (1, 2, 3)
    named: dict[str, tuple[int, ...]] = {}
    for given in settings:
        if "=" in given:
            player, text = given.split("=", 1)
            if player.strip() in named:
                raise click.BadParameter(f"{given!r}: player {player.strip()!r} given twice",
                                         param_hint="'--memory'")
            named[player.strip()] = _memory_sizes(text.strip(), given)
        else:
            unnamed = _memory_sizes(given.strip(), given)
    # memory auto (the default) lets a pomdp's synthesis add a belief-based controller with more
    # nodes; sizes given explicitly bound the strategy's memory
    explicit = any(given.split("=", 1)[-1].strip() != "auto" for given in settings)
    return SynthesisOptions(memory=unnamed, timeout=timeout, seed=seed, adversaries=adversaries,
                            jobs=jobs, player_memory=tuple(sorted(named.items())),
                            belief=False if explicit else None, started=started)


def _write_synthesised(directory: str, report: Any) -> list[str]:
    """One posgmc-fss/1 file per synthesised player, <player>.json, in ``directory``; a second
    strategy of the same player (the composed defence that ``vs_fss_adversary`` is about, when it
    is not the reported defence) goes to <player>.vs_fss.json. Returns the paths written."""
    import os

    from posgmc.strategies.files import write_strategy

    os.makedirs(directory, exist_ok=True)
    paths: list[str] = []
    for r in report.results:
        written: set[str] = set()
        for fss in getattr(r, "strategies", ()):
            name = fss.player or "agent"
            paths.append(os.path.join(directory, f"{name}.vs_fss.json" if name in written
                                      else f"{name}.json"))
            write_strategy(fss, paths[-1])
            written.add(name)
    return paths


def _not_passed(r: Any) -> bool:
    """A threshold that is false or undecided, or a result whose iteration did not converge."""
    return r.value is False or (r.value is None and r.kind.value == "boolean") or not r.converged


def strategy_options(values: Sequence[str]) -> dict[str | None, str]:
    """``("rover=r.json", "a.json")`` -> {"rover": "r.json", None: "a.json"} (None: the file's
    own player).

    Raises:
        click.UsageError: a player given twice, or an empty file name.
    """
    out: dict[str | None, str] = {}
    for text in values:
        player, sep, path = text.partition("=")
        key: str | None = player if sep else None
        path = path if sep else player
        if not path:
            raise click.UsageError(f"--strategy {text!r}: give PLAYER=FILE")
        if key in out:
            raise click.UsageError(
                f"--strategy: two strategies for player {key or '(from file)'!r}"
            )
        out[key] = path
    return out


def _write_strategy(path: str, report: Any) -> None:
    """The memoryless strategy of a check as JSON, one line per deciding state, written as it is
    encoded: a large game's strategy never exists as one document in memory (rover_wind L=500,
    583k states: ``json.dumps`` of the whole document with indentation took about 11 s and
    1.4 GB)."""
    import numpy as np

    from posgmc.io.atomic import atomic_open

    if len(report.results) != 1 or report.results[0].strategy is None:
        raise PosgmcError("--export-strategy needs exactly one unbounded P or R query")
    m = report.model
    strategy = np.asarray(report.results[0].strategy)
    # only the states where the strategy chooses; their fields gathered as whole arrays
    chosen = np.flatnonzero(strategy >= 0)
    choices = strategy[chosen]
    local = (choices - m.row_groups[chosen]).tolist()
    actions = m.choice_actions[choices].tolist()
    names = list(m.variable_names)
    values = m.state_values[chosen].tolist() if names else None
    players = m.state_players[chosen].tolist() if m.player_names else None
    encode = json.JSONEncoder().encode  # compact, C-accelerated
    with atomic_open(path) as handle:
        handle.write(
            '{"property": ' + encode(report.results[0].property) + ', "memoryless": true, '
            '"states": ['
        )
        for i, (s, c, a) in enumerate(zip(chosen.tolist(), local, actions)):
            entry: dict[str, object] = {"state": s, "choice": c, "action": m.action_names[a]}
            if values is not None:
                entry["valuation"] = dict(zip(names, values[i]))
            if players is not None:
                entry["player"] = m.player_names[players[i]]
            handle.write(("\n  " if i == 0 else ",\n  ") + encode(entry))
        handle.write("\n]}\n")


def _json_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]]
) -> dict[str, Any]:
    def one(constants: Mapping[str, object], report: CheckReport) -> dict[str, Any]:
        stats = report.model.statistics()
        return {
            "constants": {n: _const_json(v) for n, v in constants.items()},
            "model": {k: stats[k] for k in ("type", "states", "choices", "transitions")},
            "build_seconds": round(report.build_seconds, 6),
            "results": [_outcome_json(r) for r in report.outcomes],
        }

    if len(rows) == 1:
        out = {"model_file": model, **one(*rows[0])}
        return out
    return {"model_file": model, "swept": swept, "runs": [one(c, r) for c, r in rows]}


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return "unknown"
    return f"{v:.10g}"


def _print_multi(r: Any) -> None:
    """A multi(...) result: its answer, what it is, and the front of a Pareto query."""
    front = r.front
    if front is not None:
        click.echo(f"{r.property}: Pareto front {front.text()}  ({r.method}, {r.seconds:.3f} s)")
        click.echo(f"  under-approximation (achievable vertices): {front.text()}")
        if len(front.corners):
            corners = ",".join("(" + ",".join(f"{v:.10g}" for v in c) + ")" for c in front.corners)
            click.echo(
                f"  over-approximation vertices: [{corners}]; precision {front.precision:.3g}"
            )
    else:
        line = f"{r.property}: {'NaN' if r.value != r.value else _fmt(r.value)}"
        what = ("proven (see the note)" if r.sound else
                "LP value: floating point, see the note" if r.method.startswith("lp")
                else "from an under-approximation, see the note")
        line += f"  ({r.method}, {r.seconds:.3f} s)  {what}"
        click.echo(line)
    if r.note:
        click.echo(f"  note: {r.note}")


def _print_header(
    model: str, stats: dict[str, Any], seconds: float, warnings: Sequence[str]
) -> None:
    click.echo(
        f"Model {model}: {stats['type']}, {stats['states']} states, {stats['choices']} choices, "
        f"{stats['transitions']} transitions (built in {seconds:.3f} s)"
    )
    for w in warnings:
        click.echo(f"warning: {w}", err=True)


def _print_outcome(r: Any, *, verbose: bool = False, seen: set[str] | None = None) -> None:
    """One property's result (or error) as text (:mod:`posgmc.checking.result_text`); notes in
    ``seen`` are not repeated; click.echo flushes, so it shows at once."""
    from posgmc.checking.result_text import result_lines

    if not isinstance(r, tuple) and getattr(r, "multi", None) is not None:
        _print_multi(r)
        return
    for line in result_lines(r, verbose=verbose, seen=seen):
        click.echo(line)
    if isinstance(r, tuple):
        click.echo(r[1].render(), err=True)


def _print_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]],
    *, verbose: bool = False,
) -> None:
    first = rows[0][1]
    _print_header(model, first.model.statistics(), first.build_seconds, first.warnings)
    if len(rows) == 1:
        seen: set[str] = set()
        for r in first.outcomes:
            _print_outcome(r, verbose=verbose, seen=seen)
        return
    for i, r0 in enumerate(first.outcomes):
        click.echo(f"\n{r0[0] if isinstance(r0, tuple) else r0.property}:")
        click.echo("\t".join(swept + ["Result"]))
        for constants, report in rows:
            r = report.outcomes[i]
            value = "Error" if isinstance(r, tuple) else _fmt(r.value)
            click.echo("\t".join([_const_text(constants[n]) for n in swept] + [value]))
            if isinstance(r, tuple):
                click.echo(r[1].render(), err=True)


# the strategy commands (test, simulate, show-strategy) live in their own module and register
# themselves on ``main`` when imported
from posgmc import cli_strategies, cli_tradeoffs  # noqa: E402,F401

if __name__ == "__main__":  # pragma: no cover
    # run as a script this file is __main__; the commands registered on the imported posgmc.cli
    from posgmc.cli import main as registered

    registered()
