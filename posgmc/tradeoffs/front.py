"""Multi-objective trade-offs on mdps: PRISM's ``multi(...)`` as a library call, and its CSV.

``multi_objective(path, 'multi(Pmax=? [F "goal"], R{"cost"}min=? [C])')`` answers any of the three
forms (achievability, numerical, Pareto) with the typed
:class:`~posgmc.checking.multi.MultiAnswer`; a Pareto query's
:class:`~posgmc.checking.multi.Front` holds the achievable vertices (under-approximation), the
vertices of the over-approximation and the distance between them
(:mod:`posgmc.checking.multi` says how they are computed and what the numbers are worth).
:func:`front_to_csv` writes a front for scripts, :func:`posgmc.tradeoffs.plot.plot_front` draws it.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from posgmc.checking.multi_objectives import Front, MultiAnswer
from posgmc.errors import InputError

__all__ = ["multi_objective", "front_to_csv"]


def multi_objective(
    path: str | Path, prop: str, *, constants: Mapping[str, Any] | None = None
) -> MultiAnswer:
    """Answer one ``multi(...)`` query on the model at ``path``.

    Args:
        path: an mdp (PRISM language or DRN).
        prop: the query, e.g. ``'multi(Pmax=? [ F "goal" ], R{"cost"}<=20 [ C ])'``.
        constants: values of the model's undefined constants.

    Returns:
        The typed answer (``kind``, ``achievable``/``decided``/``margin``, ``value``, ``front``).

    Raises:
        PosgmcError: the model or the query is invalid, or outside the supported fragment.
    """
    from posgmc import api

    if not prop.lstrip().startswith("multi"):
        raise InputError(f"not a multi(...) query: {prop}",
                         hint='e.g. multi(Pmax=? [ F "goal" ], R{"cost"}min=? [ C ])')
    report = api.check(api.load(path, constants=dict(constants or {})), properties=[prop])
    outcome = report.outcomes[0]
    if isinstance(outcome, api.PropertyError):
        raise outcome.error
    return outcome.multi  # type: ignore[no-any-return]


def front_to_csv(front: Front) -> str:
    """A front as CSV: a header ``kind,<objective 1>,...,<objective n>``, then one row per
    achievable vertex (``achievable``) and per vertex of the over-approximation
    (``over_approximation``), and a last row ``precision,<distance>,`` (empty cells after it)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["kind", *front.objectives])
    for p in front.points:
        w.writerow(["achievable", *(repr(float(v)) for v in p)])
    for p in front.corners:
        w.writerow(["over_approximation", *(repr(float(v)) for v in p)])
    w.writerow(["precision", repr(float(front.precision)), *([""] * (len(front.objectives) - 1))])
    return out.getvalue()
