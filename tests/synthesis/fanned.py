"""The commands whose independent parts (constant points, front weights, test runs) fan out on an
executor, on small models, and their output with what may differ run to run (seconds) taken
out: shared by the local pool's tests (test_fanout.py) and the Ray cluster's (test_ray_pool.py),
which compare every number with ``--jobs 1``.

Where the numbers come from: models/beacon with the jammer's budget B left open (memoryless rover:
a coin flip at every budget, models/beacon/README.md); the one-shot choice of
tests/tradeoffs/test_defence.py (cost 1 / mission 1/2 against cost 10 / mission 0.9); the chain of
tests/cli/helpers.py (P(F (x=1 & X x=2)) = p).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from click.testing import CliRunner

from posgmc.cli import main
from tests.cli.helpers import CHAIN
from tests.tradeoffs.helpers import CHOICE

ROOT = Path(__file__).resolve().parents[2]
PROP = '<<rover>> Pmax=? [ F "safe" ]'
SMALL = ["--memory", "1", "--effort", "0.2", "-q"]
"""A work budget that ends far within any clock (no --timeout: the numbers are the budget's)."""


def commands(folder: Path) -> dict[str, list[str]]:
    """The four fanned-out commands on models written into ``folder``."""
    text = (ROOT / "models" / "beacon" / "beacon.posg").read_text()
    assert "const int B = 1;" in text
    budget = folder / "budget.posg"
    budget.write_text(text.replace("const int B = 1;", "const int B;"))
    choice = folder / "choice.pomdp"
    choice.write_text(CHOICE)
    suite = folder / "suite"
    suite.mkdir()
    (suite / "m.prism").write_text(CHAIN)
    (suite / "m.props").write_text(
        "// RESULT (p=0.25): 0.25\n// RESULT (p=0.5): 0.5\n// RESULT (p=0.75): 0.7\n"
        "P=? [ F (x=1 & X x=2) ];\n")
    (suite / "m.props.args").write_text("-const p=0.25\n-const p=0.5\n-const p=0.75\n")
    return {
        "check sweep": ["check", str(budget), "--const", "B=0:1", "--prop", PROP, "--json",
                        *SMALL],
        "pareto sweep": ["pareto", str(budget), "--sweep", "B=0:1", "--prop", PROP, *SMALL],
        "defence front": ["pareto", str(choice), "--prop", 'Pmax=? [ F "goal" ]', "--cost",
                          'R{"cost"}min=? [ F "done" ]', "--weights", "0,30", "--budget", "5",
                          *SMALL],
        "test runs": ["test", str(suite)],
    }


EXIT = {"check sweep": 0, "pareto sweep": 0, "defence front": 0, "test runs": 1}
"""The exit status of each (the chain's p=0.75 RESULT line is wrong on purpose: 0.75, not 0.7,
so that a failing run is compared too)."""


def _without_times(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _without_times(v) for k, v in value.items()
                if k not in ("seconds", "build_seconds", "phases", "synthesis", "points")}
    if isinstance(value, list):
        return [_without_times(v) for v in value]
    return value


def comparable(name: str, output: str) -> Any:
    """``output`` of command ``name`` without its seconds (and where it ran)."""
    if name == "check sweep":
        return _without_times(json.loads(output))
    return re.sub(r", [0-9.]+ s\)", ", _ s)", output)


def run(args: list[str]) -> tuple[int, str]:
    out = CliRunner().invoke(main, args, catch_exceptions=False)
    return out.exit_code, out.stdout


def agrees_with_one_process(name: str, args: list[str], placement: list[str]) -> tuple[str, str]:
    """The command ``name`` (of :func:`commands`) run with ``--jobs 1`` and with the options
    ``placement``: both exit as :data:`EXIT` says and print the same (the seconds aside).
    Returns (one process's output, the placed run's output)."""
    code, one = run(args)
    assert code == EXIT[name], one
    code, placed = run([*args, *placement])
    assert code == EXIT[name], placed
    assert comparable(name, placed) == comparable(name, one)
    return one, placed
