"""How ``check`` shows its results: one line per property with its proven bounds and what each
number means, sweep tables, and the JSON documents of docs/cli.md."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import click

from posgmc.checking.result_text import point_text
from posgmc.cli.constants import const_json, const_text

if TYPE_CHECKING:
    from posgmc.api import CheckReport

__all__ = ["fmt", "interrupt_summary", "outcome_json", "json_report", "print_header",
           "print_outcome", "print_report"]


def outcome_json(r: Any) -> dict[str, Any]:
    if isinstance(r, tuple):
        return {"property": r[0], "error": r[1].render()}
    return r.to_json()  # type: ignore[no-any-return]


def json_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]],
    points: Mapping[str, Any] | None = None, *, sweep: bool | None = None,
) -> dict[str, Any]:
    """``check --json``: one point's report, or a sweep's ``runs`` with ``points``, where the
    points ran (executor, workers, and the ``"constant point"`` tasks with their seconds, and
    the points an interrupt cancelled); ``sweep``: whether the rows are a sweep's (default: more
    than one row; an interrupted sweep may have finished one)."""
    def one(constants: Mapping[str, object], report: CheckReport) -> dict[str, Any]:
        stats = report.model.statistics()
        return {
            "constants": {n: const_json(v) for n, v in constants.items()},
            "model": {k: stats[k] for k in ("type", "states", "choices", "transitions")},
            "build_seconds": round(report.build_seconds, 6),
            "results": [outcome_json(r) for r in report.outcomes],
        }

    if not (len(rows) > 1 if sweep is None else sweep):
        out = {"model_file": model, **one(*rows[0])}
        return out
    out = {"model_file": model, "swept": swept, "runs": [one(c, r) for c, r in rows]}
    if points is not None:
        out["points"] = dict(points)
    return out


def fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return "unknown"
    return f"{v:.10g}"


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


def print_outcome(r: Any, *, verbose: bool = False, seen: set[str] | None = None) -> None:
    """One property's result (or error) as text (:mod:`posgmc.checking.result_text`); notes in
    ``seen`` are not repeated; click.echo flushes, so it shows at once."""
    from posgmc.checking.result_text import result_lines

    if not isinstance(r, tuple) and getattr(r, "multi", None) is not None:
        print_multi(r)
        return
    for line in result_lines(r, verbose=verbose, seen=seen):
        click.echo(line)
    if isinstance(r, tuple):
        click.echo(r[1].render(), err=True)


def print_report(
    model: str, swept: list[str], rows: Sequence[tuple[Mapping[str, object], CheckReport]],
    *, verbose: bool = False, sweep: bool | None = None,
) -> None:
    """One point's results, or a sweep's table per property (``sweep``: whether the rows are a
    sweep's; default: more than one row)."""
    first = rows[0][1]
    print_header(model, first.model.statistics(), first.build_seconds, first.warnings)
    if not (len(rows) > 1 if sweep is None else sweep):
        seen: set[str] = set()
        for r in first.outcomes:
            print_outcome(r, verbose=verbose, seen=seen)
        return
    for i, r0 in enumerate(first.outcomes):
        click.echo(f"\n{r0[0] if isinstance(r0, tuple) else r0.property}:")
        click.echo("\t".join(swept + ["Result"]))
        for constants, report in rows:
            r = report.outcomes[i]
            value = "Error" if isinstance(r, tuple) else \
                point_text(r.value, r.lower, r.upper, settled=r.converged and r.sound)
            click.echo("\t".join([const_text(constants[n]) for n in swept] + [value]))
            if isinstance(r, tuple):
                click.echo(r[1].render(), err=True)


def interrupt_summary(finished: Sequence[str], cut: Sequence[str],
                      cancelled: Sequence[str]) -> str:
    """The line an interrupted sweep or front ends with: the points that finished (``cut``: those
    of them the interrupt cut short, which report their best verified defence) and the points
    cancelled (not started, or cut on Ray: no result)."""
    total = len(finished) + len(cancelled)
    line = (f"interrupted: {len(finished)} of {total} points finished"
            + (f" ({'; '.join(finished)})" if finished else ""))
    if cut:
        line += f"; cut short, their best verified defence reported: {'; '.join(cut)}"
    if cancelled:
        line += f"; cancelled: {'; '.join(cancelled)}"
    return line
