"""Peak memory and time of ``build --export drn`` against building alone, and Storm's DRN export.

Each measurement runs in a fresh subprocess so that its peak resident memory (``ru_maxrss``) is
its own: posgmc building two_robots (``build``), posgmc building and writing it as DRN
(``export``, :func:`posgmc.io.drn.write_drn`), and Storm building and writing it
(``stormpy.build_model`` + ``stormpy.export_to_drn``) in the reference environment, in the same
invocation. The export's cost is its peak over the build's, which should stay a small multiple of
the model's own memory (the writer streams; it never holds the whole text).

Usage::

    python benchmarks/export_bench.py 20 32     # two_robots N values

Prints a markdown table (for docs/performance.md). Files are written to a temporary directory and
removed.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

from _locations import reference_python, shared_benchmarks  # this folder is on sys.path
from _worker import run_worker  # benchmarks/_worker.py (this folder is on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MODEL = shared_benchmarks() / "scale" / "two_robots.nm"
STORM_PYTHON = reference_python()


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def worker_posgmc(n: int, target: str | None) -> dict[str, object]:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.io.drn import write_drn

    model = api.build(api.load(MODEL, constants={"N": n})).model
    built_mb = _peak_mb()
    t0 = time.perf_counter()
    if target is not None:
        write_drn(model, target)
    return {
        "states": model.num_states,
        "built_mb": built_mb,
        "peak_mb": _peak_mb(),
        "write_s": time.perf_counter() - t0,
        "bytes": os.path.getsize(target) if target else 0,
    }


def worker_storm(n: int, target: str) -> dict[str, object]:
    import stormpy

    program = stormpy.parse_prism_program(str(MODEL))
    program = stormpy.io.instantiate_constants(program, f"N={n}")[0]
    options = stormpy.BuilderOptions()
    options.set_build_all_labels()
    options.set_build_all_reward_models()
    options.set_build_choice_labels()  # posgmc writes action names too
    model = stormpy.build_model(program, options=options)
    built_mb = _peak_mb()
    t0 = time.perf_counter()
    stormpy.io.export_to_drn(model, target)
    return {
        "states": model.nr_states,
        "built_mb": built_mb,
        "peak_mb": _peak_mb(),
        "write_s": time.perf_counter() - t0,
        "bytes": os.path.getsize(target),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("sizes", nargs="*", type=int, default=[20, 32])
    parser.add_argument("--worker", nargs="+")
    parser.add_argument("--no-storm", action="store_true")
    args = parser.parse_args()
    if args.worker:
        tool, n, target = args.worker[0], int(args.worker[1]), args.worker[2]
        fn = worker_posgmc if tool == "posgmc" else worker_storm
        print(json.dumps(fn(n, None if target == "-" else target)))
        return
    script = Path(__file__)
    print(
        "| N | states | posgmc build peak (MB) | posgmc export peak (MB) | export / build | "
        "write (s) | file (MB) | Storm build peak (MB) | Storm export peak (MB) | Storm write (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        with tempfile.TemporaryDirectory() as tmp:
            build = run_worker(script, sys.executable, ["posgmc", str(n), "-"], 3600)
            export = run_worker(script, sys.executable, ["posgmc", str(n), f"{tmp}/m.drn"], 3600)
            os.unlink(f"{tmp}/m.drn") if os.path.exists(f"{tmp}/m.drn") else None
            storm: dict[str, object] = {}
            if not args.no_storm and STORM_PYTHON is not None and STORM_PYTHON.exists():
                storm = run_worker(
                    script, str(STORM_PYTHON), ["storm", str(n), f"{tmp}/s.drn"], 3600
                )
        if "error" in build or "error" in export:
            print(f"| {n} | error: {build.get('error') or export.get('error')} |")
            continue
        ratio = float(export["peak_mb"]) / float(build["peak_mb"])  # type: ignore[arg-type]
        print(
            f"| {n} | {build['states']:,} | {build['peak_mb']:.0f} | {export['peak_mb']:.0f} | "
            f"{ratio:.2f} | {export['write_s']:.1f} | {int(export['bytes']) / 1e6:.0f} | "  # type: ignore[call-overload]
            + (
                f"{storm['built_mb']:.0f} | {storm['peak_mb']:.0f} | {storm['write_s']:.1f} |"
                if storm and "error" not in storm
                else f"{storm.get('error', '-')} | | |"
            ),
            flush=True,
        )


if __name__ == "__main__":
    main()
