"""A trade-off front by sweeping a constant: one verified answer, and strategy, per point.

For a partially observable model every point is a synthesised defence (:mod:`posgmc.synthesis`)
with its proven ``guaranteed`` number, the ``full_observation`` bound beside it and, against the
adversary strategies enumerated, ``upper_bound``; the strategies are written one directory per
point, so a user can pick the point they want and deploy its strategy. For a fully observable
model a point is the optimal value with its proven bounds. E.g. mission success against the
adversary's take-down budget ``B = 0..2`` (models/secure_autonomy/README.md).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from posgmc.checking.results import Bound, PropertyResult
from posgmc.errors import PosgmcError
from posgmc.synthesis import progress

__all__ = ["Sweep", "SweepPoint", "sweep", "sweeps_of_check", "to_csv"]


@dataclass(frozen=True, eq=False)
class SweepPoint:
    """One point: the swept constant's ``setting`` (as given, e.g. ``"2"``), its numeric ``x``,
    and the property's result there (or the error that stopped it); ``strategy_dir`` holds the
    point's ``<player>.json`` files when strategies were written. ``also`` holds the further
    properties of the sweep (:func:`sweep`'s ``also``), each checked under the point's
    synthesised strategy: their ``guaranteed`` numbers."""

    setting: str
    x: float
    result: PropertyResult | None
    error: PosgmcError | None = None
    strategy_dir: str | None = None
    also: tuple[PropertyResult | PosgmcError, ...] = ()

    def main_number(self) -> Bound | None:
        """What the point is worth to the decision maker: ``guaranteed`` when strategies are
        synthesised, else the value with its bounds."""
        r = self.result
        if r is None:
            return None
        if r.guaranteed is not None:
            return r.guaranteed
        if isinstance(r.value, bool) or r.value is None or r.lower is None or r.upper is None:
            return None
        return Bound(float(r.value), float(r.lower), float(r.upper), r.sound)


@dataclass(frozen=True, eq=False)
class Sweep:
    """The points of one property over one swept constant, in sweep order; ``cancelled``: the
    settings an interrupt (Ctrl-C) left without a point (not started, or cut on Ray), after
    ``points``."""

    constant: str
    property: str
    points: tuple[SweepPoint, ...]
    also: tuple[str, ...] = ()
    cancelled: tuple[str, ...] = ()


def sweep(
    path: str | Path,
    prop: str,
    *,
    constant: str,
    settings: Sequence[Any],
    constants: Mapping[str, Any] | None = None,
    synthesis: Any = None,
    full_observation: bool = False,
    zero_based_players: bool = False,
    strategy_dir: str | Path | None = None,
    also: Sequence[str] = (),
    placement: Any = None,
) -> Sweep:
    """Check (or synthesise for) ``prop`` at every value of ``constant``.

    Args:
        path: the model file.
        prop: one property, e.g. ``'<<planner>> Pmax=? [ F "retrieved" ]'``.
        constant: the swept constant (undefined in the model).
        settings: its values, as ``--const`` would take them (``"0"``, ``2``, ``"1/3"``).
        constants: the other undefined constants.
        synthesis: :class:`~posgmc.synthesis.search.SynthesisOptions` for partially observable
            models (default options when None).
        strategy_dir: where to write each point's strategies, as ``<dir>/<constant>=<v>/``.
        also: further properties, each checked at every point under the decision maker's
            synthesised strategy of that point (its ``guaranteed`` number against every
            adversary): e.g. the expected cost of the defence that maximises the mission's
            success, so that every point of the front carries both verified numbers.

    Returns:
        The sweep; a point whose property fails keeps its error (the others go on, as in PRISM).
    """
    from posgmc import api
    from posgmc.synthesis.fanout import Spread, each_result
    from posgmc.synthesis.tasks import Placement

    # the model's text travels to the workers (a cluster's nodes need not see the file); a
    # file that cannot be read is the sweep's error, raised once
    text = api.load(path).source.text
    calls = [(str(path), text, prop, constant, setting, dict(constants or {}), synthesis,
              full_observation, zero_based_players, tuple(also)) for setting in settings]
    points: list[SweepPoint] = []
    spread = Spread()
    results = each_result(sweep_point, calls, placement or Placement(),
                          labels=[f"{constant}={s}" for s in settings], spread=spread)
    try:
        for point in results:
            if strategy_dir is not None and point.result is not None and point.result.strategies:
                point = _written(point, constant, strategy_dir)
            points.append(point)
            progress.point_done(f"{constant}={point.setting}",
                                None if point.result is None else point.result.headline,
                                len(points), len(settings))
    finally:
        results.close()
    _raise_common_error(points)
    cancelled = tuple(str(settings[len(points) + i]) for i in range(len(spread.cancelled)))
    return Sweep(constant, prop, tuple(points), tuple(also), cancelled)


def sweep_point(path: str, text: str, prop: str, constant: str, setting: Any,
                constants: dict[str, Any], synthesis: Any, full_observation: bool,
                zero_based_players: bool, also: tuple[str, ...]) -> SweepPoint:
    """One point of :func:`sweep`: the model (``text``, read from ``path``) with ``constants``
    and ``constant`` = ``setting``, ``prop`` checked or synthesised, the ``also`` properties under
    its defence; strategies not yet written (:func:`_written`). Plain data in and out: a task on
    any executor."""
    from posgmc import api

    label = str(setting)
    values = {**constants, constant: setting}
    try:
        session = api.load(path, text=text, constants=values)
        report = api.check(session, properties=[prop], synthesis=synthesis,
                           full_observation=full_observation,
                           zero_based_players=zero_based_players)
    except PosgmcError as e:
        return SweepPoint(label, _number(label), None, e)
    outcome = report.outcomes[0]
    if isinstance(outcome, tuple):
        return SweepPoint(label, _number(label), None, outcome[1])
    return SweepPoint(label, _number(label), outcome, None, None, _also(session, also, outcome))


def _written(point: SweepPoint, constant: str, strategy_dir: str | Path) -> SweepPoint:
    """``point`` with its strategies written to ``<strategy_dir>/<constant>=<setting>/``."""
    from posgmc.strategies.files import write_strategy

    assert point.result is not None  # noqa: S101 - a point with strategies has a result
    where = os.path.join(str(strategy_dir), f"{constant}={point.setting}")
    os.makedirs(where, exist_ok=True)
    for fss in point.result.strategies:
        write_strategy(fss, os.path.join(where, f"{fss.player or 'agent'}.json"))
    return dataclasses.replace(point, strategy_dir=where)


def _raise_common_error(points: Sequence[SweepPoint]) -> None:
    """An error that every point has alike (a constant not declared or left without a value, an
    unreadable file, a malformed property) is about the sweep, not its points: raised once, not
    reported per point.

    Raises:
        PosgmcError: the error every point has.
    """
    errors = [p.error for p in points if p.error is not None]
    if points and len(errors) == len(points) and len({e.render() for e in errors}) == 1:
        raise errors[0]


def _also(session: Any, props: Sequence[str], outcome: PropertyResult) -> tuple[Any, ...]:
    """The ``also`` properties under the decision maker's synthesised strategy of a point."""
    from posgmc import api
    from posgmc.errors import UnsupportedError

    if not props:
        return ()
    if not outcome.strategies:
        error = UnsupportedError("no synthesised strategy at this point to evaluate further "
                                 "properties under (--also needs a pomdp/posg sweep)")
        return tuple(error for _ in props)
    defence = outcome.strategies[0]  # the decision maker's; the others are adversaries found
    name = defence.player  # "" for a pomdp's agent, as load_strategies keys it
    out: list[Any] = []
    for text in props:
        try:
            report = api.check(session, properties=[text], strategies={name: defence})
            o = report.outcomes[0]
            out.append(o.error if isinstance(o, api.PropertyError) else o)
        except PosgmcError as e:
            out.append(e)
    return tuple(out)


def _also_cells(a: Any) -> list[str]:
    g = getattr(a, "guaranteed", None)
    if g is None:
        return ["", "", ""]
    return [repr(g.value), repr(g.lower), repr(g.upper)]


def sweeps_of_check(constant: str, rows: Sequence[tuple[Mapping[str, str], Any]]) -> list[Sweep]:
    """The sweeps of ``check --const B=0:4``: one per property, from the
    ``(constant settings as text, CheckReport)`` rows of the swept runs."""
    out = []
    for i, o in enumerate(rows[0][1].outcomes):
        name = o[0] if isinstance(o, tuple) else o.property
        points = []
        for constants, report in rows:
            setting = constants[constant]
            r = report.outcomes[i]
            if isinstance(r, tuple):
                points.append(SweepPoint(setting, _number(setting), None, r[1]))
            else:
                points.append(SweepPoint(setting, _number(setting), r))
        out.append(Sweep(constant, name, tuple(points)))
    return out


def _number(text: str) -> float:
    from fractions import Fraction

    try:
        return float(Fraction(text))
    except (ValueError, ZeroDivisionError):
        return math.nan


_COLUMNS = ("constant", "setting", "value", "lower", "upper",
            "full_observation", "full_observation lower", "full_observation upper",
            "upper_bound", "upper_bound lower", "upper_bound upper",
            "memory", "partial", "strategies", "error")


def _bound_cells(b: Bound | None) -> list[str]:
    """A number's value, lower and upper bound as CSV cells; empty when it was not computed."""
    return ["", "", ""] if b is None else [repr(b.value), repr(b.lower), repr(b.upper)]


def to_csv(s: Sweep) -> str:
    """The sweep as CSV: one row per point; ``value``/``lower``/``upper`` are ``guaranteed`` for
    synthesised points, the optimum otherwise; ``full_observation`` and ``upper_bound`` each with
    their proven bounds, all three cells empty where the number was not computed."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(
        list(_COLUMNS)
        + [f"{a} {part}" for a in s.also for part in ("guaranteed", "lower", "upper")]
    )
    for p in s.points:
        b = p.main_number()
        r = p.result
        full = _bound_cells(r.full_observation if r is not None else None)
        ub = _bound_cells(r.upper_bound if r is not None else None)
        memory = ";".join(f"{n}={k}" for n, k in r.memory) if r is not None else ""
        partial = bool(r.synthesis and r.synthesis.get("partial")) if r is not None else ""
        w.writerow([s.constant, p.setting,
                    "" if b is None else repr(b.value), "" if b is None else repr(b.lower),
                    "" if b is None else repr(b.upper), *full, *ub, memory, partial,
                    p.strategy_dir or "", "" if p.error is None else p.error.message]
                   + [x for a in (p.also or (None,) * len(s.also)) for x in _also_cells(a)])
    return out.getvalue()
