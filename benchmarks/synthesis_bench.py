"""Synthesis quality and time against PAYNT, both in the same invocation.

Usage:
    python benchmarks/synthesis_bench.py [--set posmg|pomdp] [--timeout 30] [--paynt-timeout 30]
        [--only NAME ...] [--shared DIR]

For every POSMG under posmg/ of the benchmarks folder (--shared, default $POSGMC_SHARED_BENCHMARKS
or tests/data/benchmarks) with a DRN sketch (or, with --set pomdp, every POMDP under pomdp/;
--only NAME... for a subset): posgmc synthesises the
coalition's strategy (`check` without --strategy: gradient search over randomised FSSs with
memory 1..3 against the omniscient opponent, verified by sound interval iteration) within
--timeout, and PAYNT 0.5.0 (`python -m paynt DIR --sketch sketch.templ --props sketch.props
--fsc-synthesis --timeout T`, run by $POSGMC_REFERENCE_PYTHON) within --paynt-timeout. PAYNT's
value is the last "optimum" it prints. Prints a markdown table: our guaranteed with its proven
bounds, the full-observation value, vs_fss_adversary and upper_bound, the adversary phases
(enumerated [all] / ranked / kept / added by the double oracle; which defence is reported), our
time; PAYNT's value and time; who is better.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

from _locations import reference_python, shared_benchmarks  # this folder is on sys.path

ROOT = Path(__file__).resolve().parents[1]
SHARED = shared_benchmarks()
REFPY = reference_python()


def first_property(directory: Path) -> str:
    """The first property of the sketch's properties file (comments and blank lines skipped)."""
    for line in (directory / "sketch.props").read_text().splitlines():
        if line.strip() and not line.strip().startswith("//"):
            return line.strip().rstrip(";")
    raise SystemExit(f"{directory}: no property")


def ours(directory: Path, timeout: float) -> dict[str, object]:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.synthesis.options import SynthesisOptions

    prop = first_property(directory)
    started = time.perf_counter()
    report = api.check(
        api.load(directory / "sketch.templ"),
        properties=[prop],
        zero_based_players=True,
        synthesis=SynthesisOptions(timeout=timeout, started=started),  # loading counts
    )
    seconds = time.perf_counter() - started
    outcome = report.outcomes[0]
    if isinstance(outcome, tuple):
        return {"property": prop, "error": outcome[1].message, "seconds": seconds}
    rounds = outcome.synthesis["rounds"] if outcome.synthesis else []
    stats = outcome.synthesis or {}
    adversaries = "-"
    if "adversaries_enumerated" in stats:
        adversaries = (f"{stats['adversaries_enumerated']}{' (all)' if stats['exhaustive'] else ''}"
                       f"/{stats['adversaries_ranked']}/{stats['adversaries_kept']}/"
                       f"{stats['adversaries_added']}; {stats['defence']}")
    return {"property": prop, "guaranteed": outcome.guaranteed, "full": outcome.full_observation,
            "vs": outcome.vs_fss_adversary, "ub": outcome.upper_bound, "adversaries": adversaries,
            "memory": dict(outcome.memory), "partial": outcome.synthesis["partial"],
            "deterministic": rounds[-1]["deterministic"] if rounds else None, "seconds": seconds}


def paynt(directory: Path, timeout: float) -> dict[str, object]:
    if REFPY is None or not REFPY.exists():
        return {"error": "set POSGMC_REFERENCE_PYTHON (benchmarks/README.md)"}
    cmd = [str(REFPY), "-m", "paynt", str(directory), "--sketch", "sketch.templ", "--props",
           "sketch.props", "--fsc-synthesis", "--timeout", str(int(timeout))]
    started = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout + 60, cwd="/tmp")
    except subprocess.TimeoutExpired:
        return {"error": "did not stop", "seconds": time.perf_counter() - started}
    seconds = time.perf_counter() - started
    text = out.stdout + out.stderr
    values = re.findall(r"optimum: ([0-9.eE+-]+)", text) or re.findall(
        r"double-checking specification satisfiability:\s*:\s*([0-9.eE+-]+)", text)
    if not values:
        tail = [line for line in text.splitlines() if line.strip()][-1:] or ["no output"]
        return {"error": tail[0][-80:], "seconds": seconds}
    return {"value": float(values[-1]), "seconds": seconds}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--timeout", type=float, default=30.0)
    ap.add_argument("--paynt-timeout", type=float, default=30.0)
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--set", choices=["posmg", "pomdp"], default="posmg")
    ap.add_argument(
        "--shared", type=Path, default=SHARED,
        help="benchmarks folder (default: $POSGMC_SHARED_BENCHMARKS or tests/data/benchmarks)",
    )
    args = ap.parse_args()
    base = args.shared / args.set
    dirs = sorted(
        d for d in base.iterdir() if (d / "sketch.templ").exists() and (d / "sketch.props").exists()
    )
    if args.only:
        dirs = [d for d in dirs if d.name in args.only]
    print(
        "| model | property | posgmc guaranteed [lower, upper] | full observation "
        "| vs_fss_adversary | upper_bound | adversaries | memory | posgmc (s) "
        "| PAYNT --fsc-synthesis | PAYNT (s) | better |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for d in dirs:
        a = ours(d, args.timeout)
        b = paynt(d, args.paynt_timeout)
        prop = str(a["property"]).replace("|", "\\|")
        if "error" in a:
            mine = f"error: {a['error']}"
            full = memory = vs = ub = adversaries = "-"
            better = "PAYNT" if "value" in b else "-"
        else:
            g = a["guaranteed"]
            mine = f"{g.value:.6f} [{g.lower:.6f}, {g.upper:.6f}]" + (
                " (partial)" if a["partial"] else ""
            )
            full = f"{a['full'].value:.6f}"
            vs = f"{a['vs'].value:.6f}" if a["vs"] is not None else "-"
            ub = f"{a['ub'].value:.6f}" if a["ub"] is not None else "-"
            adversaries = a["adversaries"]
            memory = ", ".join(f"{k or 'agent'}={v}" for k, v in a["memory"].items())
            if "value" in b:
                maximize = "max" in prop
                diff = (g.lower - b["value"]) if maximize else (b["value"] - g.upper)
                # equal within the precision of the proven bounds (1e-6 absolute) and PAYNT's
                # printed digits (6 significant)
                tol = max(2e-6, 1e-6 * abs(b["value"]))
                better = "posgmc" if diff > tol else "PAYNT" if diff < -tol else "equal"
            else:
                better = "posgmc (PAYNT fails)"
        theirs = f"{b['value']:.6f}" if "value" in b else f"fails: {b['error']}"
        pt = f"{b['seconds']:.1f}" if "seconds" in b else "-"
        print(
            f"| {d.name} | `{prop}` | {mine} | {full} | {vs} | {ub} | {adversaries} | {memory} "
            f"| {a['seconds']:.1f} | {theirs} | {pt} | {better} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
