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
    assert lines[0] == "strategy of player 'rover': 3 memory nodes, initial node 1, deterministic"
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
