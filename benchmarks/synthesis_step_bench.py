"""The cost of one gradient step of the synthesis search on a large product.

Usage: python benchmarks/synthesis_step_bench.py [--n 5] [--memory 2] [--steps 3] [--no-exact]

Builds models/secure_autonomy at N (flash=false, B=1), takes seeded random logits for the
planner's k-node FSS, and times `Parametrisation.evaluate` (the value against the omniscient
adversary's best response and its gradient) on the exact path (policy iteration with sparse LU
solves, then one LU of the chain and its adjoint) and on the iterative path (warm-started value
iteration), for --steps successive steps of size 0.05 in the logits (the iterative path is
warm-started from the step before). Prints a markdown table with the seconds per step, the values
and the largest difference of the two gradients. Both paths run in this process one after the
other; no reference tool computes this quantity.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from posgmc import api  # noqa: E402
from posgmc.syntax import parser  # noqa: E402
from posgmc.synthesis import parametric  # noqa: E402
from posgmc.synthesis.search import parametrisation, problem_of  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", default="5")
    ap.add_argument("--memory", type=int, default=2)
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--no-exact", action="store_true")
    args = ap.parse_args()
    session = api.load(ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg",
                       constants={"N": args.n, "flash": "false", "B": "1"})
    model = api.build(session).model
    expr = parser.parse_property('<<planner>> Pmax=? [ F "retrieved" ]').expr
    coalition_of = api._resolver(model, False).coalition_of
    player = next(iter(coalition_of(expr.coalition)))
    problem = problem_of(model, expr, player=player, adversary=1 - player,
                         coalition_of=coalition_of, scalar=api._scalar)
    exact, iterative = parametrisation(problem, args.memory), parametrisation(problem, args.memory)
    rng = np.random.default_rng(0)
    la, ld = rng.normal(size=exact.shapes[0]), rng.normal(size=exact.shapes[1])
    print(f"secure_autonomy N={args.n}: {model.num_states} states, k = {args.memory}")
    print(
        "| step | exact (s) | exact value | iterative (s) | iterative value | max gradient "
        "difference |"
    )
    print("|---|---|---|---|---|---|")
    for step in range(args.steps):
        g, d = exact.probabilities(la, ld)
        parametric.ITERATIVE_STATES = 0
        t = time.perf_counter()
        it = iterative.evaluate(g, d)
        t_it = time.perf_counter() - t
        cells = ["-", "-", "-"]
        if not args.no_exact:
            parametric.ITERATIVE_STATES = 10**12
            t = time.perf_counter()
            ex = exact.evaluate(g, d)
            t_ex = time.perf_counter() - t
            diff = max(np.abs(it.grad_action - ex.grad_action).max(),
                       np.abs(it.grad_update - ex.grad_update).max())
            cells = [f"{t_ex:.2f}", f"{ex.value:.10f}", f"{diff:.2e}"]
        print(
            f"| {step} | {cells[0]} | {cells[1]} | {t_it:.2f} | {it.value:.10f} | {cells[2]} |",
            flush=True,
        )
        la = la + 0.05 * rng.normal(size=la.shape)


if __name__ == "__main__":
    main()
