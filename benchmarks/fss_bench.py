"""Finite-state strategies: what synthesis pays per candidate, and what a large strategy file costs.

Usage: python benchmarks/fss_bench.py [--root DIR] [--nodes 1000,20000] [--repeat 5]

Runs against the posgmc checkout at ``--root`` (default: this one), so that two checkouts can be
compared with the same script. Two parts, each printed as a markdown table:

* **synthesis path** (small dense strategies): on ``benchmarks/models/jammer_grid.posg`` (N=20,
  B=2) a seeded random randomised k-node strategy of the rover over all its observations is made
  from dense arrays (``FiniteStateStrategy.from_arrays``, as the search makes every candidate),
  its arrays read back (``.action``, ``.update``), bound to the model and multiplied into the
  product (``bind`` + ``strategy_product``), for k = 1, 2, 3. Medians of ``--repeat`` runs.
* **large files**: a k-node strategy file for the rover (``models/rover.posg``; 7 rules per node,
  each moving to the next node) is read and shown (``show-strategy``'s table), in a fresh
  process each, with its wall time and peak resident memory; a checkout that stores dense
  k x Z x A x k arrays is given at most ``--dense-limit`` bytes for them (``ulimit -v``), so its
  failure is a MemoryError, not the machine's.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _synthesis_path(root: Path, repeat: int) -> None:
    sys.path.insert(0, str(root))
    import numpy as np

    from posgmc import api
    from posgmc.strategies.binding import bind, player_view
    from posgmc.strategies.fss import FiniteStateStrategy
    from posgmc.strategies.product import strategy_product

    try:  # --root may be a checkout from before the searches were remembered
        from posgmc.engines.support_cache import clear_all
    except ImportError:
        def clear_all() -> None:
            pass

    session = api.load(HERE / "models" / "jammer_grid.posg", constants={"N": 20, "B": 2})
    model = api.build(session).model
    view = player_view(model, 0)
    owned = model.state_players == 0
    rows = np.flatnonzero(owned[model.choice_states])
    Z = view.num_observations
    offered = np.zeros((Z, len(model.action_names)), dtype=bool)
    offered[view.state_obs[model.choice_states[rows]], model.choice_actions[rows]] = True
    used = np.flatnonzero(offered.any(axis=0))
    obs = np.flatnonzero(offered.any(axis=1))
    mask = offered[np.ix_(obs, used)]
    print(f"model: {model.num_states:,} states, {model.num_choices:,} choices; the rover has "
          f"{obs.size} observations and {used.size} labels\n")
    print("| k | from_arrays (ms) | read action+update (ms) | bind + product (ms) | "
          "product states |")
    print("|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    for k in (1, 2, 3):
        action = rng.random((k, obs.size, used.size)) * mask[None]
        action /= action.sum(axis=2, keepdims=True)
        update = rng.random((k, obs.size, used.size, k))
        update /= update.sum(axis=3, keepdims=True)
        make, read, prod = [], [], []
        states = 0
        for _ in range(repeat):
            clear_all()  # every repetition as a fresh command: no graph search remembered
            a, u = action.copy(), (update * (action[..., None] > 0))
            t0 = time.perf_counter()
            fss = FiniteStateStrategy.from_arrays(
                player=view.name, observables=view.observables,
                observation_values=view.obs_values[obs],
                actions=tuple(model.action_names[i] for i in used.tolist()), action=a, update=u)
            t1 = time.perf_counter()
            _ = float(fss.action.sum()) + float(fss.update.sum())
            t2 = time.perf_counter()
            p = strategy_product(model, [bind(model, fss)])
            t3 = time.perf_counter()
            make.append(t1 - t0)
            read.append(t2 - t1)
            prod.append(t3 - t2)
            states = p.model.num_states
        print(f"| {k} | {1e3 * statistics.median(make):.1f} | {1e3 * statistics.median(read):.2f} "
              f"| {1e3 * statistics.median(prod):.0f} | {states:,} |")


_SHOW = """
import resource, sys, time
sys.path.insert(0, {root!r})
from posgmc.strategies.files import read_strategy
from posgmc.strategies.render import strategy_table
t = time.perf_counter()
text = strategy_table(read_strategy({path!r}))
print(time.perf_counter() - t, len(text.splitlines()),
      resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def _large_files(root: Path, nodes: list[int], dense_limit: int) -> None:
    print("\n| memory nodes | rules | file (MB) | read + table (s) | peak memory (MB) | outcome |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k in nodes:
            rules = [{"memory": n, "observation": {"x": x},
                      "action": {("done" if x in (0, 6) else "fwd"): 1.0},
                      "update": {("done" if x in (0, 6) else "fwd"): {str((n + 1) % k): 1.0}}}
                     for n in range(k) for x in range(7)]
            path = Path(tmp) / f"s{k}.json"
            path.write_text(json.dumps({"format": "posgmc-fss/1", "player": "rover",
                                        "memory_size": k, "initial_memory": 0,
                                        "observables": ["x"], "rules": rules}))

            def limit() -> None:
                resource.setrlimit(resource.RLIMIT_AS, (dense_limit, dense_limit))

            done = subprocess.run([sys.executable, "-c", _SHOW.format(root=str(root),
                                                                      path=str(path))],
                                  capture_output=True, text=True, preexec_fn=limit, check=False)
            size = path.stat().st_size / 1e6
            if done.returncode == 0:
                seconds, lines, peak = done.stdout.split()
                outcome = f"{int(lines) - 2:,} table rows"
                shown, mem = f"{float(seconds):.2f}", f"{int(peak) / 1024:.0f}"
            else:
                last = (done.stderr.strip().splitlines() or ["?"])[-1]
                outcome, shown, mem = f"failed: {last[:70]}", "-", "-"
            print(f"| {k:,} | {len(rules):,} | {size:.1f} | {shown} | {mem} | {outcome} |")


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--root", type=Path, default=HERE.parent)
    parser.add_argument("--nodes", default="1000,20000")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--dense-limit", type=int, default=8 << 30,
                        help="address-space limit (bytes) of each large-file process")
    args = parser.parse_args()
    print(f"checkout: {args.root}\n")
    _synthesis_path(args.root.resolve(), args.repeat)
    if args.nodes:
        _large_files(args.root.resolve(), [int(n) for n in args.nodes.split(",")],
                     args.dense_limit)
    return 0


if __name__ == "__main__":
    sys.exit(main())
