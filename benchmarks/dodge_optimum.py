"""The optimum of PAYNT's dodge-6-lines: a hand-built randomised runner, proven against every
guard, shows that the partially observable optimum is the full-observation value 1, so the
bracket's bound side (1.0) is tight there and the gap the synthesis leaves is its achievable
side's (posgmc and PAYNT both find about 0.488).

Usage:
    POSGMC_REFERENCE_PYTHON=... python benchmarks/dodge_optimum.py [--rates 1e-2 1e-3 ...] \
        [--export DIR]

``--export DIR`` also writes each runner to ``DIR/dodge-6-lines-runner-<rate>.fss.json``
(``tests/data/strategies/`` keeps the one of rate 1e-3).

The game (the DRN ``posmg/dodge-6-lines/sketch.templ`` of the benchmark models, from PAYNT's
``models/posmg``; its PRISM source ``model.prism`` beside it describes a later version with the
same geometry): the runner (player 0) walks a 6x6 grid from (1,1) to (6,6), moves l1/r1/d1/u1
deterministically (a move into a wall stays); the guard (player 1, who sees everything) moves on an
L of nine cells, the row y=4 for x=0..4 and the column x=4 for y=0..4, each move succeeding with
probability 0.8; the runner loses when both stand on one cell. The runner observes only whether
x1=x2 (observation 4), y1=y2 (5) or neither (0). Inside the box x, y <= 3 it therefore sees the L
cells (x,4) and (4,y), and to leave the box it must step onto an L cell (an exit) and off it; a
guard next to that exit along the L catches it with probability 0.8.

The runner built here (memory: its own cell, known by dead reckoning, and a mode; 144 nodes):

* in the box it walks at random over the box cells, never onto the L, except that at (2,3) it
  steps up and at (3,2) right with probability ``rate`` (a *blind exit*): the only exits whose
  covering cells ((1,4) and (3,4); (4,1) and (4,3)) are visible from a neighbouring box cell;
* when it sees the guard it runs along its row (guard on the row y=4) or column (guard on the
  column x=4) to the exit on the far arm, leaves the L and walks round to (6,6): the guard cannot
  reach that exit in time from where it was seen.

A guard covering (2,4) stands on (1,4) or (3,4), which the runner's next random move exposes with
probability 1/3; it must then move, and fails to with probability 0.2, and is seen. The corner
covers (3,4) and (4,3) without that risk, which is why the runner never exits blindly there. So
each blind exit is caught with probability at most 0.8, while the guard that covers it is exposed
about 1/(12 rate) times as often: the runner's guarantee tends to 1 as the rate goes to 0 (no
single strategy reaches 1: with rate 0 the guard just waits at the corner).

Each runner is checked twice, CPU seconds of each check beside it: by posgmc's sound strategy
check (``api.check`` with the strategy, every guard strategy allowed, interval iteration), and
independently by Storm: this script builds
the product of the DRN with the runner itself (its own DRN reader, not posgmc's) as an MDP in
which only the guard chooses, and Storm's sound environment computes ``Pmin=? [F "goal"]`` on it
(``stormpy.environments.sound()``, precision 1e-10) in the reference interpreter
(``$POSGMC_REFERENCE_PYTHON``; without it that column is ``-``). Prints a markdown table, then
the full-observation value (posgmc, ``--full-observation``) and the 1-minute load average.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _locations import ROOT, reference_python, shared_benchmarks  # noqa: E402

MODEL = shared_benchmarks() / "posmg" / "dodge-6-lines" / "sketch.templ"
PROPERTY = '<<1>> Pmax=? [ F "goal" ]'  # PRISM-games numbering: <<0>> in Storm's and PAYNT's
RATES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7)

MOVES = {"l1": (-1, 0), "r1": (1, 0), "d1": (0, -1), "u1": (0, 1)}
SIZE = 6
MODES = ("wander", "right", "up", "out")
NONE, X_ALIGNED, Y_ALIGNED = 0, 4, 5
TERMINAL = (6, 7, 8)  # crashed (two observations) and goal: deadlocks, one unlabelled choice
BLIND_EXITS = {(2, 3): "u1", (3, 2): "r1"}


def _step(x: int, y: int, action: str) -> tuple[int, int]:
    dx, dy = MOVES[action]
    return min(max(x + dx, 1), SIZE), min(max(y + dy, 1), SIZE)


def _in_box(x: int, y: int) -> bool:
    return x <= 3 and y <= 3


def _outside(x: int, y: int) -> str:
    """Off the box: off an exit onto the far side, then up to the top row and right to (6,6)."""
    if x == 4 and y <= 3:
        return "r1"
    if y == 4 and x <= 3:
        return "u1"
    return "u1" if y < SIZE else "r1"


def probing_runner(rate: float) -> dict[str, object]:
    """The runner as a ``posgmc-fss/1`` strategy of player "0" (observation ids of the DRN)."""
    nodes = [(x, y, m) for x in range(1, SIZE + 1) for y in range(1, SIZE + 1) for m in MODES]
    index = {n: i for i, n in enumerate(nodes)}
    rules: list[dict[str, object]] = []

    def rule(node: tuple[int, int, str], z: int, action: dict[str, float],
             mode: dict[str, str]) -> None:
        x, y, _ = node
        update = {a: {str(index[(*_step(x, y, a), mode[a])]): 1.0} for a in action}
        rules.append({"memory": index[node], "observation": z, "action": action,
                      "update": update})

    for node in nodes:
        x, y, m = node
        for z in (NONE, X_ALIGNED, Y_ALIGNED):
            if not _in_box(x, y) or m == "out":
                a = _outside(x, y)
                rule(node, z, {a: 1.0}, {a: "out"})
                continue
            if m == "wander" and z == NONE:
                inside = [a for a in MOVES if _step(x, y, a) != (x, y) and _in_box(*_step(x, y, a))]
                blind = BLIND_EXITS.get((x, y))
                stay = 1.0 - (rate if blind else 0.0)
                action = {a: stay / len(inside) for a in inside}
                modes = dict.fromkeys(inside, "wander")
                if blind:
                    action[blind], modes[blind] = rate, "out"
                rule(node, z, action, modes)
                continue
            # seen on the row y=4 (x aligned): leave by the column's exit on this row; seen on
            # the column x=4: leave by the row's exit in this column
            run = m if m != "wander" else ("right" if z == X_ALIGNED else "up")
            a = "r1" if run == "right" else "u1"
            last = x == 3 if run == "right" else y == 3
            rule(node, z, {a: 1.0}, {a: "out" if last else run})
        for z in TERMINAL:
            rules.append({"memory": index[node], "observation": z, "action": {"": 1.0}})
    return {"format": "posgmc-fss/1", "player": "0", "memory_size": len(nodes),
            "initial_memory": index[(1, 1, "wander")], "observables": [], "rules": rules}


# ---- the independent check: the product built here, solved by Storm ----

_STATE = re.compile(r"state (\d+) \{(\d+)\} <(\d+)>(.*)")
_ACTION = re.compile(r"\s+action (\S+)")
_BRANCH = re.compile(r"\s+(\d+) : (\S+)")


def _read_drn(path: Path) -> tuple[dict[int, tuple[int, int, set[str]]],
                                    dict[int, dict[str, list[tuple[int, float]]]]]:
    """(state -> (observation, player, labels), state -> action -> branches) of a POSMG DRN."""
    info: dict[int, tuple[int, int, set[str]]] = {}
    moves: dict[int, dict[str, list[tuple[int, float]]]] = {}
    state = action = None
    for line in path.read_text().splitlines():
        if m := _STATE.match(line):
            state = int(m[1])
            info[state] = (int(m[2]), int(m[3]), set(m[4].split()))
            moves[state] = {}
        elif (m := _ACTION.match(line)) and state is not None:
            action = m[1]
            moves[state][action] = []
        elif (m := _BRANCH.match(line)) and state is not None and action is not None:
            moves[state][action].append((int(m[1]), float(m[2])))
    return info, moves


def product_drn(fss: dict[str, object], out: Path) -> int:
    """Write the reachable product of the game with the runner as an MDP DRN in which only the
    guard chooses (goal states labelled "goal"); returns its state count."""
    info, moves = _read_drn(MODEL)
    rules = {(r["memory"], r["observation"]): r for r in fss["rules"]}  # type: ignore[attr-defined]
    start = (next(s for s, (_, _, labels) in info.items() if "init" in labels),
             int(fss["initial_memory"]))  # type: ignore[call-overload]
    number = {start: 0}
    order = [start]
    rows: list[list[dict[tuple[int, int], float]]] = []
    for s, n in order:  # grows while it is walked
        z, player, labels = info[s]
        if "deadlock" in labels:
            choices = [{(s, n): 1.0}]
        elif player == 0:
            r = rules[(n, z)]
            mixed: dict[tuple[int, int], float] = {}
            for a, pa in r["action"].items():  # type: ignore[union-attr]
                to = r.get("update", {}).get(a, {str(n): 1.0})  # type: ignore[union-attr]
                for t, pt in moves[s][a]:
                    for m, pm in to.items():
                        mixed[(t, int(m))] = mixed.get((t, int(m)), 0.0) + pa * pt * pm
            choices = [mixed]
        else:
            choices = [{(t, n): p for t, p in branch} for branch in moves[s].values()]
        for c in choices:
            for q in c:
                if q not in number:
                    number[q] = len(order)
                    order.append(q)
        rows.append(choices)
    text = ["@type: MDP", "@parameters", "", "@reward_models", "", "@nr_states", str(len(order)),
            "@nr_choices", str(sum(map(len, rows))), "@model"]
    for i, ((s, _), choices) in enumerate(zip(order, rows, strict=True)):
        labels = " goal" if "goal" in info[s][2] else ""
        text.append(f"state {i}{' init' if i == 0 else ''}{labels}")
        for j, c in enumerate(choices):
            text.append(f"\taction {j}")
            text += [f"\t\t{number[q]} : {p!r}" for q, p in c.items()]
    out.write_text("\n".join(text) + "\n")
    return len(order)


_STORM = """
import json, sys, time, stormpy, stormpy.environments
model = stormpy.build_model_from_drn(sys.argv[1])
prop = stormpy.parse_properties('Pmin=? [ F "goal" ]')[0]
env = stormpy.environments.sound()
env.solver().min_max().precision = stormpy.Rational(1e-10)
started = time.process_time()
result = stormpy.model_checking(model, prop, environment=env)
seconds = time.process_time() - started
print(json.dumps({"value": result.get_value(model.initial_states[0]), "seconds": seconds}))
"""


def storm_min(product: Path) -> tuple[float, float] | None:
    """Storm's sound Pmin on the product DRN and the CPU seconds of its check (None without the
    reference interpreter)."""
    python = reference_python()
    if python is None:
        return None
    done = subprocess.run([str(python), "-c", _STORM, str(product)], capture_output=True,
                          text=True, check=True)
    line = json.loads([x for x in done.stdout.splitlines() if x.startswith("{")][-1])
    return float(line["value"]), float(line["seconds"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rates", type=float, nargs="+", default=list(RATES))
    parser.add_argument("--export", type=Path, default=None,
                        help="a directory to write each runner's strategy file to")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from posgmc import api

    session = api.load(MODEL)
    print("| blind-exit rate | memory nodes | guaranteed (posgmc, proven) | CPU s | "
          "Storm, sound (product MDP) | Storm CPU s | product states |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for rate in args.rates:
            fss = probing_runner(rate)
            path = Path(args.export or tmp) / f"dodge-6-lines-runner-{rate:g}.fss.json"
            path.write_text(json.dumps(fss, indent=None, separators=(",", ":")) + "\n")
            c0 = time.process_time()
            r = api.check(session, properties=[PROPERTY], strategies={"0": path}).results[0]
            cpu = time.process_time() - c0
            g = r.guaranteed
            assert g is not None and g.sound  # noqa: S101
            product = Path(tmp) / f"product-{rate:g}.drn"
            states = product_drn(fss, product)
            storm = storm_min(product)
            value, seconds = ("-", "-") if storm is None else (f"{storm[0]:.10g}",
                                                               f"{storm[1]:.2f}")
            print(f"| {rate:g} | {fss['memory_size']} | {g.value:.10g} [{g.lower:.10g}, "
                  f"{g.upper:.10g}] | {cpu:.2f} | {value} | {seconds} | {states} |")
    full = api.check(session, properties=[PROPERTY], full_observation=True).results[0]
    print(f"\nfull observation: {full.value} [{full.lower}, {full.upper}]; "
          f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
