"""The secure-autonomy case study at scale, end to end: `posgmc check` of the planner's Pmax of
retrieving the target (models/secure_autonomy, flash=false, B=1, default effort) at N=5 with
memory 2 and at N=8 with memory 1, each in a fresh process under `/usr/bin/time -v`.

Targets (docs/performance.md): N=5 (141,921 states) with memory 2 within 3 minutes; N=8 (962,169
states) with memory 1 within 15 minutes and within the machine's memory.

Printed per run: wall and CPU seconds and peak resident memory of the whole command, the load
average (1 min) before and after (on a shared machine the wall time is only as good as the cores
that are free: the CPU seconds are the comparable figure), the proven numbers (guaranteed with its
bounds, whether sound, the optimum bracket) and the phase seconds the JSON reports. A run that
exits non-zero or passes --limit seconds is reported as such, with what it printed.

    python benchmarks/case_study_bench.py [--only 5 8] [--limit 3600]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
PROP = '<<planner>> Pmax=? [ F "retrieved" ]'


@dataclass(frozen=True)
class Case:
    n: int
    memory: int
    target_seconds: float

    def command(self) -> list[str]:
        return ["check", str(MODEL.relative_to(ROOT)), "--prop", PROP, "--const",
                f"N={self.n},flash=false,B=1", "--memory", str(self.memory), "--json"]


CASES = (Case(5, 2, 180.0), Case(8, 1, 900.0))


@dataclass(frozen=True)
class Run:
    case: Case
    wall: float
    cpu: float
    peak_mb: float
    load_before: float
    load_after: float
    exit_code: int | None  # None: stopped at the limit
    result: dict[str, object] | None
    stderr_tail: str


def _time_field(text: str, name: str) -> float:
    m = re.search(rf"{re.escape(name)}: ([0-9.:]+)", text)
    if m is None:
        return float("nan")
    value = m.group(1)
    if ":" in value:  # h:mm:ss or m:ss
        seconds = 0.0
        for part in value.split(":"):
            seconds = 60.0 * seconds + float(part)
        return seconds
    return float(value)


def run_case(case: Case, limit: float) -> Run:
    argv = ["/usr/bin/time", "-v", sys.executable, "-m", "posgmc", *case.command()]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    load_before = os.getloadavg()[0]
    started = time.perf_counter()
    try:
        out = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT, env=env,
                             timeout=limit)
        code: int | None = out.returncode
        stdout, stderr = out.stdout, out.stderr
    except subprocess.TimeoutExpired as e:
        code = None
        stdout = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        stderr = e.stderr.decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
    wall = time.perf_counter() - started
    result = None
    if code == 0:
        result = json.loads(stdout)["results"][0]
    cpu = _time_field(stderr, "User time (seconds)") + _time_field(stderr,
                                                                   "System time (seconds)")
    peak = _time_field(stderr, "Maximum resident set size (kbytes)") / 1024.0
    if code is not None:
        wall = _time_field(stderr, "Elapsed (wall clock) time (h:mm:ss or m:ss)")
    tail = "\n".join(line for line in stderr.splitlines()
                     if not line.startswith("\t"))[-400:]
    return Run(case, wall, cpu, peak, load_before, os.getloadavg()[0], code, result, tail)


def _bound(b: object) -> str:
    if not isinstance(b, dict):
        return "—"
    return f"{b['value']:.10f} [{b['lower']:.10f}, {b['upper']:.10f}]"


def report(run: Run) -> None:
    c = run.case
    states = {5: "141,921", 8: "962,169"}.get(c.n, "?")
    status = ("stopped at the limit" if run.exit_code is None else
              "ok" if run.exit_code == 0 else f"exit {run.exit_code}")
    r = run.result or {}
    optimum = r.get("optimum")
    opt = (f"[{optimum['lower']:.10f}, {optimum['upper']:.10f}]"
           if isinstance(optimum, dict) else "—")
    within = "yes" if run.exit_code == 0 and run.wall <= c.target_seconds else "no"
    print(f"| N={c.n} ({states} states), memory {c.memory} | {status} | {run.wall:.0f} | "
          f"{run.cpu:.0f} | {run.peak_mb:,.0f} | {run.load_before:.1f} / {run.load_after:.1f} | "
          f"{_bound(r.get('guaranteed'))} | {r.get('sound', '—')} | {opt} | "
          f"{c.target_seconds:.0f} s: {within} |", flush=True)


def phases(run: Run) -> None:
    r = run.result
    if not r:
        print(f"N={run.case.n}: no phases ({run.stderr_tail.strip() or 'no output'})")
        return
    ph = r.get("phases") or {}
    assert isinstance(ph, dict)
    parts = ", ".join(f"{name} {seconds:.1f}" for name, seconds in ph.items())
    print(f"N={run.case.n}, memory {run.case.memory} — phases (s): {parts}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", type=int, nargs="+", default=[c.n for c in CASES],
                    help="grid sizes to run (5, 8)")
    ap.add_argument("--limit", type=float, default=3600.0,
                    help="stop a run after this many wall seconds")
    a = ap.parse_args()
    cases = [c for c in CASES if c.n in a.only]
    print(f"# case_study_bench: {platform.node()}, {os.cpu_count()} cores, "
          f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC")
    print(f"# command: python benchmarks/case_study_bench.py --only "
          f"{' '.join(str(c.n) for c in cases)} --limit {a.limit:.0f}")
    print()
    print("| case | status | wall s | CPU s | peak MB | load before / after | guaranteed "
          "[proven bounds] | sound | optimum bracket | target |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    runs = []
    for case in cases:
        run = run_case(case, a.limit)
        runs.append(run)
        report(run)
    print()
    for run in runs:
        phases(run)
    return 0 if all(r.exit_code == 0 for r in runs) else 1


if __name__ == "__main__":
    raise SystemExit(main())
