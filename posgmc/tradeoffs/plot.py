"""Pictures of trade-offs (matplotlib, an optional extra: ``pip install posgmc[plot]``)."""

from __future__ import annotations

import math
from pathlib import Path

from posgmc.errors import InputError, UnsupportedError
from posgmc.io.atomic import atomic_open
from posgmc.tradeoffs.sweep import Sweep

__all__ = ["plot_sweep"]


def plot_sweep(s: Sweep, path: str | Path, *, title: str | None = None) -> None:
    """The property against the swept constant: the main number of each point (``guaranteed`` or
    the optimum) with its proven bounds as error bars and its value written beside it, and, where
    present, the full-observation bound and ``upper_bound`` as dashed lines. The format follows
    the file name (``.png``, ``.svg``, ``.pdf``).

    Raises:
        UnsupportedError: matplotlib is not installed.
        InputError: no point has a number to draw, or an unknown file type.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UnsupportedError("plots need matplotlib", hint="pip install 'posgmc[plot]'") from None
    suffix = Path(path).suffix.lower()
    if suffix not in (".png", ".svg", ".pdf"):
        raise InputError(f"{path}: a plot is written as .png, .svg or .pdf")
    xs, ys, lo, hi, full, ub, labels = [], [], [], [], [], [], []
    for p in s.points:
        b = p.main_number()
        if b is None or math.isnan(p.x):
            continue
        xs.append(p.x)
        ys.append(b.value)
        lo.append(max(0.0, b.value - b.lower))
        hi.append(max(0.0, b.upper - b.value))
        r = p.result
        full.append(r.full_observation.value if r is not None and r.full_observation else math.nan)
        ub.append(r.upper_bound.value if r is not None and r.upper_bound else math.nan)
        labels.append(f"{b.value:.4g}")
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
    with atomic_open(path, "wb", encoding=None) as handle:  # never a half-written picture
        fig.savefig(handle, format=suffix[1:])
    plt.close(fig)
