"""Trade-off fronts by sweeping a constant: every point verified, every synthesised
point re-verified from its exported strategy, CSV and plot written whole."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.synthesis.options import SynthesisOptions
from posgmc.tradeoffs.sweep import sweep, to_csv

ROOT = Path(__file__).resolve().parents[2]
PROP = '<<rover>> Pmax=? [ F "safe" ]'

# by hand: x=0 reaches x=1 with probability p, else x=2; P(F x=1) = p
CHAIN = """dtmc
const double p;
module m x : [0..2] init 0; [] x=0 -> p:(x'=1) + 1-p:(x'=2); [] x>0 -> true; endmodule
"""

# by hand: x=0 stays with probability q, reaches x=1 with 0.375, else x=2: P(F x=1) = 0.375/(1-q)
LOOP = """dtmc
const double q;
module m x : [0..2] init 0;
  [] x=0 -> q:(x'=0) + 0.375:(x'=1) + 0.625-q:(x'=2); [] x>0 -> true;
endmodule
"""


@pytest.fixture()
def budget_model(tmp_path: Path) -> Path:
    """models/beacon with the jammer's budget B left open: each jam costs the remembering rover a
    wait survived with probability 0.9, so the optimum is 0.9^B (models/beacon/README.md)."""
    text = (ROOT / "models" / "beacon" / "beacon.posg").read_text()
    assert "const int B = 1;" in text
    path = tmp_path / "budget.posg"
    path.write_text(text.replace("const int B = 1;", "const int B;"))
    return path


def test_a_fully_observable_sweep_is_the_value_per_point(tmp_path: Path) -> None:
    path = tmp_path / "chain.prism"
    path.write_text(CHAIN)
    s = sweep(path, "P=? [ F x=1 ]", constant="p", settings=["0.1", "1/2", "0.9"])
    assert [p.setting for p in s.points] == ["0.1", "1/2", "0.9"]
    for p, want in zip(s.points, (0.1, 0.5, 0.9)):
        b = p.main_number()
        assert b is not None and b.lower - 1e-12 <= want <= b.upper + 1e-12
        assert p.result is not None and p.result.guaranteed is None



def test_pareto_reports_each_point_as_it_completes(tmp_path: Path) -> None:
    """--progress: one "point p=... done" line on stderr per point, in order, with its number
    (the chain's values by hand: 0.1, 0.5, 0.9), before the table on stdout."""
    path = tmp_path / "chain.prism"
    path.write_text(CHAIN)
    r = CliRunner().invoke(main, ["pareto", str(path), "--prop", "P=? [ F x=1 ]", "--sweep",
                                  "p=0.1:0.4:0.9", "--progress"])
    assert r.exit_code == 0, r.output
    done = [x for x in r.stderr.splitlines() if " done" in x]
    assert [x.split("point ")[1].split(" done")[0] for x in done] == ["p=0.1", "p=0.5", "p=0.9"]
    for line, want in zip(done, ("0.1", "0.5", "0.9")):
        assert f"guaranteed {want}" in line and "point " in line


def test_pareto_prints_a_point_as_its_table_does(tmp_path: Path) -> None:
    """A point's progress line shows the shortest decimal inside its proven interval, as the
    table does: P(F x=1) = 0.375/(1-q) by hand, 0.75 at q=0.5, where interval iteration stops at
    about 0.7499998924 (tests/cli/test_progress_view.py pins that)."""
    path = tmp_path / "loop.prism"
    path.write_text(LOOP)
    r = CliRunner().invoke(main, ["pareto", str(path), "--prop", "P=? [ F x=1 ]", "--sweep",
                                  "q=0.25:0.25:0.5", "--progress"])
    assert r.exit_code == 0, r.output
    done = [x for x in r.stderr.splitlines() if " done" in x]
    assert [x.split(" | ")[1] for x in done] == ["guaranteed 0.5", "guaranteed 0.75"]
    rows = [line.split()[:2] for line in r.stdout.splitlines()[2:]]
    assert rows == [["0.25", "0.5"], ["0.5", "0.75"]]  # the table's value column
    assert "0.7499998924" not in r.stderr  # the raw point (the bounds are printed as they are)

# the guaranteed front over B = 0, 1 per memory size (models/beacon/README.md): a memoryless rover
# reaches the exits not knowing which is safe, a coin flip whatever the budget; with two nodes
# 0.9^B. The synthesis tests below run with one node by default (half the time: 8 s against 17 s
# each); their two-node variants run with -m slow (two-node synthesis on beacon stays in the
# default run: the tutorial, test_synthesis.py::test_cli_memory_per_player_and_adversary_memory)
FRONT = {1: (0.5, 0.5), 2: (1.0, 0.9)}
MEMORY = [1, pytest.param(2, marks=pytest.mark.slow)]


@pytest.mark.parametrize("memory", MEMORY)
def test_every_point_of_a_posg_front_reverifies_from_its_strategy(
    budget_model: Path, tmp_path: Path, memory: int
) -> None:
    out = tmp_path / "strategies"
    s = sweep(budget_model, PROP, constant="B", settings=["0", "1"],
              synthesis=SynthesisOptions(memory=(memory,), timeout=20), strategy_dir=out)
    for p, want in zip(s.points, FRONT[memory]):
        g = p.main_number()
        assert g is not None and g.lower - 1e-9 <= want <= g.upper + 1e-9
        assert p.strategy_dir == str(out / f"B={p.setting}")
        # the exported defence, checked again on its own, guarantees the same
        again = api.check(api.load(budget_model, constants={"B": p.setting}), properties=[PROP],
                          strategies={"rover": Path(p.strategy_dir) / "rover.json"}).results[0]
        assert again.guaranteed.lower == pytest.approx(g.lower, abs=1e-9)
    rows = list(csv.DictReader(io.StringIO(to_csv(s))))
    assert [r["setting"] for r in rows] == ["0", "1"]
    assert float(rows[1]["lower"]) <= FRONT[memory][1] <= float(rows[1]["upper"])
    assert rows[1]["memory"] == f"rover={memory}" and rows[1]["full_observation"] == "1.0"
    # each number with its proven bounds (upper_bound had its value only, even a placeholder)
    for key in ("full_observation", "upper_bound"):
        b = getattr(s.points[1].result, key)
        assert b is not None and b.converged  # computed, not cut short
        assert [rows[1][key], rows[1][f"{key} lower"], rows[1][f"{key} upper"]] == [
            repr(b.value), repr(b.lower), repr(b.upper)]
        assert float(rows[1]["lower"]) <= float(rows[1][f"{key} upper"]) + 1e-9


@pytest.mark.parametrize(("memory", "table"), [
    (1, ("0  0.5 [0.4999999999, 0.5000000001]", "1  0.5 [0.4999999999, 0.5000000001]")),
    pytest.param(2, ("0  1 [1, 1]", "1  0.9 ["), marks=pytest.mark.slow),
], ids=["1", "2"])
def test_pareto_command_table_csv_and_plot(
    budget_model: Path, tmp_path: Path, memory: int, table: tuple[str, str]
) -> None:
    pytest.importorskip("matplotlib")
    csv_file, plot = tmp_path / "f.csv", tmp_path / "f.svg"
    r = CliRunner().invoke(main, ["pareto", str(budget_model), "--prop", PROP, "--sweep", "B=0:1",
                                  "--memory", str(memory), "--timeout", "20", "--csv",
                                  str(csv_file), "--plot", str(plot)])
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert lines[0] == f"{PROP} against B:"
    assert lines[2].startswith(table[0]) and lines[3].startswith(table[1])
    # full_observation and upper_bound with their proven bounds: the full-observation value is 1
    # named by their role for a maximiser, the CSV's names beside
    assert lines[1].split()[:4] == ["B", "value", "[lower,", "upper]"]
    assert "no defence above, full observation (full_observation)" in lines[1]
    assert "no defence above (upper_bound)" in lines[1]
    assert "1 [1, 1]" in lines[2].split("]", 1)[1]
    assert csv_file.read_text().startswith("constant,setting,value,lower,upper")
    assert plot.read_text().lstrip().startswith("<?xml") and "</svg>" in plot.read_text()


def test_pareto_refuses_what_it_cannot_do(budget_model: Path, tmp_path: Path) -> None:
    r = CliRunner().invoke(
        main,
        [
            "pareto",
            str(budget_model),
            "--prop",
            'multi(Pmax=? [ F "safe" ], Pmax=? [ F "over" ])',
            "--sweep",
            "B=0:1",
        ],
    )
    assert r.exit_code == 2 and "--sweep does not apply" in r.output
    r = CliRunner().invoke(
        main,
        [
            "pareto",
            str(budget_model),
            "--prop",
            'multi(Pmax=? [ F "safe" ], Pmax=? [ F "safe" ])',
            "--const",
            "B=1",
        ],
    )
    assert r.exit_code == 2 and "not on posg models" in r.output
    r = CliRunner().invoke(main, ["pareto", str(budget_model), "--prop", PROP, "--sweep", "B=1"])
    assert r.exit_code == 2 and "one constant with a range" in r.output
    r = CliRunner().invoke(
        main,
        [
            "pareto",
            str(budget_model),
            "--prop",
            PROP,
            "--sweep",
            "B=0:1",
            "--plot",
            str(tmp_path / "f.txt"),
            "--memory",
            "1",
            "--timeout",
            "5",
        ],
    )
    assert r.exit_code == 2 and ".png, .svg or .pdf" in r.output
    assert not (tmp_path / "f.txt").exists()


def test_check_sweep_draws_a_plot(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    path, plot = tmp_path / "chain.prism", tmp_path / "sweep.svg"
    path.write_text(CHAIN)
    r = CliRunner().invoke(main, ["check", str(path), "--prop", "P=? [ F x=1 ]", "--prop",
                                  "P=? [ F x=2 ]", "--const", "p=0.1:0.4:0.9", "--plot", str(plot)])
    assert r.exit_code == 0, r.output
    svg = plot.read_text()
    # one series per property, each point annotated with its value (0.1, 0.5, 0.9 and reversed)
    assert "</svg>" in svg and svg.count("P=? [ F x=1 ]") >= 1 and svg.count("P=? [ F x=2 ]") >= 1
    r = CliRunner().invoke(main, ["check", str(path), "--prop", "P=? [ F x=1 ]", "--const", "p=0.5",
                                  "--plot", str(tmp_path / "none.svg")])
    assert r.exit_code == 2 and "one swept constant" in r.output
    assert not (tmp_path / "none.svg").exists()


@pytest.mark.parametrize("memory", MEMORY)
def test_also_properties_are_verified_under_each_points_defence(
    budget_model: Path, tmp_path: Path, memory: int
) -> None:
    # the sweep's own property as an --also property: under the same defence it must guarantee
    # the same number (the same strategy, verified a second time); a second objective (mission
    # over within 6 steps) gets its own verified number
    s = sweep(budget_model, PROP, constant="B", settings=["1"],
              synthesis=SynthesisOptions(memory=(memory,), timeout=20),
              also=[PROP, '<<rover>> Pmax=? [ F<=6 "over" ]'])
    (p,) = s.points
    same, bounded = p.also
    assert same.guaranteed.lower == pytest.approx(p.result.guaranteed.lower, abs=1e-9)
    assert 0.0 <= bounded.guaranteed.lower <= bounded.guaranteed.upper <= 1.0
    header = next(csv.reader(io.StringIO(to_csv(s))))
    assert header[-3:] == [
        '<<rover>> Pmax=? [ F<=6 "over" ] guaranteed',
        '<<rover>> Pmax=? [ F<=6 "over" ] lower',
        '<<rover>> Pmax=? [ F<=6 "over" ] upper',
    ]


def test_also_needs_a_synthesised_defence(tmp_path: Path) -> None:
    path = tmp_path / "chain.prism"
    path.write_text(CHAIN)
    s = sweep(path, "P=? [ F x=1 ]", constant="p", settings=["0.5"], also=["P=? [ F x=2 ]"])
    (error,) = s.points[0].also
    assert "no synthesised strategy" in error.message


def test_an_error_of_every_point_is_the_sweep_s_said_once(tmp_path: Path) -> None:
    path = tmp_path / "chain.prism"
    path.write_text(CHAIN.replace("const double p;", "const double p;\nconst int k;"))
    r = CliRunner().invoke(main, ["pareto", str(path), "--prop", "P=? [ F x=1 ]", "--sweep",
                                  "p=0.1:0.4:0.9"])
    assert r.exit_code == 2
    assert r.output.count('undefined constant "k" must be given a value') == 1, r.output
    assert "Error" not in r.output  # no table of failed points
    # a point of its own error keeps it, the others go on: p = 2 is no probability
    s = sweep(path, "P=? [ F x=1 ]", constant="p", settings=["0.5", "2"], constants={"k": 1})
    assert s.points[0].error is None and s.points[1].error is not None


def test_the_table_prints_values_as_the_shortest_decimal_inside_their_bounds() -> None:
    # red_and_black's bold play: exactly 0.064 from start=1 and 0.16 from start=2
    # (models/red_and_black/README.md); interval iteration stops around them
    model = str(ROOT / "models" / "red_and_black" / "red_and_black.smg")
    r = CliRunner().invoke(main, ["pareto", model, "--prop",
                                  '<<gambler,casino>> Pmax=? [ F "rich" ]', "--sweep",
                                  "start=1:2"])
    assert r.exit_code == 0, r.output
    rows = [line.split()[:2] for line in r.output.splitlines()[2:4]]
    assert rows == [["1", "0.064"], ["2", "0.16"]]
