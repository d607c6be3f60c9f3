"""Pareto fronts of multi(...) queries as a library call, a table, CSV and a picture;
the values themselves are pinned in tests/checking/test_multi.py."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from posgmc.cli import main
from posgmc.errors import InputError, UnsupportedError
from posgmc.tradeoffs.front import front_to_csv, multi_objective

# s0: a (reward 3 in "r", then goal with 1/2) or b (no reward, goal for sure) or c (reward 1,
# goal with 0.8): pure points (3, 0.5), (0, 1), (1, 0.8) of (R{"r"} [C], P[F goal])
MDP = """mdp
module m
  s : [0..2] init 0;
  [a] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [b] s=0 -> (s'=1);
  [c] s=0 -> 0.8:(s'=1) + 0.2:(s'=2);
  [] s>0 -> true;
endmodule
label "goal" = s=1;
rewards "r" [a] true : 3; [c] true : 1; endrewards
"""
PROP = 'multi(R{"r"}max=? [ C ], Pmax=? [ F "goal" ])'


@pytest.fixture()
def model(tmp_path: Path) -> Path:
    path = tmp_path / "m.nm"
    path.write_text(MDP)
    return path


def test_library_front(model: Path) -> None:
    a = multi_objective(model, PROP)
    front = a.front
    assert a.kind.value == "pareto" and a.states == 3
    # (1, 0.8) lies below the segment (3, 0.5)-(0, 1) (at r=1 the segment has 0.833): not a vertex
    assert np.allclose(front.points, [[3, 0.5], [0, 1]], atol=1e-9)
    assert front.precision <= 1e-6 and front.converged
    rows = list(csv.reader(io.StringIO(front_to_csv(front))))
    assert rows[0] == ["kind", 'R{"r"}max=? [ C ]', 'Pmax=? [ F "goal" ]']
    assert [r[0] for r in rows[1:]] == ["achievable"] * 2 + ["over_approximation"] * 2 + [
        "precision"
    ]


def test_library_numerical_and_errors(model: Path) -> None:
    # max reward with P(goal) >= 0.9: mix a (q) and b: 1 - q/2 >= 0.9, q <= 0.2, reward 0.6;
    # c helps: mixing c and b, 1 - 0.2 qc >= 0.9 allows qc = 1/2 with reward 0.5 < 0.6
    assert multi_objective(
        model, 'multi(R{"r"}max=? [ C ], P>=0.9 [ F "goal" ])'
    ).value == pytest.approx(0.6)
    with pytest.raises(InputError):
        multi_objective(model, 'Pmax=? [ F "goal" ]')
    three = multi_objective(
        model, 'multi(R{"r"}max=? [ C ], Pmax=? [ F "goal" ], Pmin=? [ F "goal" ])'
    )
    assert three.front is not None and three.front.points.shape[1] == 3
    with pytest.raises(UnsupportedError, match="at most 5"):
        multi_objective(model, "multi(" + ", ".join(['Pmax=? [ F "goal" ]'] * 6) + ")")


def test_pareto_command_prints_writes_and_draws(model: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    csv_file, plot = tmp_path / "front.csv", tmp_path / "front.svg"
    r = CliRunner().invoke(main, ["pareto", str(model), "--prop", PROP, "--csv", str(csv_file),
                                  "--plot", str(plot)])
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    assert lines[0].startswith(f"{PROP}: Pareto front, 2 vertices")
    assert lines[2].split() == ["achievable", "3", "0.5"] and lines[3].split() == [
        "achievable",
        "0",
        "1",
    ]
    assert "precision" in r.output
    assert csv_file.read_text().startswith("kind,")
    assert "</svg>" in plot.read_text()


def test_pareto_command_on_a_numerical_query(model: Path, tmp_path: Path) -> None:
    r = CliRunner().invoke(
        main, ["pareto", str(model), "--prop", 'multi(Pmax=? [ F "goal" ], R{"r"}>=1 [ C ])']
    )
    # reward >= 1: a with q >= 1/3 gives 1 - q/2 = 5/6; c with qc = 1 gives 0.8; mixing a and c
    # (3 qa + qc >= 1): P = 1 - qa/2 - 0.2 qc, best qa = 1/3 (1/6 lost) vs qc = 1 (0.2 lost): 5/6
    assert r.exit_code == 0 and r.output.startswith(
        'multi(Pmax=? [ F "goal" ], R{"r"}>=1 [ C ]): 0.83333333'
    )
    r = CliRunner().invoke(
        main,
        [
            "pareto",
            str(model),
            "--prop",
            'multi(Pmax=? [ F "goal" ], R{"r"}>=1 [ C ])',
            "--csv",
            str(tmp_path / "x.csv"),
        ],
    )
    assert r.exit_code == 2 and "no front" in r.output and not (tmp_path / "x.csv").exists()
