"""How ``check`` shows its results: one line per property with its proven bounds and what each
number means, sweep tables, and the JSON documents of docs/cli.md."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import click

from posgmc.cli.constants import const_text
from posgmc.semantics.evaluate import format_value

if TYPE_CHECKING:
    from posgmc.api import CheckReport

__all__ = ["fmt", "outcome_json", "json_report", "print_header", "print_outcome", "print_report"]


def outcome_json(r: Any) -> dict[str, Any]:
    if isinstance(r, tuple):
        return {"property": r[0], "error": r[1].render()}
    return r.to_json()  # type: ignore[no-any-return]


def json_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]]
) -> dict[str, Any]:
    def one(constants: Mapping[str, object], report: CheckReport) -> dict[str, Any]:
        stats = report.model.statistics()
        return {
            "constants": {n: const_text(v) for n, v in constants.items()},
            "model": {k: stats[k] for k in ("type", "states", "choices", "transitions")},
            "build_seconds": round(report.build_seconds, 6),
            "results": [outcome_json(r) for r in report.outcomes],
        }

    if len(rows) == 1:
        out = {"model_file": model, **one(*rows[0])}
        return out
    return {"model_file": model, "swept": swept, "runs": [one(c, r) for c, r in rows]}


def fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return "unknown"
    return f"{v:.10g}"


def print_strategy_numbers(r: Any) -> None:
    """The numbers about given strategies, each with its bounds and what it means."""
    from posgmc.checking.results import STRATEGY_NUMBERS

    for key in (*STRATEGY_NUMBERS, "full_observation"):
        number = getattr(r, key, None)
        if number is not None:
            click.echo(
                f"  {key}: {fmt(number.value)}  [{fmt(number.lower)}, {fmt(number.upper)}]"
            )
    optimum = getattr(r, "optimum", None)
    if optimum is not None:
        click.echo(f"  optimum: [{fmt(optimum.lower)}, {fmt(optimum.upper)}]  gap "
                   f"{fmt(optimum.gap)} (any defence; bound by {optimum.method})"
                   + ("" if optimum.sound else "  NOT PROVEN"))
    stats = getattr(r, "synthesis", None)
    if stats:
        rounds = ", ".join(
            f"k={x['memory']}: {x['value_policy_iteration']:.8g}" for x in stats["rounds"]
        )
        phases = ", ".join(f"{k} {v:.2f} s" for k, v in stats["phases"].items())
        click.echo(
            f"  synthesis: {rounds} (best so far, by policy iteration); {phases}; time budget "
            f"{stats['timeout']:g} s, seed {stats['seed']}"
            + ("; PARTIAL: the budget ran out" if stats["partial"] else "")
        )
        if "adversaries_enumerated" in stats:
            click.echo(
                f"  adversaries: {stats['adversaries_enumerated']} enumerated"
                + (" (all of them)" if stats["exhaustive"] else "")
                + f", {stats['adversaries_ranked']} ranked by strength, defence composed against "
                f"{stats['adversaries_kept']} ({stats['adversaries_added']} added by the double "
                f"oracle); reported defence: {stats['defence']}'s; vs_fss_adversary over "
                f"{stats['vs_adversaries']}, of the {stats['vs_fss_defence']} defence")
    if getattr(r, "memory", ()):
        click.echo("  memory: " + ", ".join(f"{p or 'agent'}={k}" for p, k in r.memory))


def print_multi(r: Any) -> None:
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
        line = f"{r.property}: {'NaN' if r.value != r.value else fmt(r.value)}"
        what = ("proven (see the note)" if r.sound else
                "LP value: floating point, see the note" if r.method.startswith("lp")
                else "from an under-approximation, see the note")
        line += f"  ({r.method}, {r.seconds:.3f} s)  {what}"
        click.echo(line)
    if r.note:
        click.echo(f"  note: {r.note}")


def print_header(
    model: str, stats: dict[str, Any], seconds: float, warnings: Sequence[str]
) -> None:
    click.echo(
        f"Model {model}: {stats['type']}, {stats['states']} states, {stats['choices']} choices, "
        f"{stats['transitions']} transitions (built in {seconds:.3f} s)"
    )
    for w in warnings:
        click.echo(f"warning: {w}", err=True)


def print_outcome(r: Any) -> None:
    """One property's result (or error) as text; click.echo flushes, so it shows at once."""
    if isinstance(r, tuple):
        click.echo(f"{r[0]}: ERROR")
        click.echo(r[1].render(), err=True)
        return
    if getattr(r, "multi", None) is not None:
        print_multi(r)
        return
    line = f"{r.property}: {fmt(r.value)}"
    if r.exact is not None:
        line = f"{r.property}: {format_value(r.exact)}"
    if r.lower is not None and not isinstance(r.value, bool):
        line += f"  [{fmt(r.lower)}, {fmt(r.upper)}]"
    line += f"  ({r.method}, {r.iterations} it., {r.seconds:.3f} s)"
    if r.value is None:
        line += "  (the proven bounds do not decide it, even after refining)"
    if not r.converged:
        line += ("  NOT CONVERGED: the bounds hold but are wider than the precision (iteration"
                 " cap, or rounding of the model's numbers along very long expected paths)")
    if not r.sound:
        line += "  NOT PROVEN: bounds did not separate or the method is unsound"
    click.echo(line)
    print_strategy_numbers(r)
    if r.note:
        click.echo(f"  note: {r.note}")


def print_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]]
) -> None:
    first = rows[0][1]
    print_header(model, first.model.statistics(), first.build_seconds, first.warnings)
    if len(rows) == 1:
        for r in first.outcomes:
            print_outcome(r)
        return
    for i, r0 in enumerate(first.outcomes):
        click.echo(f"\n{r0[0] if isinstance(r0, tuple) else r0.property}:")
        click.echo("\t".join(swept + ["Result"]))
        for constants, report in rows:
            r = report.outcomes[i]
            value = "Error" if isinstance(r, tuple) else fmt(r.value)
            click.echo("\t".join([const_text(constants[n]) for n in swept] + [value]))
            if isinstance(r, tuple):
                click.echo(r[1].render(), err=True)
