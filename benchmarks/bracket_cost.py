"""What the optimum bracket costs when no --gap is asked for: the same synthesis with and without
the bound side (``SynthesisOptions.bracket``), with the default work budget (effort 1, no
wall-clock cap, so both runs do the same search), CPU seconds of each and the difference.

Usage:
    python benchmarks/bracket_cost.py

Target: the bracket's default grid makes synthesis at most 10 % slower. CPU seconds (this process's
user + system time, loading excluded) are what is compared: on a shared machine wall time mostly
measures the other jobs. Prints a markdown table: model, property, CPU seconds without and with the
bracket, the increase, wall seconds of both, guaranteed (the same in both: the search is
untouched) and the bracket; then the 1-minute load average. One untimed synthesis with the
bracket runs first: the process's one-time costs (lazy imports, compiled kernels, about 0.35 s)
would otherwise fall on the first timed run, the one without the bracket, and hide part of the
bracket's cost.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = (
    ("models/rover.posg", '<<rover>> Pmax=? [ !"crash" U "goal" ]'),
    ("models/tiger/tiger.pomdp", 'R{"cost"}min=? [ F "opened" ]'),
    ("tests/data/benchmarks/pomdp/nrp-8/sketch.templ", 'Pmax=? [ F "unfair" ]'),
    ("models/beacon/beacon.posg", '<<rover>> Pmax=? [ F "safe" ]'),
    ("models/trap_grid/trap_grid.pomdp", 'Pmax=? [ F "goal" ]'),
)


def main() -> None:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.engines.support_cache import clear_all
    from posgmc.synthesis.options import SynthesisOptions

    warm, warm_prop = CASES[-1]
    api.check(api.load(ROOT / warm), properties=[warm_prop],
              synthesis=SynthesisOptions(bracket=True))
    print("| model | property | CPU s without | CPU s with | increase | wall s (without / "
          "with) | guaranteed (without / with) | optimum |")
    print("|---|---|---|---|---|---|---|---|")
    for path, prop in CASES:
        model = api.load(ROOT / path)
        row = []
        for bracket in (False, True):
            clear_all()  # each run as a fresh command: no graph search remembered from the other
            c0, t0 = time.process_time(), time.perf_counter()
            r = api.check(model, properties=[prop],
                          synthesis=SynthesisOptions(bracket=bracket)).results[0]
            row.append((time.process_time() - c0, time.perf_counter() - t0, r))
        (c_off, t_off, off), (c_on, t_on, on) = row
        assert off.guaranteed is not None and on.guaranteed is not None  # noqa: S101
        o = on.optimum
        bracket_text = "-" if o is None else f"[{o.lower:.10g}, {o.upper:.10g}]"
        print(f"| {path} | `{prop}` | {c_off:.2f} | {c_on:.2f} "
              f"| {100 * (c_on / c_off - 1):.1f} % | {t_off:.1f} / {t_on:.1f} "
              f"| {off.guaranteed.value:.10g} / {on.guaranteed.value:.10g} | {bracket_text} |",
              flush=True)
    print(f"\nload average (1 min) at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
