"""Parsing-speed benchmark of posgmc's PRISM-language front end against Storm, on generated files.

Generates an ``mdp`` with one module of N commands of the form (with ``k`` the command number)::

    [a3] s=k & s<N -> 0.5:(s'=k+1) + 0.5:(s'=max(0,k-1));

and a property file of M properties that cycle through PCTL shapes (``Pmax=? [F "goal"]``,
bounded and unbounded until, reward queries, thresholds, nested ``!``/``&``/``=>``), writes them
to a temporary directory and times:

* posgmc: ``posgmc.syntax.parser.parse_model`` / ``parse_properties`` on the text (reading the
  file is not timed), median of ``--repeat`` runs in one fresh process, after a warm-up parse
  that is not counted; "startup" is that process's ``import posgmc.syntax.parser`` plus building
  the LALR parser (``lark_parser()``), the one-off cost every command-line call pays; "GC after"
  is what Python's cycle collector then spends on the new tree (a generation-0, -1 and -2
  collection right after each parse: the passes the collector would make on its own as the
  program goes on, since the parser pauses it while parsing);
* Storm (when ``POSGMC_REFERENCE_PYTHON`` names an interpreter with stormpy):
  ``stormpy.parse_prism_program(path)`` and
  ``stormpy.parse_properties(text, program)`` (against a small model declaring the property
  file's names), median of ``--repeat`` runs in one fresh process, the first run included (Storm
  has no lazily built parser tables to warm up).

Both tools run in the same invocation, one after the other, so that the ratio is measured under
the same machine load.

Usage::

    python benchmarks/parse_bench.py                        # 1000/5000/20000 commands, 5000 props
    python benchmarks/parse_bench.py --commands 2000 --properties 0 --repeat 5
    python benchmarks/parse_bench.py --no-storm

Prints a markdown table (for docs/performance.md, "Parsing").
"""

from __future__ import annotations

import argparse
import gc
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _locations import reference_python  # benchmarks/_locations.py (this folder is on sys.path)
from _worker import run_worker  # benchmarks/_worker.py (this folder is on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
STORM_PYTHON = reference_python()
DEFAULT_COMMANDS = (1000, 5000, 20000)
DEFAULT_PROPERTIES = (5000,)


# ---------------------------------------------------------------------------------------------
# generated inputs
# ---------------------------------------------------------------------------------------------


def model_text(num_commands: int) -> str:
    """An ``mdp`` with one module of ``num_commands`` commands over ``s`` in ``[0..num_commands]``.

    Args:
        num_commands: how many commands the module has (at least 1).

    Returns:
        The PRISM text (one command per line, plus a label and a reward structure).
    """
    n = num_commands
    lines = ["mdp", "", f"const int N = {n};", "", "module m", f"  s : [0..{n}] init 0;"]
    for k in range(n):
        lines.append(
            f"  [a{k % 7}] s={k} & s<{n} -> 0.5:(s'={k + 1}) + 0.5:(s'=max(0,{k}-1));"
        )
    lines += [
        "endmodule",
        "",
        'label "goal" = s=N;',
        "",
        'rewards "cost"',
        "  [a0] true : 1;",
        "  s>N/2 : 0.5;",
        "endrewards",
        "",
    ]
    return "\n".join(lines)


def properties_text(num_properties: int) -> str:
    """A property file of ``num_properties`` PCTL properties over the model of :func:`model_text`.

    Args:
        num_properties: how many properties (cycling through eight shapes).

    Returns:
        The property file text, one property per line, each ending in ``;``.
    """
    shapes = (
        'Pmax=? [ F "goal" ]',
        "Pmin=? [ s<={k} U s>={k1} ]",
        'R{{"cost"}}min=? [ F s={k} ]',
        "P>=0.5 [ F<=10 s={k} ]",
        "Pmax=? [ G !(s={k}) ]",
        'Pmin=? [ !"goal" U<={k1} (s>{k} & s<N) ]',
        'R{{"cost"}}max=? [ C<={k1} ]',
        "P<0.25 [ X (s={k} => s+1>{k1}*2) ]",
    )
    lines = []
    for i in range(num_properties):
        lines.append(shapes[i % len(shapes)].format(k=i % 97, k1=i % 97 + 1) + ";")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# workers (run in a fresh subprocess; print one JSON line)
# ---------------------------------------------------------------------------------------------


def worker_posgmc(kind: str, path: str, repeat: int) -> dict[str, object]:
    t0 = time.perf_counter()
    sys.path.insert(0, str(ROOT))
    from posgmc.syntax.lalr import lark_parser
    from posgmc.syntax.parser import parse_model, parse_properties

    lark_parser()
    startup = time.perf_counter() - t0
    text = Path(path).read_text(encoding="utf-8")
    parse = parse_model if kind == "model" else parse_properties
    parse(text, file=path)  # warm-up: first-call caches (terminal table, imports)
    gc.collect()
    times, collector = [], []
    for _ in range(repeat):
        t = time.perf_counter()
        tree = parse(text, file=path)
        times.append(time.perf_counter() - t)
        t = time.perf_counter()
        for generation in (0, 1, 2):
            gc.collect(generation)
        collector.append(time.perf_counter() - t)
        del tree
        gc.collect()
    return {
        "startup": startup,
        "parse": statistics.median(times),
        "collector": statistics.median(collector),
    }


def worker_storm(kind: str, path: str, repeat: int, context: str) -> dict[str, object]:
    import stormpy

    times = []
    if kind == "model":
        for _ in range(repeat):
            t = time.perf_counter()
            stormpy.parse_prism_program(path)
            times.append(time.perf_counter() - t)
    else:
        program = stormpy.parse_prism_program(context)
        text = Path(path).read_text(encoding="utf-8")
        for _ in range(repeat):
            t = time.perf_counter()
            stormpy.parse_properties(text, program)
            times.append(time.perf_counter() - t)
    return {"parse": statistics.median(times)}


# ---------------------------------------------------------------------------------------------
# driver
# ---------------------------------------------------------------------------------------------


def _run(python: str, args: list[str], timeout: float) -> dict[str, object]:
    return run_worker(Path(__file__), python, args, timeout)


def _storm_available(python: Path) -> bool:
    if not python.exists():
        return False
    probe = subprocess.run(
        [str(python), "-c", "import stormpy"], check=False, capture_output=True, timeout=120
    )
    return probe.returncode == 0


def _sizes(text: str) -> list[int]:
    return [int(x) for x in text.split(",") if x.strip() and int(x) > 0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--commands",
        default=",".join(map(str, DEFAULT_COMMANDS)),
        help="comma-separated command counts of the generated models",
    )
    parser.add_argument(
        "--properties",
        default=",".join(map(str, DEFAULT_PROPERTIES)),
        help="comma-separated property counts of the generated property files (0: none)",
    )
    parser.add_argument("--repeat", type=int, default=3, help="timed parses per input (median)")
    parser.add_argument("--no-storm", action="store_true", help="skip Storm")
    parser.add_argument(
        "--storm-python",
        default=None if STORM_PYTHON is None else str(STORM_PYTHON),
        help="interpreter with stormpy (default: $POSGMC_REFERENCE_PYTHON)",
    )
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per worker")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.worker:
        tool, kind, path, repeat, *rest = args.worker
        if tool == "posgmc":
            out = worker_posgmc(kind, path, int(repeat))
        else:
            out = worker_storm(kind, path, int(repeat), rest[0] if rest else "")
        print(json.dumps(out))
        return 0

    storm = (
        not args.no_storm
        and args.storm_python is not None
        and _storm_available(Path(args.storm_python))
    )
    if not args.no_storm and not storm:
        where = args.storm_python or "$POSGMC_REFERENCE_PYTHON (unset)"
        print(f"(Storm skipped: no stormpy at {where})", file=sys.stderr)

    header = (
        "| input | lines | posgmc startup (s) | posgmc parse (s) | posgmc µs/line "
        "| posgmc GC after (s) |"
    )
    rule = "|---|---|---|---|---|---|"
    if storm:
        header += " Storm parse (s) | posgmc / Storm |"
        rule += "---|---|"
    lines = [header, rule]
    with tempfile.TemporaryDirectory(prefix="parse_bench_") as tmp:
        context = Path(tmp) / "context.nm"
        context.write_text(model_text(1), encoding="utf-8")
        jobs: list[tuple[str, str, Path]] = []
        for n in _sizes(args.commands):
            path = Path(tmp) / f"commands_{n}.nm"
            path.write_text(model_text(n), encoding="utf-8")
            jobs.append(("model", f"mdp, {n:,} commands", path))
        for n in _sizes(args.properties):
            path = Path(tmp) / f"properties_{n}.props"
            path.write_text(properties_text(n), encoding="utf-8")
            jobs.append(("props", f"{n:,} properties", path))
        for kind, label, path in jobs:
            num_lines = path.read_text(encoding="utf-8").count("\n")
            job = [kind, str(path), str(args.repeat)]
            ours = _run(sys.executable, ["posgmc", *job], args.timeout)
            if "error" in ours:
                lines.append(f"| {label} | {num_lines:,} | posgmc failed: {ours['error']} |")
                print(lines[-1], file=sys.stderr)
                continue
            parse = float(ours["parse"])  # type: ignore[arg-type]
            cells = [
                label,
                f"{num_lines:,}",
                f"{float(ours['startup']):.2f}",  # type: ignore[arg-type]
                f"{parse:.3f}",
                f"{parse / num_lines * 1e6:.0f}",
                f"{float(ours['collector']):.2f}",  # type: ignore[arg-type]
            ]
            if storm:
                theirs = _run(args.storm_python, ["storm", *job, str(context)], args.timeout)
                if "error" in theirs:
                    cells += [f"failed: {theirs['error']}", ""]
                else:
                    storm_parse = float(theirs["parse"])  # type: ignore[arg-type]
                    cells += [f"{storm_parse:.3f}", f"{parse / storm_parse:.1f}x"]
            lines.append("| " + " | ".join(cells) + " |")
            print(lines[-1], file=sys.stderr)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
