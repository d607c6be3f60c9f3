"""Strategy products at scale: build time of the product with a k-node strategy and the time of
the `guaranteed` check on it, for k = 1, 2, 4.

Usage: python benchmarks/product_bench.py [--n 80] [--budget 4] [--repeat 3] [--seed 0]

The model is benchmarks/models/jammer_grid.posg (the rover observes its cell only). For each k a
random randomised strategy is drawn (seeded): in every (memory, observation) a distribution over the
labels the observation offers (staying put 20 times less likely) and over next memory nodes. Prints
a markdown table with the product's size, the product build time, the check time and the value with
its bounds (medians of --repeat runs in this process).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from posgmc import api
from posgmc.engines.support_cache import clear_all
from posgmc.strategies.binding import bind, player_view
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import strategy_product
from posgmc.strategies.verify import StrategyChecker
from posgmc.syntax import parser

MODEL = Path(__file__).resolve().parent / "models" / "jammer_grid.posg"
PROP = '<<rover>> Pmax=? [ F<={steps} "goal" ]'  # 8N steps: 4N rover moves (2N-2 needed)


def random_strategy(model, k: int, rng: np.random.Generator) -> FiniteStateStrategy:  # type: ignore[no-untyped-def]
    view = player_view(model, 0)
    owned = model.state_players == 0
    rows = np.flatnonzero(owned[model.choice_states])
    Z, A = view.num_observations, len(model.action_names)
    offered = np.zeros((Z, A), dtype=bool)
    offered[view.state_obs[model.choice_states[rows]], model.choice_actions[rows]] = True
    used = np.flatnonzero(offered.any(axis=0))
    gamma = rng.random((k, Z, used.size)) * offered[None][:, :, used]
    stay = [i for i, a in enumerate(used.tolist()) if model.action_names[a] == "stay"]
    gamma[:, :, stay] *= 0.05  # mostly moving, so that the goal is reached within the horizon
    gamma /= gamma.sum(axis=2, keepdims=True)
    delta = rng.random((k, Z, used.size, k)) ** 4
    delta /= delta.sum(axis=3, keepdims=True)
    return FiniteStateStrategy.from_arrays(
        player="rover", observables=view.observables, observation_values=view.obs_values,
        actions=tuple(model.action_names[a] for a in used), action=gamma, update=delta,
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=80)
    ap.add_argument("--budget", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    session = api.load(MODEL, constants={"N": args.n, "B": args.budget})
    started = time.perf_counter()
    model = api.build(session).model
    build = time.perf_counter() - started
    print(
        f"model N={args.n}, B={args.budget}: {model.num_states:,} states, "
        f"{model.num_choices:,} choices, {model.num_transitions:,} transitions "
        f"(built in {build:.2f} s)"
    )
    prop = PROP.format(steps=8 * args.n)
    print(f"property: {prop}")
    print()
    print("| k | product states | product choices | product transitions | product build (s) | "
          "guaranteed check (s) | guaranteed [lower, upper] |")
    print("|---|---|---|---|---|---|---|")
    expr = parser.parse_property(prop).expr
    for k in (1, 2, 4):
        fss = random_strategy(model, k, np.random.default_rng(args.seed + k))
        builds, checks = [], []
        for _ in range(args.repeat):
            clear_all()  # every repetition as a fresh command: no graph search remembered
            t0 = time.perf_counter()
            product = strategy_product(model, [bind(model, fss)])
            builds.append(time.perf_counter() - t0)
            checker = StrategyChecker(model, {"rover": fss},
                                      coalition_of=api._resolver(model, False).coalition_of,
                                      scalar=api._scalar)
            t0 = time.perf_counter()
            r = checker.check(expr, text=prop)
            checks.append(time.perf_counter() - t0)
        pm = product.model
        g = r.guaranteed
        print(f"| {k} | {pm.num_states:,} | {pm.num_choices:,} | {pm.num_transitions:,} | "
              f"{statistics.median(builds):.2f} | {statistics.median(checks):.2f} | "
              f"{g.value:.10g} [{g.lower:.10g}, {g.upper:.10g}] |")


if __name__ == "__main__":
    main()
