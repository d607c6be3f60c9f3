"""The commands about strategies: ``simulate`` and ``show-strategy``."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import click

from posgmc.cli.constants import single_constants
from posgmc.cli.group import main
from posgmc.cli.options import (
    EXIT_OK,
    common,
    strategy_options,
    zero_based_players_option,
)
from posgmc.cli.printing import fmt
from posgmc.cli.running import guard
from posgmc.errors import InputError

__all__ = ["simulate", "show_strategy"]


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
