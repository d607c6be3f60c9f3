"""Scaling of synthesis's parallel phases over workers: secure-autonomy's adversary ranking and
candidate evaluation, in one process and on 2 workers (a local process pool, and Ray).

Usage:
    python benchmarks/scale_bench.py [--n 3 5] [--adversaries 24] [--workers 2] [--no-ray]
        [--repeat 1]

For each grid size N (models/secure_autonomy, flash=false, B=1, the planner's Pmax of retrieving
the target): the adversary's deterministic memoryless strategies are enumerated (the first
--adversaries of them) and the two phases of the adversary pipeline that fan out over workers
are run on them exactly as synthesis runs them (posgmc.synthesis.double_oracle's RankJob and
VersusJob):

* ranking: the decision maker's full-information optimum against each adversary (an MDP solve
  on the product of the model with that adversary);
* candidate evaluation: a fixed defence (the planner's uniform memoryless strategy) against each
  adversary (a Markov chain's linear solve).

Each phase runs on three executors: in this process (1 worker), a local process pool of
--workers processes, and --workers Ray actors (a Ray started on this machine; --no-ray skips
it). Printed per row: wall time, the speed-up over one worker, the overhead per task (the
workers' time not spent in jobs: workers x wall - the jobs' own seconds, per task) and the bytes
shipped per task (the job's and its result's pickles; the problem itself goes once per worker,
shown apart: on Ray without its model, which each worker builds from the model's text; Ray
sends a value the jobs of a batch share, the defence, once per batch, counted
once here). Every executor's results are checked equal to one process's. The machine's load
(uptime) is printed with the table: on a shared machine the speed-up is only as good as the
cores that are free.
"""

from __future__ import annotations

import argparse
import os
import pickle
import platform
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from posgmc import api  # noqa: E402
from posgmc.engines.support_cache import clear_all  # noqa: E402
from posgmc.syntax import parser  # noqa: E402
from posgmc.synthesis.adversaries import enumerate_adversaries  # noqa: E402
from posgmc.synthesis.double_oracle import RankJob, VersusJob  # noqa: E402
from posgmc.synthesis.executors import Executor, executor_for  # noqa: E402
from posgmc.synthesis.problem import Problem  # noqa: E402
from posgmc.synthesis.ray_pool import shared_fields  # noqa: E402
from posgmc.synthesis.ray_pool import shipped as shipped_to_ray  # noqa: E402
from posgmc.synthesis.search import parametrisation, problem_of  # noqa: E402
from posgmc.synthesis.tasks import Placement  # noqa: E402

MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
PROP = '<<planner>> Pmax=? [ F "retrieved" ]'


def problem_for(n: int) -> Problem:
    session = api.load(MODEL, constants={"N": str(n), "flash": "false", "B": "1"})
    model = api.build(session).model
    resolver = api._resolver(model, False)
    expr = parser.parse_property(PROP).expr
    player = next(iter(resolver.coalition_of(expr.coalition) or {0}))
    return problem_of(model, expr, player=player, adversary=1 - player,
                      coalition_of=resolver.coalition_of, scalar=api._scalar)


def uniform_defence(problem: Problem):  # type: ignore[no-untyped-def]
    par = parametrisation(problem, 1)
    la, ld = (np.zeros(s) for s in par.shapes)
    return par.strategy(*par.probabilities(la, ld))


def bytes_per_task(jobs: list, results: list, shares: bool) -> float:  # type: ignore[type-arg]
    """The pickles of each job and its result, averaged; ``shares``: the executor sends a value
    that several jobs share once per batch (posgmc.synthesis.ray_pool.shared_fields), counted
    once and spread over the jobs."""
    once: list[bytes] = []
    sent = shared_fields(jobs, lambda v: once.append(pickle.dumps(v, protocol=5)) or len(once)) \
        if shares else jobs
    per_job = [len(pickle.dumps(j, protocol=5)) + len(pickle.dumps(r, protocol=5))
               for j, r in zip(sent, results)]
    return float(np.mean(per_job)) + sum(map(len, once)) / len(jobs)


def timed_map(executor: Executor, jobs: list) -> tuple[list, float, float]:  # type: ignore[type-arg]
    """Results, wall seconds and the jobs' own seconds (the executor's ledger) of one batch."""
    before = sum(executor.ledger.seconds.values())
    t0 = time.perf_counter()
    out = executor.map(jobs)
    wall = time.perf_counter() - t0
    return out, wall, sum(executor.ledger.seconds.values()) - before


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[3, 5])
    ap.add_argument("--adversaries", type=int, default=24)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-ray", action="store_true")
    ap.add_argument("--repeat", type=int, default=1, help="best of this many runs per row")
    args = ap.parse_args()
    placements = [("1 process", Placement("local", 1)),
                  (f"pool x{args.workers}", Placement("local", args.workers))]
    if not args.no_ray:
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        placements.append((f"ray x{args.workers}", Placement("ray", args.workers)))
    print(f"# scale_bench: {platform.node()}, {os.cpu_count()} cores, "
          f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC")
    print(f"# command: python benchmarks/scale_bench.py --n {' '.join(map(str, args.n))} "
          f"--adversaries {args.adversaries} --workers {args.workers}"
          + (" --no-ray" if args.no_ray else "") + f" --repeat {args.repeat}")
    print()
    print("| N | states | phase | tasks | executor | wall s | speed-up | overhead/task ms "
          "| bytes/task | load (1 min) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    notes: list[str] = []
    for n in args.n:
        problem = problem_for(n)
        model = problem.model
        assert problem.adversary is not None  # noqa: S101 - a game
        adversaries = enumerate_adversaries(model, problem.adversary, memory=1,
                                            limit=args.adversaries).strategies
        defence = uniform_defence(problem)
        phases = {"ranking": [RankJob(a) for a in adversaries],
                  "candidate evaluation": [VersusJob(defence, a) for a in adversaries]}
        problem_bytes = len(pickle.dumps(problem, protocol=5))
        # what a Ray worker receives instead: the problem without its model, and the recipe
        # that builds the model from its text (posgmc.model.origin), built once per worker
        light, recipe = shipped_to_ray(problem)
        recipe_bytes = len(pickle.dumps((light, recipe), protocol=5))
        t0 = time.perf_counter()
        rebuilt = recipe() if recipe is not None else model
        rebuild_seconds = time.perf_counter() - t0
        assert rebuilt.num_states == model.num_states  # noqa: S101 - the same model
        reference: dict[str, list] = {}  # type: ignore[type-arg]
        single: dict[str, float] = {}
        for label, placement in placements:
            clear_all()  # a pool's workers fork from here: none inherits remembered searches
            executor = executor_for(problem, placement)
            try:
                for phase, jobs in phases.items():
                    best: tuple[float, float] | None = None
                    for _ in range(args.repeat):
                        clear_all()  # no graph search remembered from the last run here
                        out, wall, busy = timed_map(executor, jobs)
                        if phase not in reference:
                            reference[phase] = out
                        assert out == reference[phase], f"{label} {phase}: other numbers"  # noqa: S101
                        if best is None or wall < best[0]:
                            best = (wall, busy)
                    assert best is not None  # noqa: S101 - repeat >= 1
                    wall, busy = best
                    one = single.setdefault(phase, wall)  # the first placement: 1 process
                    shipped = bytes_per_task(jobs, out, placement.executor == "ray")
                    overhead = (executor.workers * wall - busy) / len(jobs)
                    load = os.getloadavg()[0]
                    print(f"| {n} | {model.num_states:,} | {phase} | {len(jobs)} | {label} "
                          f"| {wall:.2f} | {one / wall:.2f}x | {1000 * overhead:.1f} "
                          f"| {shipped:,.0f} | {load:.1f} |", flush=True)
            finally:
                executor.close()
        notes.append(f"N={n}: the problem with its built model pickles to "
                     f"{problem_bytes / 1e6:.1f} MB; each Ray worker receives "
                     f"{recipe_bytes / 1e3:.0f} kB instead (the problem without the model, and "
                     f"the model's text and constants) and builds the model once "
                     f"({rebuild_seconds:.2f} s here); a local pool's forked workers receive "
                     "nothing")
    print()
    for note in notes:
        print(f"- {note}")
    print(f"\n# load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
