"""Synthesis quality and time against PAYNT, both in the same invocation.

Usage:
    python benchmarks/synthesis_bench.py [--set posmg|pomdp] [--effort 1] [--timeout SECONDS]
        [--paynt-timeout 30] [--only NAME ...] [--shared DIR] [--bracket] [--no-paynt]

For every POSMG under posmg/ of the benchmarks folder (--shared, default $POSGMC_SHARED_BENCHMARKS
or tests/data/benchmarks) with a DRN sketch (or, with --set pomdp, every POMDP under pomdp/;
--only NAME... for a subset): posgmc synthesises the coalition's strategy (`check` without
--strategy: gradient search over randomised FSSs with memory 1..3 against the omniscient
opponent, verified by sound interval iteration) with the deterministic work budget --effort
(docs/synthesis.md: its numbers depend only on the model, the options and the seed, never on the
machine; --timeout is an optional wall-clock cap, and a row it cut says "cut by --timeout"), and
PAYNT 0.5.0 (`python -m paynt DIR --sketch sketch.templ --props sketch.props --fsc-synthesis
--timeout T`, run by $POSGMC_REFERENCE_PYTHON) within its own --paynt-timeout. PAYNT's value is
the last "optimum" it prints. Prints a markdown table: our guaranteed with its proven bounds, the
full-observation value, vs_fss_adversary and upper_bound, the adversary phases (enumerated [all] /
ranked / kept / added by the double oracle; which defence is reported), our time (wall and CPU);
PAYNT's value and time ("not run" with --no-paynt or without a reference interpreter, "fails:"
and its last message when it ran and printed no optimum); who is better.

With --bracket the table is the optimum bracket's instead (docs/synthesis.md): posgmc runs with
`--gap 0` (the belief grid's budget counted in vertices, times --effort), and on POMDPs Storm's
belief-space bounds run in the same invocation with as much time as posgmc's bound side took
(benchmarks/_storm_belief.py: the discretisation at resolution 2 and the finest that fits,
and the belief unfolding). Columns: the bracket [lower, upper] and its gap, what proved the bound
side, the full-observation value, Storm's discretisation at resolution 2 and the finest, Storm's
unfolding, Storm's gap (discretisation's best - unfolding), whether the bracket contains every
value a tool reaches (sound), and the time.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

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


def ours(directory: Path, effort: float, timeout: float | None,
         bracket: bool = False) -> dict[str, object]:
    sys.path.insert(0, str(ROOT))
    from posgmc import api
    from posgmc.synthesis.options import Gap, SynthesisOptions

    prop = first_property(directory)
    started, cpu = time.perf_counter(), time.process_time()
    report = api.check(
        api.load(directory / "sketch.templ"),
        properties=[prop],
        zero_based_players=True,
        synthesis=SynthesisOptions(effort=effort, timeout=timeout,
                                   started=started,  # loading counts towards the cap
                                   gap=Gap(0.0) if bracket else None),
    )
    seconds = time.perf_counter() - started
    cpu = time.process_time() - cpu
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
            "cut": stats.get("cut"),
            "optimum": outcome.optimum, "optimum_bound": stats.get("optimum_bound", {}),
            "phases": stats.get("phases", {}),
            "deterministic": rounds[-1]["deterministic"] if rounds else None, "seconds": seconds,
            "cpu": cpu}


NOT_RUN = "not run"


def paynt(directory: Path, timeout: float) -> dict[str, object]:
    """PAYNT's last optimum and time, or its error; ``{"skipped": why}`` when it could not run."""
    if REFPY is None or not REFPY.exists():
        return {"skipped": "set POSGMC_REFERENCE_PYTHON (benchmarks/README.md)"}
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


def storm_belief(directory: Path, prop: str, seconds: float) -> dict[str, object]:
    """Storm's discretisation and unfolding bounds (benchmarks/_storm_belief.py), or an error;
    what it printed last when it overran."""
    if REFPY is None or not REFPY.exists():
        return {"error": "no reference interpreter (POSGMC_REFERENCE_PYTHON)"}
    cmd = [str(REFPY), str(ROOT / "benchmarks" / "_storm_belief.py"),
           str(directory / "sketch.templ"), prop, f"{seconds:g}"]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=3 * seconds + 60)
        text = out.stdout
    except subprocess.TimeoutExpired as e:
        text = (e.stdout or b"").decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
    lines = [line for line in text.splitlines() if line.startswith("{")]
    if not lines:
        return {"error": "no result"}
    found: dict[str, object] = json.loads(lines[-1])
    return found


def paynt_cells(b: dict[str, Any], guaranteed: Any, maximize: bool) -> tuple[str, str, str]:
    """The PAYNT columns of a row: its value (or how it failed, or "not run" when it was not run:
    --no-paynt, no reference interpreter), its seconds, and which tool is better; ``guaranteed``
    is posgmc's proven Bound, None when posgmc failed."""
    if "skipped" in b:
        return NOT_RUN, "-", "-" if guaranteed is None else f"- (PAYNT {NOT_RUN})"
    theirs = f"{b['value']:.6f}" if "value" in b else f"fails: {b['error']}"
    seconds = f"{b['seconds']:.1f}" if "seconds" in b else "-"
    if guaranteed is None:
        return theirs, seconds, "PAYNT" if "value" in b else "-"
    if "value" not in b:
        return theirs, seconds, "posgmc (PAYNT fails)"
    g = guaranteed
    diff = (g.lower - b["value"]) if maximize else (b["value"] - g.upper)
    # equal within the precision of the proven bounds (1e-6 absolute) and PAYNT's printed
    # digits (6 significant)
    tol = max(2e-6, 1e-6 * abs(b["value"]))
    return theirs, seconds, "posgmc" if diff > tol else "PAYNT" if diff < -tol else "equal"


def bracket_row(d: Path, effort: float, timeout: float | None) -> str:
    """One row of the --bracket table."""
    a = ours(d, effort, timeout, bracket=True)
    prop = str(a["property"])
    if "error" in a:
        return f"| {d.name} | `{prop}` | error: {a['error']} |" + " - |" * 9
    o = a["optimum"]
    g = a["guaranteed"]
    assert o is not None and g is not None  # noqa: S101 - synthesised results carry both
    maximize = "max" in prop
    stats = a["optimum_bound"]
    assert isinstance(stats, dict)  # noqa: S101
    grid_seconds = float(a["phases"].get("optimum bound", 0.0))
    method = o.method.replace("|", "/")
    d2 = dfine = unf = storm_gap = "-"
    reached = [g.lower if maximize else g.upper]
    storm_bounds: list[float] = []
    if (d / "sketch.templ").exists() and "<<" not in prop:
        st = storm_belief(d, prop, max(1.0, grid_seconds))
        disc = st.get("discretisation") or []
        assert isinstance(disc, list)  # noqa: S101
        if disc:
            d2 = f"{disc[0]['value']:.6f}"
            best = min(disc, key=lambda r: (1 if maximize else -1) * r["value"])
            dfine = f"{best['value']:.6f} (res {best['resolution']})"
            storm_bounds.append(best["value"])
        u = st.get("unfolding")
        if isinstance(u, dict):
            unf = f"{u['value']:.6f}" + (" (completed)" if u["completed"] else "")
            reached.append(u["value"])
            if disc:
                storm_gap = f"{abs(best['value'] - u['value']):.6f}"
        if "error" in st:
            d2 = f"error: {st['error']}"
    # sound: no value a strategy reaches (posgmc's, Storm's unfolding) beyond the bound side,
    # and no bound Storm proves on the far side of the achieved one
    sign = 1.0 if maximize else -1.0
    side = o.upper if maximize else o.lower
    achieved = o.lower if maximize else o.upper
    sound = o.sound and all(sign * v <= sign * side + 1e-6 for v in reached) and all(
        sign * v >= sign * achieved - 1e-6 for v in storm_bounds)
    return (f"| {d.name} | `{prop.replace('|', '/')}` | [{o.lower:.6f}, {o.upper:.6f}] "
            f"| {o.gap:.6f} | {method} | {a['full'].value:.6f} | {d2} | {dfine} | {unf} "
            f"| {storm_gap} | {'yes' if sound else 'NO'} | {a['seconds']:.1f} "
            f"({grid_seconds:.1f}) |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--effort", type=float, default=1.0,
                    help="posgmc's work budget, a multiplier of every phase's (default 1)")
    ap.add_argument("--timeout", type=float, default=None,
                    help="an optional wall-clock cap in seconds on posgmc's synthesis per model")
    ap.add_argument("--paynt-timeout", type=float, default=30.0,
                    help="PAYNT's --timeout in seconds (default 30)")
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--set", choices=["posmg", "pomdp"], default="posmg")
    ap.add_argument(
        "--shared", type=Path, default=SHARED,
        help="benchmarks folder (default: $POSGMC_SHARED_BENCHMARKS or tests/data/benchmarks)",
    )
    ap.add_argument("--bracket", action="store_true",
                    help="the optimum bracket's table, with Storm's belief-space bounds")
    ap.add_argument("--no-paynt", action="store_true", help="do not run PAYNT")
    args = ap.parse_args()
    base = args.shared / args.set
    dirs = sorted(
        d for d in base.iterdir() if (d / "sketch.templ").exists() and (d / "sketch.props").exists()
    )
    if args.only:
        dirs = [d for d in dirs if d.name in args.only]
    if args.bracket:
        print("| model | property | optimum [lower, upper] | gap | bound side by "
              "| full observation | Storm discr. res 2 | Storm discr. finest | Storm unfolding "
              "| Storm gap | sound | posgmc s (bound side s) |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for d in dirs:
            print(bracket_row(d, args.effort, args.timeout), flush=True)
        return
    print(
        "| model | property | posgmc guaranteed [lower, upper] | full observation "
        "| vs_fss_adversary | upper_bound | adversaries | memory | posgmc s (CPU s) "
        "| PAYNT --fsc-synthesis | PAYNT (s) | better |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for d in dirs:
        a = ours(d, args.effort, args.timeout)
        b = paynt(d, args.paynt_timeout) if not args.no_paynt else {"skipped": "--no-paynt"}
        prop = str(a["property"]).replace("|", "\\|")
        if "error" in a:
            mine = f"error: {a['error']}"
            full = memory = vs = ub = adversaries = "-"
        else:
            g = a["guaranteed"]
            mine = f"{g.value:.6f} [{g.lower:.6f}, {g.upper:.6f}]" + (
                " (cut by --timeout)" if a["cut"] == "timeout" else " (partial)" if a["partial"]
                else ""
            )
            full = f"{a['full'].value:.6f}"
            vs = f"{a['vs'].value:.6f}" if a["vs"] is not None else "-"
            ub = f"{a['ub'].value:.6f}" if a["ub"] is not None else "-"
            adversaries = a["adversaries"]
            memory = ", ".join(f"{k or 'agent'}={v}" for k, v in a["memory"].items())
        theirs, pt, better = paynt_cells(b, None if "error" in a else a["guaranteed"],
                                         "max" in prop)
        print(
            f"| {d.name} | `{prop}` | {mine} | {full} | {vs} | {ub} | {adversaries} | {memory} "
            f"| {a['seconds']:.1f} ({a.get('cpu', 0.0):.1f}) | {theirs} | {pt} | {better} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
