"""The README's headline synthesis (models/rover.posg, default options): wall and CPU time of the
whole command and the numbers it prints, run by run, with the machine's load beside them.

Target (docs/performance.md): well under 10 s with the defaults on an idle machine, guaranteed at
least 0.9876454792 (what the former 20 s time budget proved), the same numbers every run.

    python benchmarks/headline_bench.py --runs 3
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMAND = ["check", str(ROOT / "models" / "rover.posg"), "--prop",
           '<<rover>> Pmax=? [ !"crash" U "goal" ]', "--json", "--quiet"]


def one_run(extra: list[str]) -> dict[str, object]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "posgmc", *COMMAND, *extra], capture_output=True,
                         text=True, check=True, cwd=ROOT)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = json.loads(out.stdout)["results"][0]
    return {"wall": wall, "cpu": (after.ru_utime - before.ru_utime)
            + (after.ru_stime - before.ru_stime), "load": os.getloadavg()[0],
            "guaranteed": r["guaranteed"], "cut": r["cut"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("extra", nargs="*", help="more options for posgmc check")
    a = parser.parse_args()
    print("| run | wall (s) | CPU (s) | load (1 min) | guaranteed [lower, upper] | cut |")
    print("|---|---|---|---|---|---|")
    seen = set()
    for i in range(a.runs):
        r = one_run(a.extra)
        g = r["guaranteed"]
        assert isinstance(g, dict)
        seen.add((g["value"], g["lower"], g["upper"]))
        print(f"| {i + 1} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['load']:.1f} | "
              f"{g['value']:.10g} [{g['lower']:.10g}, {g['upper']:.10g}] | {r['cut']} |",
              flush=True)
    print(f"distinct results: {len(seen)}")
    return 0 if len(seen) == 1 else 1


if __name__ == "__main__":
    raise SystemExit(main())
