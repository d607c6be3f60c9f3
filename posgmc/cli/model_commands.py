"""The commands about a model without properties: ``lint`` (parse and check, no build) and ``build``
(the explicit state space, its statistics and exports)."""

from __future__ import annotations

import json
from typing import Any

import click

from posgmc.cli.constants import expand_constants, single_constants
from posgmc.cli.group import main
from posgmc.cli.options import (
    EXIT_ERROR,
    EXIT_OK,
    common,
    strict_option,
    zero_based_players_option,
)
from posgmc.cli.running import guard
from posgmc.errors import MultipleErrors, PosgmcError

__all__ = ["lint", "build", "build_options"]


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.argument("props", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--prop", "prop_texts", multiple=True, metavar="TEXT", help="A property, as text.")
@zero_based_players_option
@click.option(
    "--each",
    is_flag=True,
    help="Every argument is a model (as pre-commit passes changed files); a properties file "
    "beside it with the same name and .props is checked with it; .props arguments are skipped.",
)
@strict_option
@common
def lint(
    model: str,
    props: tuple[str, ...],
    prop_texts: tuple[str, ...],
    zero_based_players: bool,
    each: bool,
    strict: bool,
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
                    strict=strict,
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

    guard(debug, run)


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
@click.option(
    "--observer",
    metavar="PLAYER",
    default=None,
    help="--export drn of a posg: the player whose observations the file carries (DRN has one "
    "observation per state): the POSMG file PAYNT reads, PLAYER its partially observing player.",
)
@strict_option
@common
def build(
    model: str,
    export: tuple[str, str] | None,
    as_json: bool,
    state_limit: int | None,
    no_fix_deadlocks: bool,
    progress: bool | None,
    observer: str | None,
    strict: bool,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """Build MODEL's explicit state space and print its statistics."""
    from posgmc import api

    def run() -> int:
        if observer is not None and (export is None or export[0] != "drn"):
            raise click.UsageError("--observer chooses the observations of --export drn")
        session = api.load(
            model, constants=single_constants(consts, what="build"), strict=strict
        )
        built = api.build(session, options=build_options(state_limit, no_fix_deadlocks, progress))
        stats = built.model.statistics()
        stats["build_seconds"] = round(built.seconds, 6)
        if export is not None:
            _export(built.model, export[0], export[1], observer)
            stats["exported"] = {"format": export[0], "file": export[1]}
        for w in built.warnings:
            click.echo(f"warning: {w}", err=True)
        if as_json:
            click.echo(json.dumps(stats))
        else:
            _print_stats(model, stats)
        return EXIT_OK

    guard(debug, run, as_json=as_json, consts=consts)


def build_options(state_limit: int | None, no_fix_deadlocks: bool, progress: bool | None, *,  # type: ignore[no-untyped-def]
                  deadline: float | None = None):
    from posgmc.compiler import BuildOptions, ProgressMode

    kwargs: dict[str, Any] = {"fix_deadlocks": not no_fix_deadlocks, "deadline": deadline}
    if state_limit is not None:
        # the user's limit replaces the guard on the memory available
        kwargs["state_limit"] = state_limit
        kwargs["memory_guard"] = False
    if progress is not None:
        kwargs["progress"] = ProgressMode.ALWAYS if progress else ProgressMode.NEVER
    return BuildOptions(**kwargs)


def _export(model: Any, fmt: str, path: str, observer: str | None = None) -> None:
    if fmt == "drn":
        from posgmc.io.drn import write_drn

        write_drn(model, path, observer=observer)
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
