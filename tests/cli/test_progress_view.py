"""Synthesis progress on the command line (posgmc/cli/progress_view.py) and Ctrl-C during
synthesis (posgmc/synthesis/budget.py, docs/synthesis.md "The work budget").

The model is models/convoy/convoy.posg (19 states; its README derives 0.4 as the convoy's value
against an omniscient attacker), small enough for a run of a second or two; the interrupt test
runs models/rover.posg at a large --effort so that there is time to interrupt it.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main
from posgmc.cli.progress_view import ProgressMode, progress_mode

ROOT = Path(__file__).resolve().parents[2]
CONVOY = str(ROOT / "models" / "convoy" / "convoy.posg")
PROP = '<<convoy>> Pmax=? [ F "arrived" ]'
ROVER = str(ROOT / "models" / "rover.posg")
ROVER_PROP = '<<rover>> Pmax=? [ !"crash" U "goal" ]'


def _check(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, ["check", CONVOY, "--prop", PROP, "--memory", "1", *args])


def test_progress_lines_name_the_phase_and_the_best_value() -> None:
    r = _check("--progress")
    assert r.exit_code == 0, r.output
    lines = [x for x in r.stderr.splitlines() if x.startswith("synthesis: ")]
    phases = [x.split(": ", 1)[1].split(" |")[0] for x in lines]
    assert "full observation" in phases and "verification" in phases
    assert any(p.startswith("gradient search k=1") for p in phases)
    assert "guaranteed 0.4" in lines[-1]  # the proven number last (convoy's README: 0.4)
    assert "best so far" in "\n".join(lines)
    # progress goes to stderr (the result's own "  synthesis: ..." line is indented)
    assert not any(x.startswith("synthesis: ") for x in r.stdout.splitlines())


def test_without_progress_a_non_terminal_gets_none_and_quiet_silences() -> None:
    assert progress_mode(quiet=False, lines=False, json_lines=False) is ProgressMode.NONE
    assert progress_mode(quiet=True, lines=True, json_lines=True) is ProgressMode.NONE
    assert progress_mode(quiet=False, lines=True, json_lines=False) is ProgressMode.LINES
    for args in ((), ("--progress", "--quiet")):
        r = _check(*args)
        assert r.exit_code == 0, r.output
        assert "synthesis: " not in r.stderr


def test_json_lines_carry_progress_events_between_model_and_result() -> None:
    r = _check("--json-lines")
    assert r.exit_code == 0, r.output
    objects = [json.loads(x) for x in r.stdout.splitlines()]
    assert "model" in objects[0] and "property" in objects[-1]
    events = [o["progress"] for o in objects[1:-1]]
    assert events and all(set(e) >= {"phase", "best", "proven", "elapsed"} for e in events)
    assert events[-1]["proven"] is True and events[-1]["best"] == objects[-1]["guaranteed"]["lower"]


def test_effort_is_validated_by_name() -> None:
    for bad in ("0", "-1", "nan", "inf"):
        r = _check("--effort", bad)
        assert r.exit_code == 2
        assert "--effort" in r.output


def _wait_for(path: Path, text: str, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if path.exists() and text in path.read_text():
            return
        time.sleep(0.05)
    raise AssertionError(f"{text!r} not seen in {path}: {path.read_text()!r}")


def test_ctrl_c_prints_exports_and_keeps_the_best_verified_defence(tmp_path: Path) -> None:
    """SIGINT during the gradient search: exit 130, the result printed with its proven
    guaranteed and marked INTERRUPTED, the defence exported; checking the exported file gives
    the printed number."""
    out, err = tmp_path / "out.txt", tmp_path / "err.txt"
    export = tmp_path / "defence"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with out.open("w") as o, err.open("w") as e:
        proc = subprocess.Popen(
            [sys.executable, "-m", "posgmc", "check", ROVER, "--prop", ROVER_PROP, "--effort",
             "50", "--progress", "--json-lines", "--export-strategy", str(export)],
            stdout=o, stderr=e, env=env)
        try:
            _wait_for(out, '"phase": "gradient search"', 60)
            proc.send_signal(signal.SIGINT)
            code = proc.wait(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert code == 130, err.read_text()
    result = json.loads(out.read_text().splitlines()[-1])
    assert result["cut"] == "interrupt" and result["partial"] is True
    g = result["guaranteed"]
    assert result["sound"] is True and g["lower"] <= g["upper"]
    again = CliRunner().invoke(main, ["check", ROVER, "--prop", ROVER_PROP, "--json",
                                      "--strategy", f"rover={export / 'rover.json'}"])
    assert again.exit_code == 0, again.output
    checked = json.loads(again.stdout)["results"][0]["guaranteed"]
    assert (checked["lower"], checked["upper"]) == (g["lower"], g["upper"])


# by hand: x=0 reaches x=1 with probability p, else x=2; P(F x=1) = p
CHAIN = """dtmc
const double p;
module m x : [0..2] init 0; [] x=0 -> p:(x'=1) + 1-p:(x'=2); [] x>0 -> true; endmodule
"""


def test_a_check_sweep_reports_each_point_as_it_completes(tmp_path: Path) -> None:
    """check --const p=...: the table comes at the end, so each point is reported on its own as it
    completes, with its number (the chain's by hand: 0.1, 0.5, 0.9): a --progress line on stderr,
    a progress event with --json-lines."""
    path = tmp_path / "chain.prism"
    path.write_text(CHAIN)
    args = ["check", str(path), "--prop", "P=? [ F x=1 ]", "--const", "p=0.1:0.4:0.9"]
    r = CliRunner().invoke(main, [*args, "--progress"])
    assert r.exit_code == 0, r.output
    done = [x for x in r.stderr.splitlines() if x.startswith("sweep: point ")]
    assert [x.split("point ")[1].split(" done")[0] for x in done] == ["p=0.1", "p=0.5", "p=0.9"]
    for i, (line, want) in enumerate(zip(done, ("0.1", "0.5", "0.9")), start=1):
        assert f"guaranteed {want}" in line and f"point {i}/3" in line
    r = CliRunner().invoke(main, [*args, "--json-lines"])
    assert r.exit_code == 0, r.output
    objects = [json.loads(x) for x in r.stdout.splitlines()]
    events = [o["progress"] for o in objects if "progress" in o]
    assert [(e["unit"], e["done"], e["total"]) for e in events] == [("point", i, 3)
                                                                    for i in (1, 2, 3)]
    assert [round(e["best"], 9) for e in events] == [0.1, 0.5, 0.9]
    assert "runs" in objects[-1]  # then the sweep's one JSON object, as --json prints it


# by hand: x=0 stays with probability q, reaches x=1 with 0.375, else x=2: P(F x=1) = 0.375/(1-q),
# 0.5 at q=0.25 and 0.75 at q=0.5; interval iteration stops near, not at, those values
LOOP = """dtmc
const double q;
module m x : [0..2] init 0;
  [] x=0 -> q:(x'=0) + 0.375:(x'=1) + 0.625-q:(x'=2); [] x>0 -> true;
endmodule
"""


def test_a_sweep_point_prints_its_number_as_the_table_does(tmp_path: Path) -> None:
    """A point's progress line shows the shortest decimal inside the proven interval, the same
    text as the sweep's table, not the iteration's raw point (e.g. 0.7499998924)."""
    path = tmp_path / "loop.prism"
    path.write_text(LOOP)
    args = ["check", str(path), "--prop", "P=? [ F x=1 ]", "--const", "q=0.25:0.25:0.5"]
    raw = json.loads(CliRunner().invoke(main, [*args, "--json"]).stdout)
    values = [run["results"][0]["value"] for run in raw["runs"]]
    assert values != [0.5, 0.75]  # the raw numbers are not the short ones: the test can fail
    r = CliRunner().invoke(main, [*args, "--progress"])
    assert r.exit_code == 0, r.output
    table = [line.split("\t")[1] for line in r.stdout.splitlines() if line.startswith("0.")]
    assert table == ["0.5", "0.75"]
    done = [x for x in r.stderr.splitlines() if x.startswith("sweep: point ")]
    assert [x.split(" | ")[1] for x in done] == [f"guaranteed {t}" for t in table]
    r = CliRunner().invoke(main, [*args, "--json-lines"])
    events = [json.loads(x)["progress"] for x in r.stdout.splitlines() if '"progress"' in x]
    # JSON keeps full precision, with the proven bounds the text was shortened within
    assert [e["best"] for e in events] == values
    assert all(e["bound"]["lower"] <= e["best"] <= e["bound"]["upper"] for e in events)


def _children(pid: int) -> list[int]:
    """The child processes of ``pid`` (forked by any of its threads)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:  # the thread ended
            pass
    return found


def _interrupt_group(args: list[str], tmp_path: Path, *, jobs: int) -> tuple[int, str, str]:
    """Run ``posgmc ARGS`` in its own process group, send SIGINT to the group (as a terminal's
    Ctrl-C) once the run is into its search (one job: the "gradient search" progress line; a
    pool: its ``jobs`` workers started and a second into their points), and return the exit
    code, stdout and stderr. The whole group is killed afterwards: a pool's workers must not
    outlive a failed test."""
    out, err = tmp_path / "out.txt", tmp_path / "err.txt"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with out.open("w") as o, err.open("w") as e:
        proc = subprocess.Popen([sys.executable, "-m", "posgmc", *args], stdout=o, stderr=e,
                                env=env, start_new_session=True)
        try:
            if jobs == 1:
                _wait_for(err, "gradient search", 60)
            else:
                end = time.monotonic() + 60
                while len(_children(proc.pid)) < jobs and time.monotonic() < end:
                    time.sleep(0.05)
                assert len(_children(proc.pid)) == jobs
                time.sleep(1.0)  # the workers are into their points' searches
            os.killpg(proc.pid, signal.SIGINT)
            code = proc.wait(timeout=120)
        finally:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    return code, out.read_text(), err.read_text()


@pytest.mark.parametrize(("command", "jobs"), [("check", 1), ("check", 2), ("pareto", 2)])
def test_ctrl_c_during_a_sweep_reports_finished_cut_and_cancelled_points(
        tmp_path: Path, command: str, jobs: int) -> None:
    """SIGINT to the process group (as a terminal's Ctrl-C) during a check --const or a pareto
    --sweep, in one process or on a local pool: exit 130; each point cut short reports its best
    verified defence in the table; a line on stderr names the points finished, cut short and
    cancelled, which together are the sweep's four points (models/beacon with its budget B left
    open)."""
    if not Path("/proc/self/task").exists():
        pytest.skip("finds the pool's workers through /proc")
    model = tmp_path / "budget.posg"
    text = (ROOT / "models" / "beacon" / "beacon.posg").read_text()
    assert "const int B = 1;" in text
    model.write_text(text.replace("const int B = 1;", "const int B;"))
    code, out, err = _interrupt_group(
        [command, str(model), "--prop", '<<rover>> Pmax=? [ F "safe" ]',
         "--const" if command == "check" else "--sweep", "B=0:3", "--memory", "1",
         "--effort", "500", "--jobs", str(jobs), "--progress"],
        tmp_path, jobs=jobs)
    assert code == 130, err
    summary = [x for x in err.splitlines() if x.startswith("interrupted: ")]
    assert len(summary) == 1, err
    line = summary[0]
    finished = line.split(" points finished (")[1].split(")")[0].split("; ")
    cut = line.split("defence reported: ")[1].split("; cancelled")[0].split("; ")
    cancelled = line.split("cancelled: ")[1].split("; ") if "cancelled: " in line else []
    # the points running when interrupted (one per job) were cut short and still reported
    assert finished == [f"B={b}" for b in range(len(finished))] and len(finished) >= jobs
    assert cut == finished[:len(cut)] and len(cut) >= jobs
    assert finished + cancelled == [f"B={b}" for b in range(4)] and cancelled
    assert f"{len(finished)} of 4 points finished" in line
    rows = [x.split() for x in out.splitlines() if x[:1].isdigit()]
    assert [r[0] for r in rows] == [f.split("=")[1] for f in finished]
    # every reported number is proven: a memoryless rover guesses the exit, 0.5 (beacon's README)
    assert all(r[1] == "0.5" for r in rows)


def test_ctrl_c_during_a_defence_front_reports_its_weights_and_writes_no_csv(
        tmp_path: Path) -> None:
    """SIGINT to the process group during pareto --cost on a pool of two: exit 130, the weights
    that finished are printed (the running ones wound down: "(partial)"), the last line names
    the cancelled ones, and no CSV of half a front is written."""
    if not Path("/proc/self/task").exists():
        pytest.skip("finds the pool's workers through /proc")
    model = tmp_path / "budget.posg"
    text = (ROOT / "models" / "beacon" / "beacon.posg").read_text()
    model.write_text(text + '\nrewards "time"\n  true : 1;\nendrewards\n')
    table = tmp_path / "front.csv"
    code, out, err = _interrupt_group(
        ["pareto", str(model), "--prop", '<<rover>> Pmax=? [ F "safe" ]', "--cost",
         '<<rover>> R{"time"}min=? [ F "over" ]', "--weights", "0,1,2,5", "--memory", "1",
         "--effort", "500", "--jobs", "2", "--csv", str(table)],
        tmp_path, jobs=2)
    assert code == 130, err
    line = [x for x in err.splitlines() if x.startswith("interrupted: ")][-1]
    finished = line.split(" points finished (")[1].split(")")[0].split("; ")
    cancelled = line.split("cancelled: ")[1].split("; ")
    assert finished + cancelled == ["w=0", "w=1", "w=2", "w=5", "w=inf"]
    assert len(finished) >= 2 and "of 5 points finished" in line
    rows = [x.split()[0] for x in out.splitlines() if x[:1].isdigit()]
    assert rows == [w.split("=")[1] for w in finished]
    assert not table.exists()
