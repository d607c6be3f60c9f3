"""The secure-autonomy defender front: guaranteed mission success against guaranteed expected
discounted time, for defences of memory k◦ = 1 and 2 (models/secure_autonomy/README.md shows it).

Usage::

    python benchmarks/secure_autonomy_defence_front.py [--n 3] [--flash true] [--budget 0,1]
        [--weights 0,5,10,20,40] [--memory 1 --memory 2] [--effort 1] [--timeout SECONDS]
        [--jobs N] [--max-cost 14,16] [--out models/secure_autonomy/defence_front]
        [--strategies DIR] [--no-readme]

For every take-down budget B (``--budget``), series (``--memory``) and weight one defence is
synthesised by scalarisation (:func:`posgmc.tradeoffs.defence.defence_front`: minimise discounted
time minus ``w`` times the discounted probability of retrieving; ``w = inf`` is the mission itself)
and verified: its ``guaranteed`` P(retrieved) and its ``guaranteed`` expected discounted time, each
with proven bounds against every adversary, from its exported ``posgmc-fss/1`` file. The extent
of each synthesis is the deterministic work budget (``--effort``, docs/synthesis.md), so the
numbers depend only on the options and the seed, never on the machine; ``--timeout`` is an
optional wall-clock cap per defence. ``--jobs N`` synthesises a series' weights on a local pool
of N processes (the same numbers as one process: each weight is an independent task; the CPU
seconds printed include the pool's). Writes ``OUT.png`` (both series) and ``OUT.csv`` (one row per
point), prints each series' points and CPU and wall seconds, and the answer to "max guaranteed
P(retrieved) s.t. guaranteed discounted time <= c" for each ``--max-cost c`` (a single defence,
or a verified mixture of two); unless ``--no-readme``, rewrites the two tables
``secure_autonomy_defence_front`` and ``secure_autonomy_defence_budgets`` of the model's README.
"""

from __future__ import annotations

import argparse
import csv
import io
import resource
import sys
import time
from pathlib import Path
from typing import Any

from _readme_block import rewrite_block  # this folder is on sys.path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
MISSION = '<<planner>> Pmax=? [ F "retrieved" ]'
COST = '<<planner>> R{"time"}min=? [ Fdiscount=0.95 "retrieved" ]'
README = MODEL.parent / "README.md"


def _cpu() -> float:
    """CPU seconds of this process and of its ended children (a series' pool ends with it)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _weight(w: float) -> str:
    return "inf" if w == float("inf") else f"{w:g}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="3")
    parser.add_argument("--flash", default="true")
    parser.add_argument("--budget", default="0", help="the adversary's take-down budgets B")
    parser.add_argument("--weights", default="0,5,10,20,40")
    parser.add_argument("--max-cost", default="", help="cost constraints c to answer")
    parser.add_argument("--memory", action="append", type=int, default=None)
    parser.add_argument("--effort", type=float, default=1.0,
                        help="the work budget's multiplier of every synthesis (default 1)")
    parser.add_argument("--timeout", type=float, default=None,
                        help="an optional wall-clock cap in seconds per defence")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=1,
                        help="a series' weights on a local pool of this many processes")
    parser.add_argument("--no-readme", action="store_true",
                        help="do not rewrite the tables in models/secure_autonomy/README.md")
    parser.add_argument("--out", type=Path,
                        default=ROOT / "models" / "secure_autonomy" / "defence_front")
    parser.add_argument("--strategies", type=Path, default=None)
    args = parser.parse_args(argv)

    from posgmc.io.atomic import atomic_write_text
    from posgmc.synthesis.tasks import Placement
    from posgmc.tradeoffs.defence import defence_front
    from posgmc.tradeoffs.plot import plot_defence_fronts

    weights = [float(w) for w in args.weights.split(",")]
    max_costs = [float(c) for c in args.max_cost.split(",") if c]
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["B", "series", "weight", "mission", "mission_lower", "mission_upper", "cost",
                "cost_lower", "cost_upper", "on_front", "seconds"])
    fronts = []
    front_rows: list[str] = []
    budget_rows: list[str] = []
    total, total_cpu = time.perf_counter(), _cpu()
    for budget in args.budget.split(","):
        for k in args.memory or [1, 2]:
            start, cpu = time.perf_counter(), _cpu()
            where = args.strategies / f"B={budget}" / f"k={k}" if args.strategies else None
            f = defence_front(MODEL, MISSION, COST, weights=weights,
                              constants={"N": args.n, "flash": args.flash, "B": budget},
                              memory=k, timeout=args.timeout, effort=args.effort,
                              seed=args.seed, budgets=max_costs, strategy_dir=where,
                              placement=Placement(workers=args.jobs))
            print(f"B={budget}, k={k}: {len(f.points)} defences in "
                  f"{time.perf_counter() - start:.0f} s wall, {_cpu() - cpu:.0f} s CPU "
                  f"(effort {args.effort:g}, {args.jobs} job(s))")
            front_rows += _front_rows(budget, k, f)
            budget_rows.append(_budget_row(budget, k, f))
            for i, p in enumerate(f.points):
                if p.error is not None or p.mission is None or p.cost is None:
                    print(
                        f"  w={p.weight:g}: error: {p.error.message if p.error else 'unverified'}"
                    )
                    continue
                print(f"  w={p.weight:g}: P(retrieved) {p.mission.value:.10g} "
                      f"[{p.mission.lower:.10g}, {p.mission.upper:.10g}], discounted time "
                      f"{p.cost.value:.10g} [{p.cost.lower:.10g}, {p.cost.upper:.10g}]"
                      f"{'  (front)' if i in f.front else ''}"
                      f"{'  PARTIAL' if p.partial else ''}  {p.seconds:.0f} s")
                w.writerow([budget, k, p.weight, p.mission.value, p.mission.lower,
                            p.mission.upper, p.cost.value, p.cost.lower, p.cost.upper,
                            i in f.front, f"{p.seconds:.1f}"])
            for a in f.budgets:
                p = a.point
                if p is None or p.mission is None or p.cost is None:
                    print(f"  time <= {a.budget:g}: no verified defence meets it")
                    continue
                how = (f"mixture of w={f.points[a.mixed[1]].weight:g} (prob. {a.mixed[2]:.4g}) and "
                       f"w={f.points[a.mixed[0]].weight:g}" if a.mixed else f"w={p.weight:g}")
                print(f"  time <= {a.budget:g}: P(retrieved) >= {p.mission.lower:.10g} by the "
                      f"{how} (time <= {p.cost.upper:.10g})")
            fronts.append((f"B={budget}, k◦={k}", f))
    atomic_write_text(str(args.out) + ".csv", out.getvalue())
    plot_defence_fronts(fronts, str(args.out) + ".png",
                        title=f"secure autonomy N={args.n}, flash={args.flash}: defences, "
                        "mission against discounted time")
    print(f"wrote {args.out}.png and {args.out}.csv in {time.perf_counter() - total:.0f} s wall, "
          f"{_cpu() - total_cpu:.0f} s CPU")
    if not args.no_readme:
        front = ["| B | k◦ | defence | guaranteed P(retrieved) | guaranteed discounted time "
                 "(at most) |", "|---|---|---|---|---|", *front_rows]
        head = " | ".join(f"c = {c:g}" for c in max_costs)
        budgets = [f"| B | k◦ | {head} |", "|---|---|" + "---|" * len(max_costs), *budget_rows]
        for name, block in (("secure_autonomy_defence_front", front),
                            ("secure_autonomy_defence_budgets", budgets)):
            if rewrite_block(README, name, "\n".join(block)):
                print(f"rewrote the {name} table of {README}")
    return 0


def _front_rows(budget: str, k: int, f: Any) -> list[str]:
    """The README rows of one series' front: each verified defence no other beats on both proven
    bounds, with the weights whose searches found the same numbers."""
    rows = []
    for i in f.front:
        p = f.points[i]
        same = [_weight(q.weight) for q in f.points
                if q.mission is not None and q.cost is not None and q.error is None
                and (q.mission.value, q.cost.value) == (p.mission.value, p.cost.value)]
        rows.append(f"| {budget} | {k} | w = {', '.join(same)} | {p.mission.value:.10g} | "
                    f"{p.cost.value:.10g} |")
    return rows


def _budget_row(budget: str, k: int, f: Any) -> str:
    """The README row of one series' answers to "max P(retrieved) s.t. time <= c"."""
    cells = []
    for a in f.budgets:
        p = a.point
        if p is None or p.mission is None or p.cost is None:
            cells.append("none")
        elif a.mixed:
            cells.append(f"{p.mission.lower:.10g} (w = {_weight(f.points[a.mixed[1]].weight)} "
                         f"with probability {a.mixed[2]:.3g}, else w = "
                         f"{_weight(f.points[a.mixed[0]].weight)}; time <= {p.cost.upper:.10g})")
        else:
            cells.append(f"{p.mission.lower:.10g} (w = {_weight(p.weight)})")
    return f"| {budget} | {k} | " + " | ".join(cells) + " |"


if __name__ == "__main__":
    sys.exit(main())
