"""The ``pareto`` command: a property against a swept constant, each point verified, or the front
of a ``multi(...)`` query on an mdp, as a table, CSV and a plot (:mod:`posgmc.tradeoffs`)."""

from __future__ import annotations

from typing import Any, Literal

import click

from posgmc.checking.result_text import point_text
from posgmc.cli.constants import const_assignments, const_text, single_constants
from posgmc.cli.group import main
from posgmc.cli.options import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_PROPERTY_FALSE,
    common,
    effort_option,
    executor_options,
    finite,
    full_observation_option,
    memory_option,
    placement_of,
    progress_options,
    seed_option,
    synthesis_options,
    timeout_option,
    zero_based_players_option,
)
from posgmc.cli.printing import fmt, interrupt_summary
from posgmc.cli.progress_view import progress_mode, progress_view
from posgmc.cli.running import guard
from posgmc.errors import InputError, SourceSpan, SourceText, UnsupportedError
from posgmc.synthesis.budget import interrupted, interruptible

__all__ = ["pareto"]


@main.command("pareto")
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--prop", "prop_text", required=True, metavar="TEXT",
              help="The property: any property with --sweep, or a multi(...) query (mdp).")
@click.option(
    "--sweep",
    "sweep_text",
    default=None,
    metavar="B=0:4",
    help="The constant to sweep, as a --const range (PRISM syntax: B=0:4, p=0.1:0.1:0.5).",
)
@click.option("--csv", "csv_file", type=click.Path(dir_okay=False), default=None,
              help="Also write the points as CSV.")
@click.option(
    "--plot",
    "plot_file",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also draw the front (.png, .svg, .pdf; needs matplotlib: pip install 'posgmc[plot]').",
)
@click.option("--strategies", "strategy_dir", type=click.Path(file_okay=False), default=None,
              help="Write each point's strategies to DIR/<constant>=<value>/<player>.json.")
@click.option("--also", "also", multiple=True, metavar="TEXT",
              help="A further property checked at every point under its synthesised defence "
              "(its guaranteed number), e.g. the defence's expected cost; repeatable.")
@click.option("--cost", "cost_text", default=None, metavar="TEXT",
              help="pomdp/posg: a defender front of --prop (the mission, <<C>> Pmax=? [ F G ]) "
              "against this cost (<<C>> R{..}min=? [ ... ]), one synthesised, verified defence per "
              "--weights value.")
@click.option("--weights", "weights_text", default=None, metavar="W1,W2,...",
              help="With --cost: the scalarisation weights (cost - w * mission), each >= 0 "
              "[default: 0,1,2,5,10,20]; the mission alone is always added (w=inf).")
@click.option("--budget", "budgets", multiple=True, type=float, metavar="C",
              callback=lambda _c, _p, v: tuple(finite(b, "--budget") for b in v),
              help="With --cost: answer 'max guaranteed mission s.t. guaranteed cost <= C' from "
              "the verified defences; repeatable.")
@full_observation_option
@zero_based_players_option
@memory_option
@executor_options
@timeout_option
@effort_option
@seed_option
@progress_options
@common
def pareto(
    model: str,
    prop_text: str,
    sweep_text: str | None,
    csv_file: str | None,
    plot_file: str | None,
    strategy_dir: str | None,
    also: tuple[str, ...],
    cost_text: str | None,
    weights_text: str | None,
    budgets: tuple[float, ...],
    full_observation: bool,
    zero_based_players: bool,
    memory: tuple[str, ...],
    jobs: int,
    executor: Literal["local", "ray"],
    ray_address: str | None,
    timeout: float | None,
    effort: float,
    seed: int,
    progress_lines: bool,
    quiet: bool,
    consts: tuple[str, ...],
    debug: bool,
) -> None:
    """A trade-off: PROP against a swept constant, one verified point (and strategy) per value;
    or the Pareto front of a multi(...) query with its approximation band."""
    from posgmc.io.atomic import atomic_write_text
    from posgmc.semantics.constants import ConstRange, parse_const_assignments
    from posgmc.synthesis.tasks import Placement
    from posgmc.tradeoffs.sweep import sweep, to_csv

    def run() -> int:
        where = placement_of(jobs, executor, ray_address)
        if plot_file is not None:
            if not plot_file.lower().endswith((".png", ".svg", ".pdf")):
                raise InputError(f"{plot_file}: a plot is written as .png, .svg or .pdf")
            from posgmc.tradeoffs.plot import require_matplotlib

            require_matplotlib()  # before the sweep or front, not after it
        if strategy_dir is not None:  # before any work, not after the whole sweep
            from posgmc.cli.strategy_export import check_destination

            check_destination(strategy_dir, directory=True, option="--strategies")
        if cost_text is None and (weights_text is not None or budgets):
            raise InputError("--weights and --budget go with --cost (a defender front)",
                             hint="add --cost '<<C>> R{\"cost\"}min=? [ ... ]'")
        if cost_text is not None:
            if sweep_text is not None or also or full_observation:
                raise UnsupportedError("--cost draws a defender front of its own: --sweep, "
                                       "--also and --full-observation do not apply to it")
            return _defence(model, prop_text, cost_text, weights_text, budgets, consts,
                            memory, timeout, effort, seed, csv_file, plot_file, strategy_dir,
                            where)
        if prop_text.lstrip().startswith("multi"):
            if sweep_text is not None:
                raise UnsupportedError(
                    "a multi(...) query gives its own front: --sweep does not apply to it",
                    hint="drop --sweep, or sweep a single-objective property",
                )
            if strategy_dir is not None or also:
                raise UnsupportedError("--strategies and --also apply to sweeps; a multi(...) "
                                       "front keeps no strategies yet")
            return _multi(model, prop_text, consts, csv_file, plot_file)
        if sweep_text is None:
            raise InputError("--sweep is needed (unless --prop is a multi(...) query)",
                             hint="e.g. --sweep B=0:4")
        swept = parse_const_assignments(sweep_text, source="--sweep")
        rng = next(iter(swept.values())) if len(swept) == 1 else None
        if not isinstance(rng, ConstRange):
            raise InputError("--sweep takes one constant with a range, e.g. --sweep B=0:4")
        name = next(iter(swept))
        others: dict[str, Any] = {}
        for n, setting in const_assignments(consts):
            if isinstance(setting, ConstRange):
                raise InputError(f"--const {n}: only --sweep takes a range in pareto",
                                 setting.span)
            if n == name:
                raise InputError(f"constant '{n}' is both swept and given", setting.span)
            others[n] = setting
        values = [const_text(v) for v in rng.values()]
        # each point a task on the executor; a single point gives it to its synthesis
        inner = where if len(values) == 1 else Placement()
        # Ctrl-C: the points running wind down and report their best verified defence, the
        # others are cancelled; the table shows the points that finished, no CSV or plot of
        # half a sweep is written, and the exit status is 130
        result = sweep(model, prop_text, constant=name, settings=values, constants=others,
                       synthesis=synthesis_options(memory or ("auto",), timeout, seed,
                                                   jobs=inner.workers, effort=effort,
                                                   executor=inner.executor,
                                                   ray_address=inner.address),
                       full_observation=full_observation, zero_based_players=zero_based_players,
                       strategy_dir=strategy_dir, also=also, placement=where)
        if interrupted():
            return _interrupted_sweep(result)
        _print(result)
        if csv_file is not None:
            atomic_write_text(csv_file, to_csv(result))
        if plot_file is not None:
            from posgmc.tradeoffs.plot import plot_sweep

            plot_sweep(result, plot_file)
        failed = any(p.error is not None or any(not hasattr(a, "guaranteed") for a in p.also)
                     for p in result.points)
        unproven = any(p.result is not None and not _proven(p.result) for p in result.points)
        return EXIT_ERROR if failed else EXIT_PROPERTY_FALSE if unproven else EXIT_OK

    def shown() -> int:
        # each point of a sweep or front is reported as it completes (the tables come at the end)
        with progress_view(progress_mode(quiet=quiet, lines=progress_lines, json_lines=False)):
            code = run()
        # a Ctrl-C the path did not report on (a multi(...) query runs to its end)
        return EXIT_INTERRUPTED if interrupted() else code

    # the first Ctrl-C asks the sweep or front to wind down (a second aborts)
    with interruptible():
        guard(debug, shown, consts=consts)


def _multi(model: str, prop_text: str, consts: tuple[str, ...], csv_file: str | None,
           plot_file: str | None) -> int:
    """``pareto --prop 'multi(...)'``: the answer; for a Pareto query the front as a table."""
    from posgmc.io.atomic import atomic_write_text
    from posgmc.tradeoffs.front import front_to_csv, multi_objective

    constants = single_constants(consts, what="a multi(...) query")
    answer = multi_objective(model, prop_text, constants=constants)
    front = answer.front
    if front is None:
        if csv_file is not None or plot_file is not None:
            raise UnsupportedError(
                f"a {answer.kind.value} query has no front to write",
                hint="--csv and --plot need a Pareto query: two objectives with =?",
            )
        value = answer.achievable if answer.kind.value == "achievability" else answer.value
        if answer.kind.value == "achievability":
            what = ("proven: the LP's strategy, re-checked by interval iteration, meets every "
                    "threshold" if answer.proven else "LP verdict, not proven")
        elif answer.certified == answer.certified:  # not NaN
            what = (
                f"LP value; proven: the optimum is {'at most' if answer.minimised else 'at least'}"
                f" {fmt(answer.certified)}"
            )
        else:
            what = "LP value: floating point, not a proven bound"
        click.echo(f"{prop_text}: {fmt(value)}  (lp (HiGHS), {answer.seconds:.3f} s; {what})")
        return EXIT_OK
    click.echo(f"{prop_text}: Pareto front, {len(front.points)} vertices "
               f"({front.solves} LPs over {answer.states} states, {answer.seconds:.3f} s)")
    rows = [("", *(o + f" ({d.value})" for o, d in zip(front.objectives, front.directions)))]
    rows += [("achievable", *(fmt(float(v)) for v in p)) for p in front.points]
    rows += [("over-approximation", *(fmt(float(v)) for v in p)) for p in front.corners]
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    how = ("" if len(front.objectives) == 2 else
           " (shifted by that much in every objective at once)")
    click.echo(f"precision: every point of the over-approximation is within {front.precision:.3g} "
               f"of an achievable one{how}"
               + ("" if front.converged else " (STOPPED at the LP budget)"))
    click.echo("achievable: the vertices of the under-approximation (each point of their convex "
               "hull, and anything worse, is achieved by a strategy); LP values in floating point")
    if csv_file is not None:
        atomic_write_text(csv_file, front_to_csv(front))
    if plot_file is not None:
        from posgmc.tradeoffs.plot import plot_front

        if len(front.objectives) != 2:
            click.echo(f"--plot: a front of {len(front.objectives)} objectives is not drawn (the "
                       "plot is 2-D); the table and --csv have every objective", err=True)
            return EXIT_ERROR
        plot_front(front, plot_file, title=prop_text)
    return EXIT_OK


def _defence(model: str, mission: str, cost: str, weights_text: str | None,
             budgets: tuple[float, ...], consts: tuple[str, ...], memory: tuple[str, ...],
             timeout: float | None, effort: float, seed: int, csv_file: str | None,
             plot_file: str | None,
             strategy_dir: str | None, placement: Any) -> int:
    """``pareto --prop MISSION --cost COST``: the defender front
    (:mod:`posgmc.tradeoffs.defence`)."""
    import math

    from posgmc.io.atomic import atomic_write_text
    from posgmc.tradeoffs.defence import defence_front, defence_front_to_csv

    # an empty --weights is an error (no weight at all), not the defaults
    text = "0,1,2,5,10,20" if weights_text is None else weights_text
    weights: list[float] = []
    column = 1
    for item in text.split(","):
        try:
            weights.append(float(item))
            if not (math.isfinite(weights[-1]) and weights[-1] >= 0):
                raise ValueError
        except ValueError:
            raise InputError(
                f"--weights: {item.strip()!r} is not a number (a comma-separated list of "
                "numbers >= 0)",
                SourceSpan(1, column, 1, column + max(len(item), 1), file="--weights"),
                source=SourceText(text, "--weights"),
                hint="e.g. --weights 0,5,10,20",
            ) from None
        column += len(item) + 1
    options = synthesis_options(memory or ("1",), timeout, seed, effort=effort)
    sizes: Any = dict(options.player_memory) if options.player_memory else options.memory
    front = defence_front(model, mission, cost, weights=weights,
                          constants=single_constants(consts, what="a front"), memory=sizes,
                          timeout=timeout, effort=effort, seed=seed, budgets=budgets,
                          strategy_dir=strategy_dir, placement=placement)
    click.echo(f"defender front: {front.mission} against {front.cost} "
               f"({len(front.points)} defences, {front.seconds:.1f} s)")
    rows = [("w", "mission: guaranteed [lower, upper]", "cost: guaranteed [lower, upper]",
             "front", "memory", "strategy")]
    for i, p in enumerate(front.points):
        w = "inf" if math.isinf(p.weight) else f"{p.weight:g}"
        if p.mission is None or p.cost is None:
            rows.append((w, "Error", "", "", "", ""))
            if p.error is not None:
                click.echo(f"w={w}: " + p.error.render(), err=True)
            continue
        rows.append(
            (
                w,
                f"{fmt(p.mission.value)} [{fmt(p.mission.lower)}, {fmt(p.mission.upper)}]"
                + (" (partial)" if p.partial else ""),
                f"{fmt(p.cost.value)} [{fmt(p.cost.lower)}, {fmt(p.cost.upper)}]",
                "*" if i in front.front else "",
                str(p.memory),
                p.strategy_file or "-",
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    fm, fc = front.full_observation
    if fm is not None and fc is not None:
        click.echo(f"full observation (no partially observing defence does better): mission "
                   f"{fmt(fm.value)}, cost {fmt(fc.value)}")
    def weight(i: int) -> str:
        w = front.points[i].weight
        return "inf" if math.isinf(w) else f"{w:g}"

    for answer in front.budgets:
        q = answer.point
        if q is None or q.mission is None or q.cost is None:
            click.echo(f"cost <= {fmt(answer.budget)}: no verified defence meets it")
            continue
        if answer.mixed is not None:
            i, j, alpha = answer.mixed
            how = (f"the mixture of w={weight(j)} (probability {alpha:.6g}) and w={weight(i)}, "
                   "verified itself")
        else:
            how = f"the defence of w={weight(answer.pure)}"  # type: ignore[arg-type]
        click.echo(f"cost <= {fmt(answer.budget)}: mission >= {fmt(q.mission.lower)} (proven), "
                   f"by {how} (cost <= {fmt(q.cost.upper)})"
                   + (f" -> {q.strategy_file}" if q.strategy_file and answer.mixed else ""))
    click.echo("each row: one synthesised defence, both numbers proven for it against every "
               "adversary; * = on the front (no other defence found is better on both proven "
               "bounds). The front is what was found, a lower bound on the best trade-off.")
    if interrupted():
        # the weights running wound down and report their best verified defence (the rows
        # marked partial); no CSV or plot of half a front is written
        done = {p.weight for p in front.points}
        click.echo(interrupt_summary(
            [f"w={_weight_text(p.weight)}" for p in front.points], [],
            [f"w={_weight_text(w)}" for w in [*weights, math.inf] if w not in done]), err=True)
        return EXIT_INTERRUPTED
    if csv_file is not None:
        atomic_write_text(csv_file, defence_front_to_csv(front))
    if plot_file is not None:
        from posgmc.tradeoffs.plot import plot_defence_fronts

        plot_defence_fronts([("", front)], plot_file)
    failed = any(p.error is not None for p in front.points)
    return EXIT_ERROR if failed else EXIT_OK


def _weight_text(w: float) -> str:
    return "inf" if w == float("inf") else f"{w:g}"


def _also_cell(a: Any) -> str:
    g = getattr(a, "guaranteed", None)
    if g is None:
        return "Error" if a is not None else "-"
    return _bound_cell(g)


def _proven(r: Any) -> bool:
    """Every number of a point's result is proven (its checks converged, by sound methods)."""
    return bool(r.sound and r.converged)


def _bound_cell(b: Any) -> str:
    """A number with its proven bounds (the number as the shortest decimal inside them, the
    bounds alone where its check did not settle); ``-`` where it was not computed."""
    if b is None:
        return "-"
    settled = b.sound and b.converged
    text = point_text(b.value, b.lower, b.upper, settled=settled)
    return text if text.startswith("[") else f"{text} [{fmt(b.lower)}, {fmt(b.upper)}]"


def _bound_headers(result: Any) -> tuple[str, str]:
    """The full_observation and upper_bound columns' names by their role for the decision
    maker's direction (``no defence above`` for a maximiser, ``below`` for a minimiser), with the
    JSON/CSV name beside; the JSON names alone when no point says its direction."""
    from posgmc.checking.result_text import role_of

    directions = [p.result.maximizing for p in result.points
                  if p.result is not None and p.result.maximizing is not None]
    if not directions:
        return "full_observation", "upper_bound"
    full = f"{role_of('full_observation', maximizing=directions[0])} (full_observation)"
    return full, f"{role_of('upper_bound', maximizing=directions[0])} (upper_bound)"


def _interrupted_sweep(result: Any) -> int:
    """An interrupted ``pareto --sweep``: the points that finished, and which were cut short or
    cancelled."""
    if result.points:
        _print(result)
    finished = [f"{result.constant}={p.setting}" for p in result.points]
    cut = [f"{result.constant}={p.setting}" for p in result.points
           if p.result is not None and (p.result.synthesis or {}).get("cut") == "interrupt"]
    click.echo(interrupt_summary(finished, cut,
                                 [f"{result.constant}={s}" for s in result.cancelled]), err=True)
    return EXIT_INTERRUPTED


def _print(result: Any) -> None:
    click.echo(f"{result.property} against {result.constant}:")
    rows = [(result.constant, "value [lower, upper]", *_bound_headers(result), "memory",
             "strategies", *result.also)]
    for p in result.points:
        b = p.main_number()
        r = p.result
        if p.error is not None:
            rows.append((p.setting, "Error", "", "", "", "", *("" for _ in result.also)))
            click.echo(p.error.render(), err=True)
            continue
        cell = _bound_cell(b)
        if r is not None and r.synthesis and r.synthesis.get("partial"):
            cell += " (partial)"
        if r is not None and not _proven(r):
            cell += " NOT PROVEN"
        rows.append(
            (
                p.setting,
                cell,
                _bound_cell(r.full_observation if r is not None else None),
                _bound_cell(r.upper_bound if r is not None else None),
                ", ".join(f"{n or 'agent'}={k}" for n, k in r.memory)
                if r is not None and r.memory
                else "-",
                p.strategy_dir or "-",
                *(_also_cell(a) for a in (p.also or (None,) * len(result.also))),
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    if any(p.result is not None and p.result.guaranteed is not None for p in result.points):
        click.echo("value: what the synthesised strategy of each point guarantees against every "
                   "adversary (proven bounds)" + ("; the further columns: what the same strategy "
                   "guarantees for each --also property" if result.also else ""))
    for p in result.points:
        for a in p.also:
            if not hasattr(a, "guaranteed") and hasattr(a, "render"):
                click.echo(f"{result.constant}={p.setting}: " + a.render(), err=True)
