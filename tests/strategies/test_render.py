"""show-strategy's table and DOT graph."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from posgmc.cli import main
from posgmc.strategies.files import read_strategy
from posgmc.strategies.render import strategy_dot, strategy_table

ROOT = Path(__file__).resolve().parents[2]
REMEMBER = ROOT / "models" / "rover" / "remember.fss.json"
CAUTIOUS = ROOT / "models" / "rover" / "cautious.fss.json"


def test_table_lists_every_rule() -> None:
    text = strategy_table(read_strategy(REMEMBER))
    lines = text.splitlines()
    assert lines[0] == ("strategy of player 'rover': 3 memory nodes, 7 observations, 21 rules, "
                        "initial node 1, deterministic")
    assert len(lines) == 2 + 3 * 7  # header, column names, one line per (memory, observation)
    assert "0       {x=2}        hold: 1  hold -> 2" in text


def test_randomised_rules_show_their_distribution() -> None:
    text = strategy_table(read_strategy(CAUTIOUS))
    assert "randomised" in text.splitlines()[0]
    assert "fwd: 0.5, hold: 0.5" in text


def test_dot_has_a_node_per_memory_and_an_edge_per_move() -> None:
    dot = strategy_dot(read_strategy(REMEMBER))
    assert dot.startswith('digraph "fss rover" {') and dot.rstrip().endswith("}")
    assert "start -> n1;" in dot and all(f"n{n} [label" in dot for n in range(3))
    assert dot.count(" -> n") - 1 == 21  # one edge per rule (deterministic), plus the start edge
    assert 'n0 -> n2 [label="{x=2} / hold : 1"];' in dot


def test_cli_show_strategy_with_model_and_dot(tmp_path: Path) -> None:
    out = tmp_path / "s.dot"
    r = CliRunner().invoke(
        main,
        [
            "show-strategy",
            str(CAUTIOUS),
            "--model",
            str(ROOT / "models" / "rover.posg"),
            "--dot",
            str(out),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "fwd: 0.5, hold: 0.5" in r.output and out.read_text().startswith("digraph")


def test_cli_show_strategy_reports_a_bad_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "posgmc-fss/1", "player": "rover", "memory_size": 1, '
                   '"observables": ["x"], "rules": [{"memory": 3, "observation": {"x": 1}, '
                   '"action": {"fwd": 1.0}}]}')
    r = CliRunner().invoke(main, ["show-strategy", str(bad)])
    assert (
        r.exit_code == 2
        and f"{bad}: rules[0].memory: memory 3 is not a memory node (0..0)" in r.output
    )


def test_filters_keep_the_rules_of_the_nodes_and_observations_asked() -> None:
    from posgmc.strategies.render import matching_observations

    fss = read_strategy(REMEMBER)
    lines = strategy_table(fss, nodes=[2]).splitlines()
    assert len(lines) == 2 + 7 and all(line.startswith("2 ") for line in lines[2:])
    chosen = matching_observations(fss, {"x": 2})
    lines = strategy_table(fss, observations=chosen).splitlines()
    assert len(lines) == 2 + 3 and all("{x=2}" in line for line in lines[2:])
    assert lines[0] == strategy_table(fss).splitlines()[0]  # the summary is the whole strategy's


def test_compact_rows_cover_exactly_the_observations_with_that_choice() -> None:
    import numpy as np

    from posgmc.strategies.fss import FiniteStateStrategy

    # observations (a, b) in 0..2 x 0..1; "go" everywhere except (2, 1): the compact rows must
    # cover the five "go" points exactly, never (2, 1)
    points = [(a, b) for a in range(3) for b in range(2)]
    action = np.array([[[0.0, 1.0] if p == (2, 1) else [1.0, 0.0] for p in points]])
    fss = FiniteStateStrategy.from_arrays(player="p", observables=("a", "b"),
                                          observation_values=np.array(points),
                                          actions=("go", "stop"), action=action)
    rows = strategy_table(fss, compact=True).splitlines()[2:]
    go = [r.split("  ")[0:2] for r in rows if "go: 1" in r]
    assert len(rows) == 3 and "{a=2, b=1}" in next(r for r in rows if "stop: 1" in r)
    covered = set()
    for row in rows:
        if "go: 1" not in row:
            continue
        box = row.split("{", 1)[1].split("}", 1)[0]
        sets = []
        for part in box.split(", "):
            text = part.split("=", 1)[1]
            lo, _, hi = text.partition("..")
            sets.append(range(int(lo), int(hi) + 1) if hi else [int(v) for v in text.split("|")])
        covered |= {(a, b) for a in sets[0] for b in sets[1]}
    assert covered == set(points) - {(2, 1)} and len(go) == 2


def test_cli_filters_and_their_errors(tmp_path: Path) -> None:
    r = CliRunner().invoke(main, ["show-strategy", str(REMEMBER), "--node", "1",
                                  "--observation", "x=2", "--compact"])
    assert r.exit_code == 0, r.output
    assert r.output.splitlines()[2:] == ["1       {x=2}        fwd: 1  fwd -> 2"]
    r = CliRunner().invoke(main, ["show-strategy", str(REMEMBER), "--observation", "y=1"])
    assert r.exit_code == 2 and "--observation y=1: 'y' is not an observable" in r.output
    r = CliRunner().invoke(main, ["show-strategy", str(REMEMBER), "--observation", "x"])
    assert r.exit_code == 2 and "'x' is not NAME=VALUE" in r.output
    r = CliRunner().invoke(main, ["show-strategy", str(REMEMBER), "--node", "3"])
    assert r.exit_code == 2 and "--node 3: the strategy of player 'rover' has memory nodes 0..2" \
        in r.output
