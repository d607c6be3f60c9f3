"""Bad or extreme input gets a clear answer: a positioned message and exit 2, never an internal
error."""

from __future__ import annotations

import json
import os
import re
import stat
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main
from posgmc.engines.options import SolverOptions
from posgmc.errors import InputError
from tests.conftest import BENCHMARKS

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.smg")
REACH = '<<rover>> Pmax=? [ F "goal" ]'


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


@pytest.mark.parametrize(
    "fmt, target",
    [("drn", "nodir/x.drn"), ("drn", ""), ("prism", "nodir/x"), ("dot", "nodir/x.dot")],
)
def test_export_to_an_impossible_path_names_the_users_path(
    tmp_path: Path, fmt: str, target: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    r = run("build", ROVER, "--export", fmt, target)
    assert r.exit_code == 2
    assert f"cannot write {target or repr(target)}" in r.output or (
        fmt == "prism" and f"cannot write {target}." in r.output
    )
    assert ".tmp" not in r.output and "internal error" not in r.output
    assert list(tmp_path.iterdir()) == []


def test_export_strategy_to_a_missing_directory(tmp_path: Path) -> None:
    r = run("check", ROVER, "--prop", REACH, "--export-strategy", str(tmp_path / "no" / "s.json"))
    assert r.exit_code == 2 and f"cannot write {tmp_path / 'no' / 's.json'}" in r.output


def test_writing_into_a_device_never_replaces_it() -> None:
    """/dev/full is written into (and reports a full disk); an atomic rename would replace it."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    r = run("build", ROVER, "--export", "drn", "/dev/full")
    assert r.exit_code == 2 and "cannot write /dev/full: No space left on device" in r.output
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)
    assert run("build", ROVER, "--export", "drn", "/dev/null").exit_code == 0
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


@pytest.mark.parametrize("value", ["nan", "inf", "0", "-1e-6"])
def test_precision_must_be_positive_and_finite(value: str) -> None:
    r = run("check", ROVER, "--prop", REACH, "--precision", value)
    assert r.exit_code == 2 and "is not a positive finite number" in r.output
    with pytest.raises(InputError, match="positive finite"):
        SolverOptions(precision=float(value))


def test_interruption_has_its_own_exit_code(monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted(*_a: object, **_k: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "check", interrupted)
    r = run("check", ROVER, "--prop", REACH)
    assert r.exit_code == 130 and "interrupted" in r.output
    monkeypatch.setattr(api, "build", interrupted)  # build exited 1 too
    r = run("build", ROVER)
    assert r.exit_code == 130 and "interrupted" in r.output


def test_empty_properties_file_is_an_error(tmp_path: Path) -> None:
    props = tmp_path / "empty.props"
    props.write_text("// only a comment\n")
    r = run("check", ROVER, str(props))
    assert r.exit_code == 2 and f"{props} holds no property" in r.output


def test_a_player_twice_in_a_coalition() -> None:
    r = run("check", ROVER, "--prop", '<<rover,1>> Pmax=? [ F "goal" ]')
    assert r.exit_code == 2
    assert '<--prop 1>:1:9: error: player "rover" appears twice in the coalition' in r.output


@pytest.mark.parametrize("gamma", ["1.5", "1"])
def test_one_discount_rule_and_message(gamma: str) -> None:
    r = run("check", ROVER, "--prop", f'<<rover>> R{{"steps"}}min=? [ Cdiscount={gamma} ]')
    assert r.exit_code == 2 and f"the discount factor {gamma} is not in [0, 1)" in r.output


def test_discount_zero_is_the_first_reward() -> None:
    # with γ = 0 only the first step counts: the rover's first move costs 1 (models/rover.smg)
    r = run("check", ROVER, "--prop", '<<rover>> R{"steps"}min=? [ Cdiscount=0 ]', "--json")
    assert r.exit_code == 0, r.output
    import json

    res = json.loads(r.output)["results"][0]
    assert res["lower"] <= 1.0 <= res["upper"]


def test_prism_file_mentioning_type_in_a_comment_is_prism(tmp_path: Path) -> None:
    model = tmp_path / "m.prism"
    model.write_text("// converted from @type: DTMC files\ndtmc\nmodule m x : [0..1] init 0;\n"
                     "  [] x=0 -> (x'=1);\n  [] x=1 -> true;\nendmodule\n")
    r = run("build", str(model), "--json")
    assert r.exit_code == 0, r.output
    assert '"states": 2' in r.output


def test_drn_with_a_byte_order_mark(tmp_path: Path) -> None:
    drn = Path(_test_game())
    copy = tmp_path / "bom.drn"
    copy.write_text("\ufeff" + drn.read_text(encoding="utf-8"), encoding="utf-8")
    r = run("build", str(copy), "--json")
    assert r.exit_code == 0, r.output
    assert '"states": 8' in r.output


@pytest.mark.parametrize("breaker", ["\x0c", "\x85", "\u2028", "\x1c"])
def test_error_shows_the_right_line_after_a_form_feed(tmp_path: Path, breaker: str) -> None:
    # str.splitlines counts these as line breaks; PRISM (and posgmc) count "\n" only
    model = tmp_path / "ff.prism"
    model.write_text(
        f"dtmc // page{breaker}break\nmodule m x : [0..1] init 0;\n"
        "  [] x=0 -> (yy'=1);\nendmodule\n"
    )
    r = run("lint", str(model))
    assert r.exit_code == 2
    lines = r.output.splitlines()
    at = next(i for i, line in enumerate(lines) if ":3:" in line)
    assert "(yy'=1)" in lines[at + 1]


def _test_game() -> str:
    return str(BENCHMARKS / "posmg" / "test-game" / "sketch.templ")


def test_drn_input_obeys_the_state_limit() -> None:
    r = run("build", _test_game(), "--state-limit", "5")
    assert r.exit_code == 2 and "the model has 8 states, more than the state limit 5" in r.output


def test_drn_input_refuses_constants() -> None:
    r = run("build", _test_game(), "--const", "N=3")
    assert r.exit_code == 2 and "it has no constants to set (N given)" in r.output


def test_json_mode_reports_input_errors_as_json() -> None:
    import json

    r = CliRunner().invoke(
        main, ["check", ROVER, "--prop", '<<rover>> Pmax=? [ F "goal" ', "--json"]
    )
    assert r.exit_code == 2
    doc = json.loads(r.stdout)
    (error,) = doc["errors"]
    assert (error["file"], error["line"]) == ("<--prop 1>", 1) and error["column"] >= 1
    assert error["message"]


def test_unknown_constant_is_reported_once_before_building(tmp_path: Path) -> None:
    model = tmp_path / "c.prism"
    model.write_text("dtmc\nconst int N;\nconst double p;\nmodule m x : [0..N] init 0;\n"
                     "  [] x<N -> p:(x'=x+1) + 1-p:(x'=x);\n  [] x=N -> true;\nendmodule\n")
    r = run("check", str(model), "--const", "N=3,p=0.5,Q=1", "--prop", "P=? [ F x=3 ]",
            "--prop", "P=? [ F x=2 ]")
    assert r.exit_code == 2
    assert r.output.count('"Q" is not a constant of the model or the properties') == 1
    assert "--const:1:11: error" in r.output and "  N=3,p=0.5,Q=1\n" in r.output
    assert "Model " not in r.output  # nothing was built


def test_zero_player_number_on_drn_names_the_option() -> None:
    r = run("check", _test_game(), "--prop", '<<0>> Pmax=? [F "goal"]', "--full-observation")
    assert r.exit_code == 2
    # the semantic stage's message (one resolution of coalitions for PRISM and DRN input)
    assert ("player number 0 does not exist: PRISM-games numbers players from 1, while Storm and "
            "PAYNT number them from 0") in r.output
    assert '"0" = <<1>> (<<0>> with --zero-based-players)' in r.output
    ok = run("check", _test_game(), "--prop", '<<0>> Pmax=? [F "goal"]', "--full-observation",
             "--zero-based-players")
    assert ok.exit_code == 0, ok.output


def test_conjunction_of_13_eventualities_takes_seconds(tmp_path: Path) -> None:
    # the automaton is built over the ring's own letters (over every letter it is exponential)
    import time

    n = 13
    model = tmp_path / "ring.prism"
    model.write_text(
        f"dtmc\nmodule ring\n  s : [0..{n - 1}] init 0;\n"
        f"  [] true -> 0.5:(s'=mod(s+1,{n})) + 0.5:(s'=s);\nendmodule\n"
        + "".join(f'label "a{i}" = s={i};\n' for i in range(n))
    )
    prop = "P=? [ " + " & ".join(f'(F "a{i}")' for i in range(n)) + " ]"
    start = time.perf_counter()
    r = run("check", str(model), "--prop", prop, "--json")
    assert r.exit_code == 0, r.output
    assert time.perf_counter() - start < 20  # seconds even on a shared machine (was 110 s)
    # every state of the ring is visited almost surely: probability 1 (hand derivation)
    assert '"value": 1' in r.output.replace("1.0", "1")


def test_each_result_is_printed_before_the_next_property_runs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # each result is printed as soon as it is known: the first line is out before the second
    # property starts (here the second is interrupted: exit 130)
    real = api._check_one
    calls = []

    def second_interrupted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(api, "_check_one", second_interrupted)
    for extra in ([], ["--json-lines"]):
        calls.clear()
        r = run("check", ROVER, "--prop", REACH, "--prop", REACH, *extra)
        assert r.exit_code == 130
        assert r.output.count("Pmax=?") == 1 and "0.98765" in r.output, r.output
        assert "interrupted" in r.output


def test_json_lines_prints_one_object_per_line() -> None:
    import json

    r = run(
        "check", ROVER, "--prop", REACH, "--prop", '<<rover>> Pmin=? [ F "goal" ]', "--json-lines"
    )
    assert r.exit_code == 0, r.output
    lines = [json.loads(line) for line in r.output.splitlines()]
    assert lines[0]["model"]["states"] > 0 and [x["property"] for x in lines[1:]] == [
        REACH,
        '<<rover>> Pmin=? [ F "goal" ]',
    ]


def test_hitting_the_iteration_cap_says_so_and_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    # one iteration cannot converge on rover's reachability; the line says so and exit is 1
    from posgmc.engines import options as engine_options

    original = engine_options.SolverOptions.__init__

    def capped(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        kwargs["max_iterations"] = 1
        original(self, *args, **kwargs)

    monkeypatch.setattr(engine_options.SolverOptions, "__init__", capped)
    r = run("check", ROVER, "--prop", REACH)
    assert "NOT CONVERGED: the bounds hold but are wider" in r.output, r.output
    # the value is its interval alone: no point inside it stands for a number nothing computed
    line = next(x for x in r.output.splitlines() if "NOT CONVERGED" in x)
    assert re.search(r": \[[0-9.e-]+, [0-9.e-]+\]  \(interval", line), line
    assert r.exit_code == 1


@pytest.mark.parametrize(
    "content, where",
    [
        (
            b"mdp\nmodule m\n  x : [0..1] init 0; // caf\xe9\n  [] true -> true;\nendmodule\n",
            ":3:28:",
        ),
        (b"mdp\n\xff\xfe", ":2:1:"),
    ],
)
def test_a_file_that_is_not_utf8_gets_line_and_column(
    tmp_path: Path, content: bytes, where: str
) -> None:
    # the byte that is not UTF-8 is given as a line and column
    model = tmp_path / "m.prism"
    model.write_bytes(content)
    for verb in ("lint", "build"):
        r = run(verb, str(model))
        assert r.exit_code == 2 and f"m.prism{where} error: the file is not UTF-8 text" in r.output


def test_export_strategy_with_an_unknown_label_reports_the_label(tmp_path: Path) -> None:
    # the unknown label is the error reported, not the export's own requirement
    r = run("check", ROVER, "--prop", '<<rover>> Pmax=? [ F "nolabel" ]',
            "--export-strategy", str(tmp_path / "s.json"))
    assert r.exit_code == 2 and 'unknown label "nolabel"' in r.output
    assert "needs exactly one" not in r.output and not (tmp_path / "s.json").exists()


# -- strategies, synthesis and resources (absurd numbers, large memories, deadlines) ----------

ROVER_POSG = str(ROOT / "models" / "rover.posg")
FORWARD = ROOT / "models" / "rover" / "forward.fss.json"


@pytest.mark.parametrize(
    "old, new, where, words",
    [
        ('"fwd": 1.0}}', '"fwd": 1' + "0" * 5000 + "}}", "rules[1].action.fwd",
         "a probability must be a number in [0, 1], got 10000000000"),
        ('{"x": 1}', '{"x": 1000000000000000000000000000000}', "rules[1].observation.x",
         "the value of 'x' 1000000000000000000000000000000 is beyond 64-bit integers"),
        ('"memory_size": 1', '"memory_size": 1000000000000000000000000000000', "memory_size",
         "memory_size 1000000000000000000000000000000 is beyond 64-bit integers"),
    ],
)
def test_strategy_files_with_absurd_numbers(tmp_path: Path, old: str, new: str, where: str,
                                            words: str) -> None:
    f = tmp_path / "s.json"
    f.write_text(FORWARD.read_text().replace(old, new, 1))
    r = run("show-strategy", str(f))
    assert r.exit_code == 2 and "internal error" not in r.output
    assert f"error: {f}: {where}: {words}" in r.output


def test_show_strategy_of_twenty_thousand_nodes(tmp_path: Path) -> None:
    """A 20,000-node strategy (140,000 rules, 14 MB) is shown from its rules (the dense update
    array would be 44.8 GB); its memory_size can be 10^6 without cost."""
    k = 20_000
    rules = [{"memory": n, "observation": {"x": x},
              "action": {("done" if x in (0, 6) else "fwd"): 1.0},
              "update": {("done" if x in (0, 6) else "fwd"): {str((n + 1) % k): 1.0}}}
             for n in range(k) for x in range(7)]
    doc = {"format": "posgmc-fss/1", "player": "rover", "memory_size": k, "initial_memory": 0,
           "observables": ["x"], "rules": rules}
    f = tmp_path / "big.json"
    f.write_text(json.dumps(doc))
    r = run("show-strategy", str(f))
    assert r.exit_code == 0
    lines = r.output.splitlines()
    assert lines[0] == "strategy of player 'rover': 20000 memory nodes, 7 observations, " \
        "140000 rules, initial node 0, deterministic"
    assert len(lines) == 2 + 7 * k and lines[-1].split() == ["19999", "{x=6}", "done:", "1",
                                                              "done", "->", "0"]
    doc["memory_size"], doc["rules"] = 1_000_000, rules[:7]
    f.write_text(json.dumps(doc))
    assert run("show-strategy", str(f), "--model", ROVER_POSG).exit_code == 0


def test_a_coalition_player_that_never_moves(tmp_path: Path) -> None:
    model = tmp_path / "idle.posg"
    model.write_text("posg\nplayer a\n  [go]\n  observables x endobservables\nendplayer\n"
                     "player b\n  [hit]\nendplayer\nmodule m\n  x : [0..2] init 0;\n"
                     "  [go] x<2 -> 0.5:(x'=x+1) + 0.5:(x'=0);\n  [hit] false -> true;\n"
                     "endmodule\nlabel \"goal\" = x=2;\n")
    r = run("check", str(model), "--prop", '<<b>> Pmax=? [ F "goal" ]')
    assert r.exit_code == 2 and "IndexError" not in r.output
    assert "<--prop 1>:1:1: error: player 'b' never has a move: none of its actions is enabled " \
        "in any state, so there is no strategy to synthesise" in r.output


def test_jobs_beyond_the_processors_are_capped_and_said(monkeypatch: pytest.MonkeyPatch) -> None:
    from posgmc import resources

    monkeypatch.setattr(resources, "usable_cpus", lambda: 1)
    r = run("check", ROVER_POSG, "--prop", REACH, "--jobs", "1000", "--memory", "1",
            "--adversaries", "0", "--timeout", "2")
    assert "warning: --jobs 1000 capped at 1: the processors available to posgmc" in r.output
    assert r.exit_code in (0, 1) and "internal error" not in r.output


def test_a_state_space_that_cannot_fit_stops_exploring(monkeypatch: pytest.MonkeyPatch) -> None:
    """The memory still available (measured: MemAvailable and RLIMIT_AS) must cover what the
    build took once more; here it is made to look exhausted."""
    import importlib

    explore_module = importlib.import_module("posgmc.compiler.explore")
    monkeypatch.setattr(explore_module, "available_bytes", lambda: 0)
    r = run("build", ROVER)
    assert r.exit_code == 2
    assert "error: the state space does not fit in memory: exploring stopped at" in r.output
    assert "hint: choose smaller constants, or give --state-limit (e.g. --state-limit" in r.output
    # a limit the user gives replaces the guard
    assert run("build", ROVER, "--state-limit", "100000").exit_code == 0


def test_a_given_timeout_bounds_the_model_build(tmp_path: Path) -> None:
    model = tmp_path / "long.posg"
    model.write_text("posg\nplayer p\n  [a]\n  observables t endobservables\nendplayer\n"
                     "player q\n  [b]\nendplayer\nmodule m\n  x : [0..1000000000] init 0;\n"
                     "  t : [0..1] init 0;\n  [a] t=0 & x<1000000000 -> (x'=x+1)&(t'=1);\n"
                     "  [b] t=1 -> (t'=0);\nendmodule\nlabel \"goal\" = x=1000000000;\n")
    r = run("check", str(model), "--prop", '<<p>> Pmax=? [ F "goal" ]', "--timeout", "0.5")
    assert r.exit_code == 2
    assert "error: the time budget ran out while building the model:" in r.output
