"""Model-checking-time benchmark of posgmc against Storm on the scale models (after building).

For each (model, N, property) posgmc runs in a fresh subprocess: load, build (timed apart), then
check the property with the default sound method (interval iteration, precision 1e-6); the checking
time is the engine call alone, as Storm's ``check_seconds`` is. Storm runs in the same invocation
through ``benchmarks/storm_check.py`` in the reference environment with its sound environment
(``stormpy.environments.sound()``), so both figures are taken under the same machine load.

Usage::

    python benchmarks/check_bench.py                       # the default jobs below
    python benchmarks/check_bench.py --jobs two_robots=10 --repeat 1 --no-storm

Prints a markdown table (for docs/performance.md).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _worker import run_worker  # benchmarks/_worker.py (this folder is on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCALE = (ROOT.parent / "shared" / "benchmarks" / "scale").resolve()
STORM_PYTHON = Path("/root/refenv/bin/python")

MODELS = {"two_robots": SCALE / "two_robots.nm", "pursuit": SCALE / "pursuit.smg"}
PROPERTIES = {
    "two_robots": ['Pmax=? [ F "goal" ]', 'Rmin=? [ F "goal" ]'],
    "pursuit": ['<<evader>> Pmax=? [ F "escaped" ]'],
}
DEFAULT = ["two_robots=32", "pursuit=30"]


def worker(path: str, n: int, prop: str) -> dict[str, Any]:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.compiler import BuildOptions, ProgressMode

    t0 = time.perf_counter()
    session = api.load(path, constants={"N": str(n)})
    built = api.build(session, options=BuildOptions(progress=ProgressMode.NEVER))
    t1 = time.perf_counter()
    report = api.check(session, properties=[prop], built=built)
    t2 = time.perf_counter()
    if report.errors:
        return {"error": report.errors[0][1].render()}
    r = report.results[0]
    m = built.model
    return {
        "states": m.num_states,
        "choices": m.num_choices,
        "transitions": m.num_transitions,
        "build_seconds": t1 - t0,
        "check_seconds": r.seconds,
        "check_wall": t2 - t1,
        "value": r.value,
        "lower": r.lower,
        "upper": r.upper,
        "iterations": r.iterations,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def _posgmc(path: Path, n: int, prop: str, timeout: float) -> dict[str, Any]:
    return run_worker(Path(__file__), sys.executable, [str(path), str(n), prop], timeout)


def _storm_module():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("storm_check", HERE / "storm_check.py")
    assert spec is not None and spec.loader is not None  # noqa: S101 - a file next to this one
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.10g}"
    return str(v)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", nargs="*", default=DEFAULT, help="model=N1,N2 ...")
    parser.add_argument("--repeat", type=int, default=1, help="runs per job; medians reported")
    parser.add_argument("--no-storm", action="store_true")
    parser.add_argument("--timeout", type=float, default=1200.0)
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        path, n, prop = args.worker
        print(json.dumps(worker(path, int(n), prop)))
        return 0

    storm = None if args.no_storm or not STORM_PYTHON.exists() else _storm_module()
    rows = [
        "| model | N | property | states | posgmc check (s) | posgmc iterations "
        "| posgmc value [lower, upper] | Storm check (s) | Storm value | check ratio |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for spec in args.jobs:
        name, _, ns = spec.partition("=")
        for n in (int(x) for x in ns.split(",")):
            for prop in PROPERTIES[name]:
                ours = [_posgmc(MODELS[name], n, prop, args.timeout) for _ in range(args.repeat)]
                if "error" in ours[0]:
                    rows.append(f"| {name} | {n} | `{prop}` | posgmc failed: {ours[0]['error']} |")
                    print(rows[-1], file=sys.stderr)
                    continue
                ours_t = statistics.median(o["check_seconds"] for o in ours)
                o = ours[0]
                cells = [
                    name,
                    str(n),
                    f"`{prop}`",
                    f"{o['states']:,}",
                    f"{ours_t:.2f}",
                    str(o["iterations"]),
                    f"{_fmt(o['value'])} [{_fmt(o['lower'])}, {_fmt(o['upper'])}]",
                ]
                if storm is not None:
                    theirs = [
                        storm.run_storm_check(
                            MODELS[name], constants=f"N={n}", prop=prop, sound=True,
                            timeout=args.timeout,
                        )
                        for _ in range(args.repeat)
                    ]
                    if "error" in theirs[0]:
                        cells += [f"Storm failed: {theirs[0]['error']}", "", ""]
                    else:
                        st = statistics.median(t["check_seconds"] for t in theirs)
                        cells += [f"{st:.2f}", _fmt(theirs[0]["value"]), f"{ours_t / st:.2f}"]
                else:
                    cells += ["-", "-", "-"]
                rows.append("| " + " | ".join(cells) + " |")
                print(rows[-1], file=sys.stderr)
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
