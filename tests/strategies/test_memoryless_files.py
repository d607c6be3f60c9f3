"""The state-indexed memoryless strategy (``{"property", "memoryless": true, "states"}``), which
``check --export-strategy`` wrote for a fully observable model before it wrote posgmc-fss/1, is
read wherever a strategy is (``check --strategy``, ``show-strategy``, the API), as the player's
strategy with one memory node."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.strategies.files import read_strategies, read_strategy, read_strategy_for
from posgmc.strategies.fss import StrategyError

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.smg")
REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'
# models/rover.props: 0.9876561794 by posgmc's exact solve (Storm 0.987655977)
VALUE = 0.9876561794


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The state-indexed form, as ``check --export-strategy`` wrote it before it wrote
    posgmc-fss/1 (and still writes it where a choice cannot be said by observation and label)."""
    from posgmc.checking.property_checker import CheckOptions
    from posgmc.strategies.files import write_memoryless_strategy

    path = tmp_path_factory.mktemp("export") / "s.json"
    report = api.check(api.load(ROVER), properties=[REACH],
                       options=CheckOptions(keep_strategy=True))
    write_memoryless_strategy(path, REACH, report.model, report.results[0].strategy)
    return path


def test_the_model_has_its_size() -> None:
    assert api.build(api.load(ROVER)).model.num_states == 60


def test_each_player_s_strategy_is_read_with_one_memory_node(exported: Path) -> None:
    rover, attacker = read_strategies(exported)
    assert (rover.player, attacker.player) == ("rover", "attacker")
    assert rover.memory_size == attacker.memory_size == 1 and rover.is_deterministic
    assert rover.observables == ("turn", "x", "budget", "spoofed")
    doc = json.loads(exported.read_text())
    assert rover.num_observations == sum(e["player"] == "rover" for e in doc["states"])
    with pytest.raises(StrategyError, match="players 'rover', 'attacker': say whose"):
        read_strategy(exported)


def test_checking_the_exported_strategy_gives_back_the_value(exported: Path) -> None:
    r = CliRunner().invoke(main, ["check", ROVER, "--prop", REACH, "--strategy",
                                  f"rover={exported}", "--json"])
    assert r.exit_code == 0, r.output
    g = json.loads(r.output)["results"][0]["guaranteed"]
    assert g["lower"] <= VALUE <= g["upper"] and g["upper"] - g["lower"] < 1e-6


def test_show_strategy_shows_each_player(exported: Path) -> None:
    r = CliRunner().invoke(main, ["show-strategy", str(exported), "--compact", "--model", ROVER])
    assert r.exit_code == 0, r.output
    heads = [line for line in r.output.splitlines() if line.startswith("strategy of player")]
    assert [h.split(":")[0] for h in heads] == ["strategy of player 'rover'",
                                               "strategy of player 'attacker'"]
    assert all("1 memory node," in h and "deterministic" in h for h in heads)


def test_a_file_of_other_constants_or_another_model_is_refused(exported: Path,
                                                               tmp_path: Path) -> None:
    doc = json.loads(exported.read_text())
    doc["states"][0]["valuation"]["x"] += 1
    other = tmp_path / "other.json"
    other.write_text(json.dumps(doc))
    model = api.build(api.load(ROVER)).model
    with pytest.raises(StrategyError, match=r"states\[0\]\.valuation: state 0 is"):
        read_strategy_for(other, model, player="rover")


def test_errors_name_the_state_entry_of_the_file(exported: Path, tmp_path: Path) -> None:
    doc = json.loads(exported.read_text())
    rover = [i for i, e in enumerate(doc["states"]) if e["player"] == "rover"]
    doc["states"][rover[1]]["valuation"] = doc["states"][rover[0]]["valuation"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(StrategyError, match=rf"bad.json: states\[{rover[1]}\]: a second rule"):
        read_strategy(bad, player="rover")
