"""The ``pareto`` command: a property against a swept constant, each point verified, as a table,
CSV and a plot (:mod:`posgmc.tradeoffs`). Thin, like :mod:`posgmc.cli`."""

from __future__ import annotations

from typing import Any

import click

from posgmc.cli import EXIT_ERROR, EXIT_OK, _common, _const_text, _fmt, _guard, _synthesis_options, main
from posgmc.errors import InputError, UnsupportedError

__all__ = ["pareto"]


@main.command("pareto")
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--prop", "prop_text", required=True, metavar="TEXT", help="The property.")
@click.option("--sweep", "sweep_text", required=True, metavar="B=0:4",
              help="The constant to sweep, as a --const range (PRISM syntax: B=0:4, p=0.1:0.1:0.5).")
@click.option("--csv", "csv_file", type=click.Path(dir_okay=False), default=None,
              help="Also write the points as CSV.")
@click.option("--plot", "plot_file", type=click.Path(dir_okay=False), default=None,
              help="Also draw the front (.png, .svg, .pdf; needs matplotlib: pip install 'posgmc[plot]').")
@click.option("--strategies", "strategy_dir", type=click.Path(file_okay=False), default=None,
              help="Write each point's strategies to DIR/<constant>=<value>/<player>.json.")
@click.option("--full-observation", is_flag=True, help="pomdp/posg: the full-observation values.")
@click.option("--zero-based-players", is_flag=True, help="Numeric coalitions count from 0 (Storm/PAYNT).")
@click.option("--memory", "memory", multiple=True, metavar="[PLAYER=]K|K1..K2|auto",
              help="Synthesis: memory sizes, as for check.")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=30.0, show_default=True,
              help="Synthesis: seconds per point.")
@click.option("--seed", type=int, default=0, show_default=True, help="Synthesis: random seed.")
@_common
def pareto(
    model: str,
    prop_text: str,
    sweep_text: str,
    csv_file: str | None,
    plot_file: str | None,
    strategy_dir: str | None,
    full_observation: bool,
    zero_based_players: bool,
    memory: tuple[str, ...],
    timeout: float,
    seed: int,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """A trade-off: PROP against a swept constant, one verified point (and strategy) per value."""
    from posgmc.io.atomic import atomic_write_text
    from posgmc.semantics.constants import ConstRange, parse_const_assignments
    from posgmc.tradeoffs.sweep import sweep, to_csv

    def run() -> int:
        if plot_file is not None and not plot_file.lower().endswith((".png", ".svg", ".pdf")):
            raise InputError(f"{plot_file}: a plot is written as .png, .svg or .pdf")
        if prop_text.lstrip().startswith("multi"):
            raise UnsupportedError(
                "multi-objective queries (multi(...)) are not supported yet",
                hint="sweep a constant instead: --sweep B=0:4 (docs/tradeoffs.md)",
            )
        swept = parse_const_assignments(sweep_text, source="--sweep")
        if len(swept) != 1 or not isinstance(next(iter(swept.values())), ConstRange):
            raise InputError("--sweep takes one constant with a range, e.g. --sweep B=0:4")
        (name, rng), = swept.items()
        others: dict[str, Any] = {}
        for i, text in enumerate(consts):
            for n, setting in parse_const_assignments(
                text, source="--const" if len(consts) == 1 else f"--const #{i + 1}"
            ).items():
                if isinstance(setting, ConstRange):
                    raise InputError(f"--const {n}: only --sweep takes a range in pareto",
                                     setting.span)
                if n == name:
                    raise InputError(f"constant '{n}' is both swept and given", setting.span)
                others[n] = setting
        values = [_const_text(v) for v in rng.values()]
        result = sweep(model, prop_text, constant=name, settings=values, constants=others,
                       synthesis=_synthesis_options(memory or ("auto",), timeout, seed),
                       full_observation=full_observation, zero_based_players=zero_based_players,
                       strategy_dir=strategy_dir)
        _print(result)
        if csv_file is not None:
            atomic_write_text(csv_file, to_csv(result))
        if plot_file is not None:
            from posgmc.tradeoffs.plot import plot_sweep

            plot_sweep(result, plot_file)
        return EXIT_ERROR if any(p.error is not None for p in result.points) else EXIT_OK

    _guard(debug, run, consts=consts)


def _print(result: Any) -> None:
    click.echo(f"{result.property} against {result.constant}:")
    rows = [(result.constant, "value [lower, upper]", "full_observation", "upper_bound", "memory",
             "strategies")]
    for p in result.points:
        b = p.main_number()
        r = p.result
        if p.error is not None:
            rows.append((p.setting, "Error", "", "", "", ""))
            click.echo(p.error.render(), err=True)
            continue
        cell = "-" if b is None else f"{_fmt(b.value)} [{_fmt(b.lower)}, {_fmt(b.upper)}]"
        if r is not None and r.synthesis and r.synthesis.get("partial"):
            cell += " (partial)"
        rows.append((
            p.setting, cell,
            _fmt(r.full_observation.value) if r is not None and r.full_observation else "-",
            _fmt(r.upper_bound.value) if r is not None and r.upper_bound else "-",
            ", ".join(f"{n or 'agent'}={k}" for n, k in r.memory) if r is not None and r.memory else "-",
            p.strategy_dir or "-",
        ))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    if any(p.result is not None and p.result.guaranteed is not None for p in result.points):
        click.echo("value: what the synthesised strategy of each point guarantees against every "
                   "adversary (proven bounds)")
