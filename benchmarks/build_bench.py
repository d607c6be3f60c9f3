"""Build-time and memory benchmark of posgmc's compiler against Storm, on the scale models.

Each build runs in a fresh subprocess so that its peak resident memory (``ru_maxrss``) is its own:
posgmc's (parse + instantiate + build) in this interpreter, Storm's (parse + instantiate +
``stormpy.build_model``) in the reference environment's interpreter when it is set
(``POSGMC_REFERENCE_PYTHON``, with stormpy 2.0; see benchmarks/README.md). Storm is asked for what
posgmc always builds: all labels, all reward models, choice labels and state valuations
(``--storm-minimal`` leaves out choice labels and state valuations). Times are wall-clock seconds
of the build step alone; the "total" columns include parsing and constant instantiation. Both
tools are run in the same invocation, one after the other, so that their ratio is measured under
the same machine load.

Usage::

    python benchmarks/build_bench.py                      # two_robots N=32, pursuit N=30
    python benchmarks/build_bench.py two_robots=10,20 pursuit=6 --repeat 3
    python benchmarks/build_bench.py --no-storm two_robots=40

Prints a markdown table (for docs/performance.md).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

from _locations import reference_python, shared_benchmarks  # this folder is on sys.path
from _worker import run_worker  # benchmarks/_worker.py (this folder is on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCALE = shared_benchmarks() / "scale"
MODELS = {"two_robots": SCALE / "two_robots.nm", "pursuit": SCALE / "pursuit.smg"}
DEFAULT = ["two_robots=32", "pursuit=30"]
STORM_PYTHON = reference_python()


# ---------------------------------------------------------------------------------------------
# workers (run in a fresh subprocess; print one JSON line)
# ---------------------------------------------------------------------------------------------


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def worker_posgmc(path: str, n: int) -> dict[str, object]:
    sys.path.insert(0, str(ROOT))
    from posgmc.compiler import BuildOptions, ProgressMode, build_model
    from posgmc.semantics.stages import instantiate
    from posgmc.syntax.parser import parse_model

    t0 = time.perf_counter()
    model_file = parse_model(Path(path).read_text(), file=path)
    flat = instantiate(model_file, constants={"N": n})
    t1 = time.perf_counter()
    result = build_model(flat, options=BuildOptions(progress=ProgressMode.NEVER))
    t2 = time.perf_counter()
    m = result.model
    return {
        "states": m.num_states,
        "choices": m.num_choices,
        "transitions": m.num_transitions,
        "build": t2 - t1,
        "total": t2 - t0,
        "peak_mb": _peak_mb(),
    }


def worker_storm(path: str, n: int, minimal: bool) -> dict[str, object]:
    import stormpy

    t0 = time.perf_counter()
    prog = stormpy.parse_prism_program(path)
    prog = stormpy.io.instantiate_constants(prog, f"N={n}")[0]
    options = stormpy.BuilderOptions()
    options.set_build_all_labels()
    options.set_build_all_reward_models()
    if not minimal:
        options.set_build_choice_labels()
        options.set_build_state_valuations()
    t1 = time.perf_counter()
    m = stormpy.build_model(prog, options=options)
    t2 = time.perf_counter()
    return {
        "states": m.nr_states,
        "choices": m.nr_choices,
        "transitions": m.nr_transitions,
        "build": t2 - t1,
        "total": t2 - t0,
        "peak_mb": _peak_mb(),
    }


# ---------------------------------------------------------------------------------------------
# driver
# ---------------------------------------------------------------------------------------------


def _run(python: str, args: list[str], timeout: float) -> dict[str, object]:
    return run_worker(Path(__file__), python, args, timeout)


def _median(runs: list[dict[str, object]], key: str) -> float:
    return statistics.median(float(r[key]) for r in runs)  # type: ignore[arg-type]


def _storm_available(python: Path) -> bool:
    if not python.exists():
        return False
    probe = subprocess.run(
        [str(python), "-c", "import stormpy"], check=False, capture_output=True, timeout=120
    )
    return probe.returncode == 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", help="model=N1,N2,... (models: two_robots, pursuit)")
    parser.add_argument(
        "--repeat", type=int, default=1, help="runs per build; medians are reported"
    )
    parser.add_argument("--no-storm", action="store_true", help="skip Storm")
    parser.add_argument(
        "--storm-python",
        default=None if STORM_PYTHON is None else str(STORM_PYTHON),
        help="interpreter with stormpy (default: $POSGMC_REFERENCE_PYTHON)",
    )
    parser.add_argument(
        "--storm-minimal", action="store_true", help="Storm without choice labels/state valuations"
    )
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per build")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.worker:
        tool, path, n, *rest = args.worker
        if tool == "posgmc":
            out = worker_posgmc(path, int(n))
        else:
            out = worker_storm(path, int(n), minimal=bool(rest and rest[0] == "minimal"))
        print(json.dumps(out))
        return 0

    jobs: list[tuple[str, int]] = []
    for spec in args.sizes or DEFAULT:
        name, _, ns = spec.partition("=")
        if name not in MODELS or not ns:
            parser.error(
                f"bad size spec {spec!r}: expected model=N1,N2 with model in {sorted(MODELS)}"
            )
        jobs.extend((name, int(x)) for x in ns.split(","))

    storm = (
        not args.no_storm
        and args.storm_python is not None
        and _storm_available(Path(args.storm_python))
    )
    if not args.no_storm and not storm:
        where = args.storm_python or "$POSGMC_REFERENCE_PYTHON (unset)"
        print(f"(Storm skipped: no stormpy at {where})", file=sys.stderr)

    header = (
        "| model | N | states | choices | transitions | posgmc build (s) | posgmc total (s) "
        "| posgmc peak (MB) |"
    )
    rule = "|---|---|---|---|---|---|---|---|"
    if storm:
        header += (
            " Storm build (s) | Storm total (s) | Storm peak (MB) | build ratio | total ratio "
            "| memory ratio | counts equal |"
        )
        rule += "---|---|---|---|---|---|---|"
    lines = [header, rule]
    for name, n in jobs:
        path = str(MODELS[name])
        ours = [
            _run(sys.executable, ["posgmc", path, str(n)], args.timeout) for _ in range(args.repeat)
        ]
        if "error" in ours[0]:
            lines.append(f"| {name} | {n} | posgmc failed: {ours[0]['error']} |")
            print(lines[-1], file=sys.stderr)
            continue
        o = ours[0]
        cells = [
            name,
            str(n),
            f"{o['states']:,}",
            f"{o['choices']:,}",
            f"{o['transitions']:,}",
            f"{_median(ours, 'build'):.2f}",
            f"{_median(ours, 'total'):.2f}",
            f"{_median(ours, 'peak_mb'):.0f}",
        ]
        if storm:
            extra = ["minimal"] if args.storm_minimal else []
            theirs = [
                _run(args.storm_python, ["storm", path, str(n), *extra], args.timeout)
                for _ in range(args.repeat)
            ]
            if "error" in theirs[0]:
                cells += [f"Storm failed: {theirs[0]['error']}"] + [""] * 6
            else:
                t = theirs[0]
                sb, st_, sm = (
                    _median(theirs, "build"),
                    _median(theirs, "total"),
                    _median(theirs, "peak_mb"),
                )
                same = (o["states"], o["choices"], o["transitions"]) == (
                    t["states"],
                    t["choices"],
                    t["transitions"],
                )
                cells += [
                    f"{sb:.2f}",
                    f"{st_:.2f}",
                    f"{sm:.0f}",
                    f"{_median(ours, 'build') / sb:.2f}",
                    f"{_median(ours, 'total') / st_:.2f}",
                    f"{_median(ours, 'peak_mb') / sm:.2f}",
                    "yes"
                    if same
                    else f"NO (Storm {t['states']}/{t['choices']}/{t['transitions']})",
                ]
        lines.append("| " + " | ".join(cells) + " |")
        print(lines[-1], file=sys.stderr, flush=True)
    print("\n".join(lines))
    print(
        f"\n{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f} at the end; "
        f"{args.repeat} run(s) per build, medians; ratios are posgmc / Storm."
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
