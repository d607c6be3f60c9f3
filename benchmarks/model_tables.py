"""Regenerate the synthesis tables of the model READMEs from what the commands print.

Synthesis is deterministic (its extent is a work budget counted in its own units,
docs/synthesis.md), so a README table quoting synthesised numbers can be the output of its
commands. Each table is the block between ``<!-- model_tables: NAME -->`` and
``<!-- model_tables: end -->`` in the README; this script runs every row's command
(``posgmc check ... --json``) and rewrites the block. With ``--check`` it rewrites nothing and
exits 1 when a block differs from what the commands print now.

    python benchmarks/model_tables.py                  # every table
    python benchmarks/model_tables.py --only secure_autonomy --check
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from _readme_block import replace_block

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


@dataclass(frozen=True)
class Row:
    """One table row: the arguments after ``posgmc check MODEL`` (shown in the table)."""

    args: tuple[str, ...]


@dataclass(frozen=True)
class Table:
    readme: Path
    model: str  # relative to the README's folder
    props: dict[str, str]  # short name -> property text
    rows: tuple[Row, ...]


MISSION = '<<planner>> Pmax=? [ F "retrieved" ]'
TIME = '<<planner>> R{"time"}min=? [ Fdiscount=0.95 "retrieved" ]'

STEPS = 'R{"steps"}min=? [ F "target" ]'
COST = 'R{"cost"}min=? [ F "opened" ]'
SAFE = '<<rover>> Pmax=? [ F "safe" ]'
ARRIVED = '<<convoy>> Pmax=? [ F "arrived" ]'
ASSET = '<<attacker>> Pmax=? [ F "asset" ]'
GOAL = 'Pmax=? [ F "goal" ]'


def _memories(prop: str) -> tuple[Row, ...]:
    return tuple(Row(("--prop", prop, "--memory", str(k))) for k in (1, 2, 3))


TABLES: dict[str, Table] = {
    "maze": Table(MODELS / "maze" / "README.md", "maze.pomdp", {"steps": STEPS},
                  tuple(Row(("--prop", "steps", "--memory", str(k))) for k in (1, 2, 3))),
    "tiger": Table(MODELS / "tiger" / "README.md", "tiger.pomdp", {"cost": COST},
                   tuple(Row(("--prop", "cost", "--memory", str(k))) for k in (1, 2, 3))),
    "beacon": Table(MODELS / "beacon" / "README.md", "beacon.posg", {"safe": SAFE},
                    _memories("safe")),
    "convoy": Table(
        MODELS / "convoy" / "README.md", "convoy.posg", {"P": ARRIVED},
        (
            *_memories("P"),
            Row(("--prop", "P", "--strategy", "convoy=mixed.fss.json", "--strategy",
                 "attacker=ambushA.fss.json")),
            Row(("--prop", "P", "--strategy", "convoy=mixed.fss.json", "--strategy",
                 "attacker=ambushB.fss.json")),
            Row(("--prop", "P", "--strategy", "attacker=ambush_mixed.fss.json")),
        ),
    ),
    "cyber_deception": Table(MODELS / "cyber_deception" / "README.md", "cyber_deception.posg",
                             {"asset": ASSET}, _memories("asset")),
    "trap_grid": Table(MODELS / "trap_grid" / "README.md", "trap_grid.pomdp", {"goal": GOAL},
                       _memories("goal")),
    "secure_autonomy": Table(
        MODELS / "secure_autonomy" / "README.md", "secure_autonomy.posg",
        {"mission": MISSION, "time": TIME},
        (
            Row(("--const", "N=3,flash=false,B=1", "--prop", "mission", "--memory", "1")),
            Row(("--const", "N=3,flash=false,B=1", "--prop", "time", "--memory", "1")),
            Row(("--const", "N=3,flash=true,B=1", "--prop", "mission", "--memory", "1")),
            Row(("--const", "N=3,flash=true,B=1", "--prop", "mission", "--memory", "1..2")),
        ),
    ),
}


def _bound(b: dict[str, float] | None) -> str:
    if b is None:
        return "–"
    return f"{b['value']:.10g} [{b['lower']:.10g}, {b['upper']:.10g}]"


def run_row(table: Table, row: Row) -> tuple[str, float, float]:
    """The table line of ``row`` and the wall and CPU seconds its command took."""
    args = list(row.args)
    shown = " ".join(args)
    for i, a in enumerate(args):
        if i and args[i - 1] == "--prop":
            args[i] = table.props[a]
    command = [sys.executable, "-m", "posgmc", "check",
               str(table.readme.parent / table.model), *args, "--json", "--quiet"]
    started, cpu = time.perf_counter(), _children_cpu()
    # from the README's folder, as its commands are written (strategy files beside the model)
    out = subprocess.run(command, capture_output=True, text=True, cwd=table.readme.parent,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, check=False)
    seconds, cpu = time.perf_counter() - started, _children_cpu() - cpu
    if out.returncode not in (0, 1):
        raise SystemExit(f"{shown}: exit {out.returncode}\n{out.stderr}")
    r = json.loads(out.stdout)["results"][0]
    rounds = ", ".join(f"k◦={x['memory']}: {x['value_policy_iteration']:.10g}"
                       for x in r.get("rounds", []))
    cut = r.get("cut")
    line = (f"| `{shown}` | {_bound(r.get('guaranteed'))} | {_bound(r.get('vs_fss_adversary'))} "
            f"| {_bound(r.get('upper_bound'))} | {rounds} |"
            + (f" cut by {cut}" if cut else ""))
    return line, seconds, cpu


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def render(table: Table) -> str:
    lines = ["| command (after `posgmc check " + table.model + "`) | guaranteed | "
             "vs_fss_adversary | upper_bound | per memory size (policy iteration) |",
             "|---|---|---|---|---|"]
    for row in table.rows:
        line, seconds, cpu = run_row(table, row)
        print(f"{seconds:6.1f} s wall {cpu:6.1f} s CPU (load {os.getloadavg()[0]:.1f})  {line}",
              file=sys.stderr)
        lines.append(line)
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", action="append", choices=sorted(TABLES))
    parser.add_argument("--check", action="store_true",
                        help="exit 1 when a README differs from what the commands print")
    a = parser.parse_args()
    stale = 0
    for name in a.only or sorted(TABLES):
        table = TABLES[name]
        block = render(table)  # minutes: the README is read after, so edits meanwhile stay
        text = table.readme.read_text()
        new = replace_block(text, f"model_tables: {name}", block, end="<!-- model_tables: end -->")
        if new != text:
            stale += 1
            if a.check:
                print(f"{table.readme}: the {name} table differs from what the commands print",
                      file=sys.stderr)
            else:
                table.readme.write_text(new)
    return 1 if a.check and stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
