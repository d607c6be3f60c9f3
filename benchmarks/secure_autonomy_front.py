"""The secure-autonomy trade-off front: mission success against the take-down budget, for
defences of memory k◦ = 1 and 2 (models/secure_autonomy/README.md shows the picture).

Usage::

    python benchmarks/secure_autonomy_front.py [--n 3] [--flash true] [--budgets 0:2]
        [--memory 1 --memory 2] [--timeout 60,120] [--out models/secure_autonomy/front]
        [--strategies DIR]

Each ``--memory`` is one series, with the synthesis's memory sizes (``1..2``: memory 1 first,
then 2, the best defence kept: the way ``check --memory 1..2`` searches); ``--timeout`` gives
each series its seconds per point. For every budget B and series a defence is synthesised for
``<<planner>> Pmax=? [ F "retrieved" ]`` (posgmc.tradeoffs.sweep, one synthesis per point, the
``--timeout`` of each memory size per point) and verified: its ``guaranteed`` number, with proven
bounds, is what it achieves against every adversary. Writes ``OUT.png`` (both series, the
full-observation bound dashed) and ``OUT.csv`` (one row per point and memory size), and prints
the time of each series. ``--strategies DIR`` keeps each point's strategies as
``DIR/k=<memory>/B=<b>/planner.json`` (``posgmc check --strategy`` re-verifies them).
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
PROP = '<<planner>> Pmax=? [ F "retrieved" ]'


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="3")
    parser.add_argument("--flash", default="true")
    parser.add_argument("--budgets", default="0:2")
    parser.add_argument("--memory", action="append", default=None,
                        help="memory sizes of one series (repeatable; default 1 and 2)")
    parser.add_argument("--timeout", default="60,120", help="seconds per point, per series")
    parser.add_argument("--out", type=Path, default=ROOT / "models" / "secure_autonomy" / "front")
    parser.add_argument("--strategies", type=Path, default=None)
    args = parser.parse_args(argv)

    from posgmc.io.atomic import atomic_write_text
    from posgmc.synthesis.options import SynthesisOptions
    from posgmc.tradeoffs.plot import plot_sweeps
    from posgmc.tradeoffs.sweep import Sweep, sweep

    lo, hi = (int(x) for x in args.budgets.split(":"))
    budgets = [str(b) for b in range(lo, hi + 1)]
    timeouts = [float(t) for t in args.timeout.split(",")]
    series = []
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["series", "B", "guaranteed", "lower", "upper", "full_observation", "seconds"])
    for k, timeout in zip(args.memory or ["1", "2"], timeouts):
        lo_k, _, hi_k = k.partition("..")
        sizes = tuple(range(int(lo_k), int(hi_k or lo_k) + 1))
        start = time.perf_counter()
        where = args.strategies / f"k={k}" if args.strategies else None
        s = sweep(MODEL, PROP, constant="B", settings=budgets,
                  constants={"N": args.n, "flash": args.flash},
                  synthesis=SynthesisOptions(memory=sizes, timeout=timeout), strategy_dir=where)
        seconds = time.perf_counter() - start
        print(f"k={k}: {len(budgets)} points in {seconds:.0f} s (timeout {timeout:g} s per point)")
        for p in s.points:
            b = p.main_number()
            full = p.result.full_observation.value if p.result and p.result.full_observation else ""
            if p.error is not None:
                print(f"  B={p.setting}: error: {p.error.message}")
            else:
                used = ",".join(f"{n}={m}" for n, m in p.result.memory)
                print(
                    f"  B={p.setting}: guaranteed {b.value:.10g} [{b.lower:.10g}, {b.upper:.10g}], "
                    f"full observation {full}, memory {used}"
                )
            w.writerow([k, p.setting, *(("", "", "") if b is None else (b.value, b.lower, b.upper)),
                        full, f"{p.result.seconds:.1f}" if p.result else ""])
        series.append(Sweep("B", f"k◦={k}: guaranteed (proven bounds)", s.points))
    atomic_write_text(str(args.out) + ".csv", out.getvalue())
    plot_sweeps(series, str(args.out) + ".png")
    print(f"wrote {args.out}.png and {args.out}.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
