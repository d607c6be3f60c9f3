"""The secure-autonomy case study's optimum brackets: what the synthesised planner guarantees and
what no planner of any memory can exceed, for the configurations that answer the paper's question
(models/secure_autonomy/README.md, "The optimum bracket").

Usage::

    python benchmarks/secure_autonomy_bracket.py [--gap 0.05] [--only NAME ...] [--seed 0]

Every row synthesises ``<<planner>> Pmax=? [ F "retrieved" ]`` with ``api.synthesize(...,
gap=GAP)`` (the search keeps 70 % of the row's timeout, the belief grid of the one-sided game
and then the lower side the rest, docs/synthesis.md) and prints the proven bracket
``optimum = [lower, upper]``, its gap, what proved the bound side, the planner's memory nodes in
the reported defence (more than the row's memory when the lower side replaced it), the wall and
CPU seconds of the row and the load average before and after it (the machine may be shared: CPU
seconds say how much work the row got).
Prints a Markdown table on stdout, one row at a time.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"
PROP = '<<planner>> Pmax=? [ F "retrieved" ]'

ROWS: tuple[tuple[str, dict[str, str], str, float], ...] = (
    ("reports kept", {"N": "3", "flash": "false", "B": "1"}, "1", 600.0),
    ("no take-down", {"N": "3", "flash": "false", "B": "0"}, "1", 120.0),
    ("reports flashed", {"N": "3", "flash": "true", "B": "1"}, "1..2", 600.0),
)
"""(name, constants, memory sizes, timeout in seconds) of each row: N=3 with the reports kept
(``flash=false``), without the adversary's take-down (``B=0``), and with the camera's reports
flashed (``flash=true``, where memory matters)."""


def _memory(text: str) -> tuple[int, ...]:
    lo, _, hi = text.partition("..")
    return tuple(range(int(lo), int(hi or lo) + 1))


def _cpu() -> float:
    """CPU seconds of this process and its finished workers."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def row(name: str, constants: dict[str, str], memory: str, timeout: float, gap: float,
        seed: int) -> str:
    sys.path.insert(0, str(ROOT))
    from posgmc import api

    load0 = os.getloadavg()[0]
    wall0, cpu0 = time.perf_counter(), _cpu()
    result = api.synthesize(api.load(MODEL, constants=dict(constants)), PROP,
                            memory=_memory(memory), timeout=timeout, seed=seed, gap=gap)
    wall, cpu = time.perf_counter() - wall0, _cpu() - cpu0
    load1 = os.getloadavg()[0]
    o = result.optimum
    const = ",".join(f"{k}={v}" for k, v in constants.items())
    # the reported defence's memory nodes (more than --memory when --gap's lower side replaced it)
    nodes = dict(result.memory).get("planner", "-")
    if o is None:
        return f"| {name} | `{const}` | `--memory {memory} --timeout {timeout:g}` | - | - | - | " \
               f"{nodes} | {wall:.0f} | {cpu:.0f} | {load0:.1f}-{load1:.1f} |"
    sound = "" if o.sound else " (not sound)"
    return (f"| {name} | `{const}` | `--memory {memory} --timeout {timeout:g}` | "
            f"[{o.lower:.10g}, {o.upper:.10g}]{sound} | {o.gap:.4f} | {o.method} | {nodes} | "
            f"{wall:.0f} | {cpu:.0f} | {load0:.1f}-{load1:.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gap", type=float, default=0.05)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", nargs="*", default=None, help="row names to run")
    parser.add_argument("--timeout-scale", type=float, default=1.0,
                        help="multiply every row's timeout (a quick look: 0.25)")
    args = parser.parse_args(argv)
    rows = [r for r in ROWS if args.only is None or r[0] in args.only]
    if not rows:
        parser.error(f"--only: no such row (rows: {', '.join(r[0] for r in ROWS)})")
    print(f"`python benchmarks/secure_autonomy_bracket.py --gap {args.gap:g}` "
          f"(seed {args.seed}, {os.cpu_count()} cores):\n")
    print("| row | `--const` | options | optimum [lower, upper] | gap | bound side | "
          "defence nodes | wall s | CPU s | load |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, constants, memory, timeout in rows:
        print(row(name, constants, memory, timeout * args.timeout_scale, args.gap, args.seed),
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
