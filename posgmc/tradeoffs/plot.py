"""Pictures of trade-offs (matplotlib, an optional extra: ``pip install posgmc[plot]``)."""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from posgmc.checking.results import Bound
from posgmc.errors import InputError, UnsupportedError
from posgmc.io.atomic import atomic_open
from posgmc.tradeoffs.sweep import Sweep, SweepPoint

if TYPE_CHECKING:
    from posgmc.checking.multi_objectives import Front
    from posgmc.tradeoffs.defence import DefenceFront

__all__ = ["plot_sweep", "plot_sweeps", "plot_front", "plot_defence_fronts", "require_matplotlib"]


def require_matplotlib() -> None:
    """Check that plots can be drawn, before the work whose results they draw.

    Raises:
        UnsupportedError: matplotlib is not installed.
    """
    _pyplot()


def _pyplot() -> ModuleType:
    """matplotlib's pyplot, imported on first use (an optional extra)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UnsupportedError("plots need matplotlib", hint="pip install 'posgmc[plot]'") from None
    return plt


def _save(fig, plt, path: str | Path) -> None:  # type: ignore[no-untyped-def]
    suffix = Path(path).suffix.lower()
    with atomic_open(path, "wb", encoding=None) as handle:  # never a half-written picture
        fig.savefig(handle, format=suffix[1:])
    plt.close(fig)


def _drawn(s: Sweep) -> list[tuple[SweepPoint, Bound]]:
    """The points of a sweep that have a number to draw, with that number."""
    out = []
    for p in s.points:
        b = p.main_number()
        if b is not None and not math.isnan(p.x):
            out.append((p, b))
    return out


def _error_bars(
    drawn: list[tuple[SweepPoint, Bound]],
) -> tuple[list[float], list[float], list[float], list[float]]:
    """x, value, and the distances down to the lower and up to the upper proven bound."""
    return ([p.x for p, _ in drawn], [b.value for _, b in drawn],
            [max(0.0, b.value - b.lower) for _, b in drawn],
            [max(0.0, b.upper - b.value) for _, b in drawn])


def _check_suffix(path: str | Path) -> None:
    if Path(path).suffix.lower() not in (".png", ".svg", ".pdf"):
        raise InputError(f"{path}: a plot is written as .png, .svg or .pdf")


def plot_front(front: Front, path: str | Path, *, title: str | None = None) -> None:
    """A two-objective Pareto front (:class:`~posgmc.checking.multi.Front`): the achievable
    region (shaded, its vertices marked and annotated), the over-approximation's boundary (dashed)
    and the band between them, in the objectives' own units; a minimised objective's better
    values are the lower ones.

    Raises:
        UnsupportedError: matplotlib is not installed.
        InputError: the front is empty (the constraints cannot be met), or an unknown file type.
    """
    import numpy as np

    from posgmc.syntax.ast import Direction

    _check_suffix(path)
    if len(front.points) == 0:
        raise InputError("the front is empty: the constraints cannot be met together")
    plt = _pyplot()
    pts, corners = np.asarray(front.points), np.asarray(front.corners)
    both = np.vstack([pts, corners]) if len(corners) else pts
    span = np.maximum(both.max(axis=0) - both.min(axis=0), 1e-9)
    lo, hi = both.min(axis=0) - 0.15 * span, both.max(axis=0) + 0.15 * span
    # the worse end of each axis, where the achievable region extends to
    worse = [lo[i] if front.directions[i] is Direction.MAX else hi[i] for i in range(2)]
    region = np.vstack([[pts[0][0], worse[1]], pts, [worse[0], pts[-1][1]], [worse[0], worse[1]]])
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    ax.fill(region[:, 0], region[:, 1], alpha=0.18, label="achievable (under-approximation)")
    ax.plot(pts[:, 0], pts[:, 1], marker="o", label="Pareto front (achievable vertices)")
    if len(corners):
        band = np.vstack([pts, corners[::-1]])
        ax.fill(band[:, 0], band[:, 1], alpha=0.35, hatch="//", fill=False,
                label=f"unknown band (width {front.precision:.2g})")
        ax.plot(corners[:, 0], corners[:, 1], linestyle="--", marker="x",
                label="over-approximation (nothing beyond)")
    for x, y in pts:
        ax.annotate(f"({x:.4g}, {y:.4g})", (x, y), textcoords="offset points", xytext=(6, 6),
                    fontsize=8)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel(f"{front.objectives[0]}  ({front.directions[0].value})", fontsize=8)
    ax.set_ylabel(f"{front.objectives[1]}  ({front.directions[1].value})", fontsize=8)
    ax.set_title(title or "Pareto front", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, plt, path)


def plot_sweep(s: Sweep, path: str | Path, *, title: str | None = None) -> None:
    """The property against the swept constant: the main number of each point (``guaranteed`` or
    the optimum) with its proven bounds as error bars and its value written beside it, and, where
    present, the full-observation bound and ``upper_bound`` as dashed lines. The format follows
    the file name (``.png``, ``.svg``, ``.pdf``).

    Raises:
        UnsupportedError: matplotlib is not installed.
        InputError: no point has a number to draw, or an unknown file type.
    """
    plt = _pyplot()
    _check_suffix(path)
    drawn = _drawn(s)
    xs, ys, lo, hi = _error_bars(drawn)
    full = [p.result.full_observation.value if p.result is not None and p.result.full_observation
            else math.nan for p, _ in drawn]
    ub = [p.result.upper_bound.value if p.result is not None and p.result.upper_bound else math.nan
          for p, _ in drawn]
    labels = [f"{y:.4g}" for y in ys]
    if not xs:
        raise InputError("no point of the sweep has a number to plot")
    synthesised = any(p.result is not None and p.result.guaranteed is not None for p in s.points)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.errorbar(xs, ys, yerr=[lo, hi], marker="o", capsize=4,
                label="guaranteed (proven bounds)" if synthesised else "value (proven bounds)")
    for x, y, text in zip(xs, ys, labels):
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(6, 6), fontsize=8)
    if not all(math.isnan(v) for v in full):
        ax.plot(xs, full, linestyle="--", marker="x", label="full observation")
    if not all(math.isnan(v) for v in ub):
        ax.plot(xs, ub, linestyle=":", marker="+", label="upper_bound (vs enumerated adversaries)")
    if len(xs) <= 20 and all(float(x).is_integer() for x in xs):
        ax.set_xticks(xs)
    ax.set_xlabel(s.constant)
    ax.set_ylabel(s.property if len(s.property) < 40 else "value")
    ax.set_title(title or s.property, fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, plt, path)


def plot_sweeps(sweeps: list[Sweep], path: str | Path) -> None:
    """Several properties against one swept constant (``check --const B=0:4 --plot F``): one
    property is drawn as :func:`plot_sweep` draws it; several share the axes, each its value with
    its proven bounds as error bars (the first full-observation bound found drawn dashed).

    Raises:
        UnsupportedError: matplotlib is not installed.
        InputError: no point has a number to draw, or an unknown file type.
    """
    if len(sweeps) == 1:
        plot_sweep(sweeps[0], path)
        return
    _check_suffix(path)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    drawn, full_drawn = 0, False
    for s in sweeps:
        xs, ys, lo, hi = _error_bars(_drawn(s))
        if xs:
            drawn += 1
            ax.errorbar(xs, ys, yerr=[lo, hi], marker="o", capsize=4, label=s.property)
            for x, y in zip(xs, ys):
                ax.annotate(
                    f"{y:.4g}", (x, y), textcoords="offset points", xytext=(6, 6), fontsize=7
                )
        full = [(p.x, p.result.full_observation.value) for p in s.points
                if p.result is not None and p.result.full_observation is not None]
        if full and not full_drawn:
            full_drawn = True
            ax.plot([x for x, _ in full], [v for _, v in full], linestyle="--", marker="x",
                    color="grey", label="full observation (bound)")
    if not drawn:
        plt.close(fig)
        raise InputError("no property of the sweep has a number to plot")
    xs_all = sorted({p.x for s in sweeps for p in s.points if not math.isnan(p.x)})
    if len(xs_all) <= 20 and all(float(x).is_integer() for x in xs_all):
        ax.set_xticks(xs_all)
    ax.set_xlabel(sweeps[0].constant)
    ax.set_ylabel("value (proven bounds)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, plt, path)


def _upper_hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The concave upper hull of (cost, mission) points sorted by cost ascending: what mixing
    two neighbours reaches (mission at least, cost at most, the mixtures of their bounds)."""
    hull: list[tuple[float, float]] = []
    for p in sorted(points):
        while len(hull) >= 2:
            (x1, y1), (x2, y2) = hull[-2], hull[-1]
            if (x2 - x1) * (p[1] - y1) - (y2 - y1) * (p[0] - x1) >= 0:
                hull.pop()  # the middle point lies on or below the chord
            else:
                break
        hull.append(p)
    return hull


def plot_defence_fronts(fronts: list[tuple[str, DefenceFront]], path: str | Path, *,
                        title: str | None = None) -> None:
    """Defender trade-off fronts (:class:`~posgmc.tradeoffs.defence.DefenceFront`), each with a
    label (e.g. ``"k◦=1"``): every verified defence as a point at (its guaranteed cost, its
    guaranteed mission) with both proven bounds as error bars, the non-dominated ones joined as a
    staircase (what the front guarantees: a defence at least this good for at most this cost),
    each annotated with its weight; dashed, the upper hull of the front, which randomised
    mixtures of two neighbouring defences reach (their proven bounds mix linearly: against the
    worst adversary a mixture does at least as well); crosses, the verified mixtures that answer
    ``--budget`` constraints; the full-observation point (no partially observing defence does
    better on either axis) as a star.

    Raises:
        UnsupportedError: matplotlib is not installed.
        InputError: no front has a verified point, or an unknown file type.
    """
    _check_suffix(path)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    drawn, full_drawn = 0, False
    for label, f in fronts:
        ok = [p for p in f.points if p.verified]
        if not ok:
            continue
        drawn += 1
        line = ax.errorbar([p.cost.value for p in ok], [p.mission.value for p in ok],  # type: ignore[union-attr]
                           xerr=[[p.cost.value - p.cost.lower for p in ok],  # type: ignore[union-attr]
                                 [p.cost.upper - p.cost.value for p in ok]],  # type: ignore[union-attr]
                           yerr=[[p.mission.value - p.mission.lower for p in ok],  # type: ignore[union-attr]
                                 [p.mission.upper - p.mission.value for p in ok]],  # type: ignore[union-attr]
                           linestyle="none", marker="o", capsize=3, alpha=0.55,
                           label=f"{label + ': ' if label else ''}verified defences")
        colour = line[0].get_color()
        best = [f.points[i] for i in f.front]
        xs = [p.cost.upper for p in best]  # type: ignore[union-attr]
        ys = [p.mission.lower for p in best]  # type: ignore[union-attr]
        sx, sy = [], []
        for i, (x, y) in enumerate(zip(xs, ys)):
            if i:
                sx.append(x)
                sy.append(ys[i - 1])
            sx.append(x)
            sy.append(y)
        ax.plot(
            sx,
            sy,
            color=colour,
            linewidth=1.5,
            label=f"{label + ': ' if label else ''}front (proven bounds)",
        )
        hull = _upper_hull(list(zip(xs, ys)))
        if len(hull) > 1:
            ax.plot([x for x, _ in hull], [y for _, y in hull], color=colour, linestyle="--",
                    linewidth=1, label=f"{label + ': ' if label else ''}randomised mixtures of two")
        answered = [a.point for a in f.budgets if a.point is not None and a.mixed is not None]
        if answered:
            ax.plot([p.cost.upper for p in answered], [p.mission.lower for p in answered],  # type: ignore[union-attr]
                    marker="x", linestyle="none", color=colour, markersize=8,
                    label=f"{label + ': ' if label else ''}--budget answers (verified mixtures)")
        for p in best:
            w = "inf" if math.isinf(p.weight) else f"{p.weight:g}"
            ax.annotate(f"w={w}: ({p.cost.value:.4g}, {p.mission.value:.4g})",  # type: ignore[union-attr]
                        (p.cost.value, p.mission.value), textcoords="offset points",  # type: ignore[union-attr]
                        xytext=(6, 6 + 8 * (drawn - 1)), fontsize=7, color=colour)
        fm, fc = f.full_observation
        if fm is not None and fc is not None and not full_drawn:
            full_drawn = True
            ax.plot([fc.value], [fm.value], marker="*", markersize=12, color="grey",
                    linestyle="none", label="full observation (bound on both)")
    if not drawn:
        plt.close(fig)
        raise InputError("no front has a verified point to plot")
    first = fronts[0][1]
    ax.set_xlabel(f"guaranteed {first.cost}  (lower is better)", fontsize=8)
    ax.set_ylabel(f"guaranteed {first.mission}", fontsize=8)
    ax.set_title(title or "defender trade-off: mission against cost", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, plt, path)
