"""The secure-autonomy trade-off front: mission success against the take-down budget, for
defences of memory k◦ = 1 and 2 (models/secure_autonomy/README.md shows the picture and table).

Usage::

    python benchmarks/secure_autonomy_front.py [--n 3] [--flash true] [--budgets 0:2]
        [--memory 1 --memory 1..2] [--effort 1] [--timeout SECONDS]
        [--out models/secure_autonomy/front] [--strategies DIR] [--no-readme]

Each ``--memory`` is one series, with the synthesis's memory sizes (``1..2``: memory 1 first,
then 2, the best defence kept: the way ``check --memory 1..2`` searches). For every budget B and
series a defence is synthesised for ``<<planner>> Pmax=? [ F "retrieved" ]``
(posgmc.tradeoffs.sweep, one synthesis per point, as ``posgmc pareto --sweep B=...`` runs it)
and verified: its ``guaranteed`` number, with proven bounds, is what it achieves against every
adversary; the expected discounted time is then verified under the same defence (``--also``).
The extent of each synthesis is the deterministic work budget (``--effort``, docs/synthesis.md),
so the numbers depend only on the options and the seed, never on the machine; ``--timeout`` is
an optional wall-clock cap per point, and a point it cuts is marked in the output.

Writes ``OUT.png`` (every series, the full-observation bound dashed), ``OUT.csv`` (one row per
point and series) and, unless ``--no-readme``, the ``secure_autonomy_front`` table of the model's
README. Prints each series' points and its CPU and wall seconds. ``--strategies DIR`` keeps each
point's strategies as ``DIR/k=<memory>/B=<b>/planner.json`` (``posgmc check --strategy``
re-verifies them).
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from pathlib import Path

from _readme_block import rewrite_block  # this folder is on sys.path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
README = MODEL.parent / "README.md"
PROP = '<<planner>> Pmax=? [ F "retrieved" ]'
TIME = '<<planner>> R{"time"}min=? [ Fdiscount=0.95 "retrieved" ]'


def _cell(b: object) -> str:
    g = getattr(b, "guaranteed", None) or b
    value = getattr(g, "value", None)
    return "–" if value is None else f"{value:.10g}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="3")
    parser.add_argument("--flash", default="true")
    parser.add_argument("--budgets", default="0:2")
    parser.add_argument("--memory", action="append", default=None,
                        help="memory sizes of one series (repeatable; default 1 and 1..2)")
    parser.add_argument("--effort", type=float, default=1.0,
                        help="the work budget's multiplier of every synthesis (default 1)")
    parser.add_argument("--timeout", type=float, default=None,
                        help="an optional wall-clock cap in seconds per point")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=ROOT / "models" / "secure_autonomy" / "front")
    parser.add_argument("--strategies", type=Path, default=None)
    parser.add_argument("--no-readme", action="store_true",
                        help="do not rewrite the table in models/secure_autonomy/README.md")
    args = parser.parse_args(argv)

    from posgmc.io.atomic import atomic_write_text
    from posgmc.synthesis.options import SynthesisOptions
    from posgmc.tradeoffs.plot import plot_sweeps
    from posgmc.tradeoffs.sweep import Sweep, sweep

    lo, hi = (int(x) for x in args.budgets.split(":"))
    budgets = [str(b) for b in range(lo, hi + 1)]
    series = []
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["series", "B", "guaranteed", "lower", "upper", "time", "time_lower",
                "time_upper", "full_observation", "cut_by_timeout"])
    table: dict[str, dict[str, str]] = {b: {} for b in budgets}
    full_of: dict[str, str] = {}
    names = args.memory or ["1", "1..2"]
    for k in names:
        lo_k, _, hi_k = k.partition("..")
        sizes = tuple(range(int(lo_k), int(hi_k or lo_k) + 1))
        wall, cpu = time.perf_counter(), time.process_time()
        where = args.strategies / f"k={k}" if args.strategies else None
        # belief=False: explicit memory sizes bound the strategy, as the CLI's --memory does
        options = SynthesisOptions(memory=sizes, effort=args.effort, timeout=args.timeout,
                                   seed=args.seed, belief=False)
        s = sweep(MODEL, PROP, constant="B", settings=budgets,
                  constants={"N": args.n, "flash": args.flash}, synthesis=options,
                  strategy_dir=where, also=[TIME])
        print(f"k={k}: {len(budgets)} points in {time.perf_counter() - wall:.0f} s wall, "
              f"{time.process_time() - cpu:.0f} s CPU (effort {args.effort:g})")
        for p in s.points:
            b = p.main_number()
            full = p.result.full_observation.value if p.result and p.result.full_observation else ""
            cost = p.also[0] if p.also else None
            cut = bool(p.result and p.result.synthesis and p.result.synthesis.get("cut"))
            if p.error is not None:
                print(f"  B={p.setting}: error: {p.error.message}")
                table[p.setting][k] = "error"
                continue
            used = ",".join(f"{n}={m}" for n, m in p.result.memory)
            print(f"  B={p.setting}: guaranteed {b.value:.10g} [{b.lower:.10g}, {b.upper:.10g}], "
                  f"discounted time {_cell(cost)}, full observation {full}, memory {used}"
                  + ("  (cut by --timeout)" if cut else ""))
            g = getattr(cost, "guaranteed", None)
            w.writerow([k, p.setting, b.value, b.lower, b.upper,
                        *(("", "", "") if g is None else (g.value, g.lower, g.upper)), full, cut])
            table[p.setting][k] = (f"{b.value:.10g} (time {_cell(cost)})"
                                   + (" cut by --timeout" if cut else ""))
            full_of[p.setting] = f"{full:.10g}" if isinstance(full, float) else str(full)
        series.append(Sweep("B", f"k◦={k}: guaranteed (proven bounds)", s.points))
    atomic_write_text(str(args.out) + ".csv", out.getvalue())
    plot_sweeps(series, str(args.out) + ".png")
    print(f"wrote {args.out}.png and {args.out}.csv")
    if not args.no_readme:
        lines = ["| B | " + " | ".join(f"k◦ = {k}" for k in names) + " | full observation |",
                 "|---|" + "---|" * len(names) + "---|"]
        for b in budgets:
            lines.append(f"| {b} | " + " | ".join(table[b].get(k, "–") for k in names)
                         + f" | {full_of.get(b, '–')} |")
        if rewrite_block(README, "secure_autonomy_front", "\n".join(lines)):
            print(f"rewrote the secure_autonomy_front table of {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
