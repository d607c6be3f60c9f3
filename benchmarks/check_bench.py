"""Model-checking-time benchmark of posgmc against Storm on the scale models (after building).

For each (model, N, property) posgmc runs in a fresh subprocess: load, build (timed apart), then
check the property with the default sound method (interval iteration, precision 1e-6); the checking
time is the engine call alone, as Storm's ``check_seconds`` is. Storm runs in the same invocation
through ``benchmarks/storm_check.py`` in the reference environment with its sound environment
(``stormpy.environments.sound()``), so both figures are taken under the same machine load.

Usage::

    python benchmarks/check_bench.py --repeat 3            # the default jobs: the whole table
    python benchmarks/check_bench.py --jobs two_robots=10 --repeat 1 --no-storm
    python benchmarks/check_bench.py --jobs rover=2000 --properties Pmin Rmin --repeat 3
    python benchmarks/check_bench.py --repeat 3 --relative  # posgmc's --relative mode

Storm's sound environment uses relative precision 1e-6; posgmc's default is absolute 1e-6 (the
CLI's default), ``--relative`` makes posgmc's precision relative as well (the CLI's
``--relative``), which is the like-for-like comparison.

Besides the check times, every row gives the whole-process ratio (a fresh interpreter that imports,
parses, builds and checks, against ``storm_check.py``'s whole run, both timed from outside), the
peak-memory ratio (each process's ``ru_maxrss``) and the CPU-time ratios of the check and of the
whole process (``time.process_time`` around each tool's check call; the finished children's
``getrusage`` user + system time), which a loaded machine disturbs less than wall times. Storm runs
interleaved with posgmc, repetition by repetition; medians are reported.

Prints a markdown table (for docs/performance.md).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import resource
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _locations import reference_python, shared_benchmarks  # this folder is on sys.path
from _worker import run_worker  # benchmarks/_worker.py (this folder is on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCALE = shared_benchmarks() / "scale"
STORM_PYTHON = reference_python()

OWN = HERE / "models"
MODELS = {
    "two_robots": SCALE / "two_robots.nm",
    "pursuit": SCALE / "pursuit.smg",
    "rover": OWN / "rover.nm",
    "rover_wind": OWN / "rover_wind.smg",
}
CONSTANT = {"two_robots": "N", "pursuit": "N", "rover": "L", "rover_wind": "L"}
"""The constant that scales each model (the N of ``--jobs model=N``)."""
PROPERTIES = {
    "two_robots": ['Pmax=? [ F "goal" ]', 'Pmin=? [ F "goal" ]', 'Rmin=? [ F "goal" ]'],
    "pursuit": [
        '<<evader>> Pmax=? [ F "escaped" ]',
        '<<evader>> Pmin=? [ F "escaped" ]',  # pursuit has no rewards: no Rmin row
    ],
    "rover": ['Pmax=? [ F "goal" ]', 'Pmin=? [ F "goal" ]', 'Rmin=? [ F "goal" ]'],
    "rover_wind": [
        '<<rover>> Pmax=? [ F "goal" ]',
        '<<rover>> Pmin=? [ F "goal" ]',
        '<<rover>> Rmin=? [ F "goal" ]',
    ],
}
DEFAULT = ["rover=2000", "rover_wind=500", "two_robots=32", "pursuit=30"]


def worker(
    path: str, n: int, prop: str, constant: str = "N", relative: bool = False
) -> dict[str, Any]:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.compiler import BuildOptions, ProgressMode
    from posgmc.engines.options import SolverOptions

    t0 = time.perf_counter()
    session = api.load(path, constants={constant: str(n)})
    built = api.build(session, options=BuildOptions(progress=ProgressMode.NEVER))
    t1 = time.perf_counter()
    options = CheckOptions(solver=SolverOptions(relative=relative))
    c1 = time.process_time()
    report = api.check(session, properties=[prop], built=built, options=options)
    t2 = time.perf_counter()
    c2 = time.process_time()
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
        "check_cpu_seconds": c2 - c1,
        "value": r.value,
        "lower": r.lower,
        "upper": r.upper,
        "iterations": r.iterations,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def _posgmc(
    path: Path, n: int, prop: str, constant: str, timeout: float, relative: bool
) -> dict[str, Any]:
    """One fresh process (imports, load, build, check); ``process_seconds`` is its wall time."""
    t0 = time.perf_counter()
    precision = "relative" if relative else "absolute"
    args = [str(path), str(n), prop, constant, precision]
    cpu0 = _children_cpu()
    out = run_worker(Path(__file__), sys.executable, args, timeout)
    out["process_seconds"] = time.perf_counter() - t0
    out["process_cpu_seconds"] = _children_cpu() - cpu0
    return out


def _children_cpu() -> float:
    """CPU seconds (user + system) of the finished child processes so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _storm(module: Any, path: Path, n: int, prop: str, constant: str, timeout: float) -> dict:
    t0 = time.perf_counter()
    cpu0 = _children_cpu()
    out = module.run_storm_check(
        path, constants=f"{constant}={n}", prop=prop, sound=True, python=STORM_PYTHON,
        timeout=timeout,
    )
    out["process_seconds"] = time.perf_counter() - t0
    out["process_cpu_seconds"] = _children_cpu() - cpu0
    return out


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
    parser.add_argument(
        "--properties",
        nargs="*",
        default=None,
        help="only the properties containing one of these strings (e.g. Pmin Rmin)",
    )
    parser.add_argument("--timeout", type=float, default=1200.0)
    parser.add_argument(
        "--scale", type=Path, default=SCALE, help="folder of the shared scale models"
    )
    parser.add_argument(
        "--relative", action="store_true", help="posgmc with relative precision 1e-6, as Storm"
    )
    parser.add_argument("--worker", nargs=5, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    for name in ("two_robots", "pursuit"):
        MODELS[name] = args.scale / MODELS[name].name
    if args.worker:
        path, n, prop, constant, precision = args.worker
        print(json.dumps(worker(path, int(n), prop, constant, precision == "relative")))
        return 0

    storm = (
        None
        if args.no_storm or STORM_PYTHON is None or not STORM_PYTHON.exists()
        else _storm_module()
    )
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    mode = "relative" if args.relative else "absolute"
    loads = [os.getloadavg()[0]]
    rows = [
        "| model | N | property | states | posgmc check (s) | posgmc value [lower, upper] "
        "| Storm check (s) | Storm value | check ratio | process ratio | peak memory ratio "
        "| CPU ratio check / process |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for spec in args.jobs:
        name, _, ns = spec.partition("=")
        for n in (int(x) for x in ns.split(",")):
            for prop in PROPERTIES[name]:
                if args.properties and not any(p in prop for p in args.properties):
                    continue
                path, const = MODELS[name], CONSTANT[name]
                ours: list[dict[str, Any]] = []
                theirs: list[dict[str, Any]] = []
                for _ in range(args.repeat):  # interleaved: both see the same machine load
                    ours.append(_posgmc(path, n, prop, const, args.timeout, args.relative))
                    if storm is not None:
                        theirs.append(_storm(storm, path, n, prop, const, args.timeout))
                if "error" in ours[0]:
                    rows.append(f"| {name} | {n} | `{prop}` | posgmc failed: {ours[0]['error']} |")
                    print(rows[-1], file=sys.stderr)
                    continue
                timed = ("check_seconds", "process_seconds", "peak_rss_mb", "check_cpu_seconds",
                         "process_cpu_seconds")
                med = {k: statistics.median(o[k] for o in ours) for k in timed}
                o = ours[0]
                cells = [
                    name,
                    str(n),
                    f"`{prop}`",
                    f"{o['states']:,}",
                    f"{med['check_seconds']:.2f}",
                    f"{_fmt(o['value'])} [{_fmt(o['lower'])}, {_fmt(o['upper'])}]",
                ]
                if theirs and "error" not in theirs[0]:
                    st = {k: statistics.median(t[k] for t in theirs) for k in timed}
                    cells += [
                        f"{st['check_seconds']:.2f}",
                        _fmt(theirs[0]["value"]),
                        f"{med['check_seconds'] / max(st['check_seconds'], 1e-3):.2f}",
                        f"{med['process_seconds'] / st['process_seconds']:.2f} "
                        f"({med['process_seconds']:.1f} / {st['process_seconds']:.1f} s)",
                        f"{med['peak_rss_mb'] / st['peak_rss_mb']:.2f} "
                        f"({med['peak_rss_mb']:.0f} / {st['peak_rss_mb']:.0f} MB)",
                        f"{med['check_cpu_seconds'] / max(st['check_cpu_seconds'], 1e-3):.2f} / "
                        f"{med['process_cpu_seconds'] / st['process_cpu_seconds']:.2f}",
                    ]
                elif theirs:
                    cells += [f"Storm failed: {theirs[0]['error']}", "", "", "", "", ""]
                else:
                    cells += ["-", "-", "-", "-", "-", "-"]
                rows.append("| " + " | ".join(cells) + " |")
                print(rows[-1], file=sys.stderr)
                loads.append(os.getloadavg()[0])
    # provenance for docs/performance.md: when, and how busy the machine was (1-minute load
    # average sampled at the start and after every row)
    print(
        f"Started {started}, ended {time.strftime('%H:%M UTC', time.gmtime())}; "
        f"load average (1 min) {min(loads):.1f}-{max(loads):.1f}, median "
        f"{statistics.median(loads):.1f}, on {os.cpu_count()} cores; posgmc's precision 1e-6 "
        f"{mode}, Storm's 1e-6 relative (its sound environment's default)."
    )
    print()
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
