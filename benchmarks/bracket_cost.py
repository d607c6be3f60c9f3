"""What the optimum bracket costs when no --gap is asked for: the same synthesis with and without
the bound side (``SynthesisOptions.bracket``), wall-clock seconds of each and the difference.

Usage:
    python benchmarks/bracket_cost.py

The budget counts from the start of each run (loading included), as the CLI's does. Prints a
markdown table: model, property, --timeout, seconds without and with the bracket, the increase,
guaranteed (the same in both: the search is untouched) and the bracket.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = (
    ("models/tiger/tiger.pomdp", 'R{"cost"}min=? [ F "opened" ]', 5.0),
    ("tests/data/benchmarks/pomdp/nrp-8/sketch.templ", 'Pmax=? [ F "unfair" ]', 10.0),
    ("models/beacon/beacon.posg", '<<rover>> Pmax=? [ F "safe" ]', 10.0),
    ("models/trap_grid/trap_grid.pomdp", 'Pmax=? [ F "goal" ]', 10.0),
)


def main() -> None:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.synthesis.options import SynthesisOptions

    print("| model | property | --timeout | s without | s with | increase | guaranteed "
          "(without / with) | optimum |")
    print("|---|---|---|---|---|---|---|---|")
    for path, prop, timeout in CASES:
        row = []
        for bracket in (False, True):
            t0 = time.perf_counter()
            r = api.check(api.load(ROOT / path), properties=[prop],
                          synthesis=SynthesisOptions(timeout=timeout, bracket=bracket,
                                                     started=t0)).results[0]
            row.append((time.perf_counter() - t0, r))
        (t_off, off), (t_on, on) = row
        assert off.guaranteed is not None and on.guaranteed is not None  # noqa: S101
        o = on.optimum
        bracket_text = "-" if o is None else f"[{o.lower:.6f}, {o.upper:.6f}]"
        print(f"| {path} | `{prop}` | {timeout:g} | {t_off:.2f} | {t_on:.2f} "
              f"| {100 * (t_on / t_off - 1):.1f} % | {off.guaranteed.value:.6f} / "
              f"{on.guaranteed.value:.6f} | {bracket_text} |", flush=True)


if __name__ == "__main__":
    main()
