"""``check --export-strategy`` (posgmc/cli/strategy_export.py): one destination per property and
constant point, each printed, and the destination checked before any work."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main
from posgmc.cli.strategy_export import destination

ROOT = Path(__file__).resolve().parents[2]
ROVER_POSG = ROOT / "models" / "rover.posg"
ROVER_SMG = str(ROOT / "models" / "rover.smg")
REACH = '<<rover>> Pmax=? [ F "goal" ]'
SAFE_REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'
LATE_REACH = '<<rover>> Pmax=? [ F>=3 "goal" ]'
# small synthesis runs: one memory size, no adversary phases
QUICK = ("--memory", "1", "--adversaries", "0", "--timeout", "3")


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


def _wrote(output: str) -> list[str]:
    return [line.removeprefix("wrote ") for line in output.splitlines()
            if line.startswith("wrote ")]


def test_destination_names() -> None:
    """The names the module docstring promises: the given destination for one property at one
    point, else the property's name or prop<i> and the swept constants."""
    one = dict(index=0, name=None, several_properties=False, point={})
    assert destination("d", directory=True, **one) == "d"  # type: ignore[arg-type]
    assert destination("s.json", directory=False, **one) == "s.json"  # type: ignore[arg-type]
    assert destination("d", directory=True, index=1, name=None, several_properties=True,
                       point={"N": "5"}) == os.path.join("d", "prop2", "N=5")
    assert destination("d", directory=True, index=0, name="safe/ty", several_properties=True,
                       point={}) == os.path.join("d", "safe_ty")
    assert destination("out/s.json", directory=False, index=0, name=None,
                       several_properties=True, point={"N": "5", "p": "0.5"}) \
        == "out/s.prop1.N=5,p=0.5.json"


def test_several_properties_get_a_directory_each_and_each_rechecks(tmp_path: Path) -> None:
    """Before, both went to d/rover.json, which held the second property's strategy: re-checking
    the first property with it gave 0 instead of its reported number."""
    out = tmp_path / "d"
    r = run("check", str(ROVER_POSG), "--prop", LATE_REACH, "--prop", SAFE_REACH, *QUICK,
            "--json", "--export-strategy", str(out))
    assert r.exit_code in (0, 1), r.output
    doc = json.loads(r.stdout)
    written = _wrote(r.stderr)  # on stderr: stdout is one JSON document
    assert written == [str(out / "prop1" / "rover.json"), str(out / "prop2" / "rover.json")]
    for prop, result, path in zip((LATE_REACH, SAFE_REACH), doc["results"], written):
        again = run("check", str(ROVER_POSG), "--prop", prop, "--strategy", f"rover={path}",
                    "--json")
        g = json.loads(again.stdout)["results"][0]["guaranteed"]
        # the same strategy, checked again: both proven intervals hold the same exact value,
        # each as wide as the precision (1e-6)
        reported = result["guaranteed"]
        assert g["lower"] <= reported["upper"] and reported["lower"] <= g["upper"]
        assert g["value"] == pytest.approx(reported["value"], abs=1e-6)


def test_a_sweep_gets_a_file_per_point(tmp_path: Path) -> None:
    """A memoryless strategy per constant point: N=5 and N=6 each keep their own."""
    model = tmp_path / "rover.smg"
    text = Path(ROVER_SMG).read_text()
    assert "const int N = 6;" in text
    model.write_text(text.replace("const int N = 6;", "const int N;"))
    out = tmp_path / "s.json"
    r = run("check", str(model), "--prop", REACH, "--const", "N=5:6", "--export-strategy", str(out))
    assert r.exit_code == 0, r.output
    assert _wrote(r.stdout) == [str(tmp_path / "s.N=5.json"), str(tmp_path / "s.N=6.json")]
    for n in (5, 6):
        doc = json.loads((tmp_path / f"s.N={n}.json").read_text())
        # the valuations are those of that point's model: x reaches N there, never beyond
        assert max(rule["observation"]["x"] for rule in doc["rules"]) <= n
    assert not out.exists()


def _refused_before_work(args: list[str], message: str) -> None:
    started = time.perf_counter()
    r = run("check", str(ROVER_POSG), "--prop", REACH, "--timeout", "30", *args)
    assert r.exit_code == 2, r.output
    assert message in r.output and "internal error" not in r.output
    assert REACH + ":" not in r.output  # no result: nothing was checked
    assert time.perf_counter() - started < 10  # not after the 30 s budget


def test_an_existing_file_is_refused_as_a_directory_before_any_work(tmp_path: Path) -> None:
    f = tmp_path / "taken"
    f.write_text("keep me")
    _refused_before_work(["--export-strategy", str(f)],
                         f"--export-strategy: cannot write {f}: it exists and is not a directory")
    assert f.read_text() == "keep me"


def test_a_path_under_a_file_is_refused_before_any_work(tmp_path: Path) -> None:
    f = tmp_path / "file"
    f.write_text("")
    _refused_before_work(["--export-strategy", str(f / "d")],
                         f"--export-strategy: cannot write {f / 'd'}: Not a directory")


def test_an_empty_path_and_a_device_are_refused_before_any_work() -> None:
    _refused_before_work(["--export-strategy", ""], "--export-strategy: an empty path")
    if os.path.exists("/dev/full"):
        _refused_before_work(["--export-strategy", "/dev/full"],
                             "--export-strategy: cannot write /dev/full: it exists and is not a "
                             "directory")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_a_read_only_directory_is_refused_before_any_work(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        _refused_before_work(["--export-strategy", str(ro / "d")],
                             f"--export-strategy: cannot write {ro / 'd'}: no new file can be "
                             f"created in {ro}")
    finally:
        ro.chmod(0o755)


def test_a_directory_is_refused_as_a_file_before_any_work(tmp_path: Path) -> None:
    r = run("check", ROVER_SMG, "--prop", REACH, "--export-strategy", str(tmp_path))
    assert r.exit_code == 2
    assert f"--export-strategy: cannot write {tmp_path}: it is a directory" in r.output
    assert REACH + ":" not in r.output


def test_given_strategies_have_nothing_to_export(tmp_path: Path) -> None:
    """Before, this said "needs exactly one unbounded P or R query" with one such query."""
    fss = ROOT / "models" / "rover" / "forward.fss.json"
    r = run("check", str(ROVER_POSG), "--prop", REACH, "--strategy", f"rover={fss}",
            "--export-strategy", str(tmp_path / "d"))
    assert r.exit_code == 2
    assert "with --strategy the strategies are given" in r.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.exists("/proc/version"), reason="no /proc here")
def test_a_file_that_takes_no_replacement_is_refused_before_any_work() -> None:
    """/proc/version exists but /proc takes no new file: "No such file or directory" after the
    work before."""
    r = run("check", ROVER_SMG, "--prop", REACH, "--export-strategy", "/proc/version")
    assert r.exit_code == 2 and REACH + ":" not in r.output
    assert ("--export-strategy: cannot write /proc/version: no new file can be created in /proc"
            in r.output)


def test_a_pomdp_strategy_goes_back_as_agent_with_boolean_observables(tmp_path: Path) -> None:
    """A pomdp's one player has no name: its file is agent.json, and --strategy agent=... was
    refused ("the strategy is player ''s"). tiger.pomdp's ``placed`` is a Boolean variable: the
    file writes it true/false, as docs/strategies.md says (it wrote 0/1)."""
    tiger = str(ROOT / "models" / "tiger" / "tiger.pomdp")
    prop = 'Pmax=? [ F "treasure" ]'
    r = run("check", tiger, "--prop", prop, *QUICK, "--json", "--export-strategy",
            str(tmp_path / "d"))
    assert r.exit_code == 0, r.output
    path = tmp_path / "d" / "agent.json"
    doc = json.loads(path.read_text())
    placed = {rule["observation"]["placed"] for rule in doc["rules"]}
    heard = {rule["observation"]["heard"] for rule in doc["rules"]}
    assert placed <= {True, False} and all(type(v) is bool for v in placed)
    assert all(type(v) is int for v in heard)  # heard: [0..2]
    again = run("check", tiger, "--prop", prop, "--strategy", f"agent={path}", "--json")
    assert again.exit_code == 0, again.output
    reported = json.loads(r.stdout)["results"][0]["guaranteed"]
    g = json.loads(again.stdout)["results"][0]["guaranteed"]
    assert g["lower"] <= reported["upper"] and reported["lower"] <= g["upper"]


def test_a_synthesis_sweep_gets_a_directory_per_point(tmp_path: Path) -> None:
    """The directory form under a --const sweep: DIR/<point>/agent.json for each point (a sweep
    kept only its last point's strategy)."""
    text = (ROOT / "models" / "tiger" / "tiger.pomdp").read_text()
    assert "const double accuracy = 0.85;" in text
    model = tmp_path / "tiger.pomdp"
    model.write_text(text.replace("const double accuracy = 0.85;", "const double accuracy;"))
    out = tmp_path / "d"
    r = run("check", str(model), "--prop", 'Pmax=? [ F "treasure" ]', "--const",
            "accuracy=0.75:0.1:0.85", "--memory", "1", "--adversaries", "0", "--timeout", "1",
            "--export-strategy", str(out))
    assert r.exit_code in (0, 1), r.output  # 1: a number the short budget left unproven
    assert _wrote(r.stdout) == [str(out / "accuracy=0.75" / "agent.json"),
                                str(out / "accuracy=0.85" / "agent.json")]
    assert all(Path(p).exists() for p in _wrote(r.stdout))


CHOICE_MDP = """mdp
module m
  s : [0..2] init 0;
  [safe]  s=0 -> 0.9:(s'=1) + 0.1:(s'=0);
  [risky] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [stay]  s>0 -> true;
endmodule
label "one" = s=1;
"""


@pytest.mark.parametrize(("prop", "value"), [('Pmax=? [ F "one" ]', 1.0),
                                             ('Pmin=? [ F "one" ]', 0.5)])
def test_an_mdp_scheduler_is_written_as_the_agent_s_fss_and_rechecks(
        tmp_path: Path, prop: str, value: float) -> None:
    """s=0 either retries (safe: reaches "one" surely) or gambles (risky: 1/2), so the Pmax and the
    Pmin scheduler differ in their one decision; each file, checked again, gives its number."""
    model = tmp_path / "choice.nm"
    model.write_text(CHOICE_MDP)
    out = tmp_path / "s.json"
    r = run("check", str(model), "--prop", prop, "--export-strategy", str(out))
    assert r.exit_code == 0, r.output
    assert _wrote(r.output) == [str(out)]
    doc = json.loads(out.read_text())
    assert (doc["format"], doc["player"], doc["memory_size"]) == ("posgmc-fss/1", "", 1)
    decision = next(rule for rule in doc["rules"] if rule["observation"] == {"s": 0})
    assert decision["action"] == {"safe" if value == 1.0 else "risky": 1.0}
    # the scheduler fixed, the other direction gives the same number
    other = prop.replace("max", "MIN").replace("min", "max").replace("MIN", "min")
    again = run("check", str(model), "--prop", other, "--strategy", str(out), "--json")
    assert again.exit_code == 0, again.output
    g = json.loads(again.stdout)["results"][0]["guaranteed"]
    assert g["lower"] <= value <= g["upper"]
    shown = run("show-strategy", str(out))
    assert shown.exit_code == 0, shown.output
    assert "1 memory node" in shown.output and "deterministic" in shown.output


def test_a_game_strategy_is_the_coalition_s_fss_and_rechecks(tmp_path: Path) -> None:
    """rover.smg: the file is the rover's strategy alone (the attacker's is not the coalition's),
    so ``--strategy FILE`` needs no player and gives back the printed number."""
    out = tmp_path / "s.json"
    r = run("check", ROVER_SMG, "--prop", SAFE_REACH, "--export-strategy", str(out), "--json")
    assert r.exit_code == 0, r.output
    assert _wrote(r.stderr) == [str(out)]
    assert json.loads(out.read_text())["player"] == "rover"
    reported = json.loads(r.stdout)["results"][0]
    again = run("check", ROVER_SMG, "--prop", SAFE_REACH, "--strategy", str(out), "--json")
    assert again.exit_code == 0, again.output
    g = json.loads(again.stdout)["results"][0]["guaranteed"]
    assert g["lower"] <= reported["upper"] and reported["lower"] <= g["upper"]


def test_a_coalition_of_two_gets_a_file_per_player(tmp_path: Path) -> None:
    """red_and_black's ``<<gambler,casino>>``: one file per coalition player; both given back
    reproduce the value (0.064 at start=1, models/red_and_black/README.md)."""
    model = str(ROOT / "models" / "red_and_black" / "red_and_black.smg")
    prop = '<<gambler,casino>> Pmax=? [ F "rich" ]'
    out = tmp_path / "s.json"
    r = run("check", model, "--const", "start=1", "--prop", prop, "--export-strategy", str(out))
    assert r.exit_code == 0, r.output
    gambler, casino = tmp_path / "s.gambler.json", tmp_path / "s.casino.json"
    assert _wrote(r.output) == [str(gambler), str(casino)] and not out.exists()
    again = run("check", model, "--const", "start=1", "--prop", prop, "--strategy",
                f"gambler={gambler}", "--strategy", f"casino={casino}", "--json")
    assert again.exit_code == 0, again.output
    g = json.loads(again.stdout)["results"][0]["guaranteed"]
    assert g["lower"] <= 0.064 <= g["upper"]


def test_a_full_observation_strategy_of_a_posg_stays_state_indexed(tmp_path: Path) -> None:
    """--full-observation on rover.posg: the optimal choices differ between states the rover
    cannot tell apart, so no posgmc-fss/1 file of the rover says them; the state-indexed form is
    written and the message says why."""
    out = tmp_path / "s.json"
    r = run("check", str(ROVER_POSG), "--prop", SAFE_REACH, "--full-observation",
            "--export-strategy", str(out))
    assert r.exit_code == 0, r.output
    assert _wrote(r.output) == [str(out)]
    assert "note: the state-indexed memoryless strategy of every player, not posgmc-fss/1" \
        in r.output
    assert json.loads(out.read_text())["memoryless"] is True
