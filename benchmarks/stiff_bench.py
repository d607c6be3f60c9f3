"""Stiff systems: interval iteration alone against interval iteration that switches to the
policy-iteration certificate (posgmc/engines/certify.py) once it turns out stiff.

Usage: python benchmarks/stiff_bench.py [--repeat 3]

Cases:
* the rover POSG (models/rover.posg) under the 2-node strategy a synthesis run produced
  (benchmarks/models/rover_synthesised.fss.json: the rover holds with probability 0.9997 next to
  the ravine, so the loop is left with probability ~3e-4), property `guaranteed` of
  `<<rover>> Pmax=? [ !"crash" U "goal" ]`;
* a 3-state chain left with probability p per step (p = 1e-3, 1e-4, 1e-5), `Pmax=? [F goal]`
  (exact value 0.3 by hand).

"switch off" sets the stiffness threshold beyond the iteration cap (the engine before the
certificate existed), in the same process. Prints a markdown table: time (median of --repeat),
iterations, the proven bounds, for both.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import posgmc
from posgmc.engines import objectives as obj
from posgmc.engines import solving as common
from posgmc.model.explicit import make_model
from posgmc.syntax.ast import ModelType

ROOT = Path(__file__).resolve().parents[1]


def _rover() -> tuple[str, Callable[[], tuple[int, float, float]]]:
    session = posgmc.load(ROOT / "models" / "rover.posg")
    built = posgmc.build(session)
    fss = posgmc.load_strategy(ROOT / "benchmarks" / "models" / "rover_synthesised.fss.json")
    prop = '<<rover>> Pmax=? [ !"crash" U "goal" ]'

    def run() -> tuple[int, float, float]:
        r = posgmc.check(
            session, properties=[prop], strategies={"rover": fss}, built=built
        ).results[0]
        assert r.guaranteed is not None
        return r.iterations, r.guaranteed.lower, r.guaranteed.upper

    return "rover.posg, synthesised 2-node strategy, guaranteed", run


def _chain(p: float) -> tuple[str, Callable[[], tuple[int, float, float]]]:
    model = make_model(
        ModelType.MDP,
        row_groups=[0, 2, 3, 4],
        transitions=[[1 - p, 0.3 * p, 0.7 * p], [0.0, 0.25, 0.75], [0, 1, 0], [0, 0, 1]],
        labels={"goal": [False, True, False]},
    )

    def run() -> tuple[int, float, float]:
        r = obj.reach_probability(model, model.label("goal"), maximize=np.full(3, True))
        return r.iterations, float(r.lower[0]), float(r.upper[0])

    return f"chain left with p = {p:g}, Pmax (exact 0.3)", run


def _measure(
    run: Callable[[], tuple[int, float, float]], repeat: int
) -> tuple[float, tuple[int, float, float]]:
    times = []
    out = run()
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    cases = [_rover(), _chain(1e-3), _chain(1e-4), _chain(1e-5)]
    print("| case | switch | seconds | iterations | proven bounds |")
    print("|---|---|---|---|---|")
    default = common._STIFF_STEPS
    for name, run in cases:
        for label, steps in (("on (default)", default), ("off", 10**12)):
            common._STIFF_STEPS = steps
            try:
                seconds, (it, lo, hi) = _measure(run, args.repeat)
            finally:
                common._STIFF_STEPS = default
            print(f"| {name} | {label} | {seconds:.3f} | {it} | [{lo:.10f}, {hi:.10f}] |")


if __name__ == "__main__":
    main()
