"""Option values out of range are refused before any work, naming the option, with exit 2
(posgmc/cli/options.py and the commands' own options). Each case failed before: an internal
error (ValueError, OverflowError, MemoryError) after the work, or a silent default."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]
POSG = str(ROOT / "models" / "rover.posg")
FORWARD = str(ROOT / "models" / "rover" / "forward.fss.json")
REACH = '<<rover>> Pmax=? [ !"crash" U "goal" ]'
COST = '<<rover>> R{"steps"}min=? [ F "over" ]'
CHECK = ("check", POSG, "--prop", REACH)
SIMULATE = ("simulate", POSG, "--prop", REACH, "--strategy", f"rover={FORWARD}")


def run(*args: str):  # type: ignore[no-untyped-def]
    return CliRunner().invoke(main, list(args))


@pytest.fixture
def test_files(tmp_path: Path) -> tuple[str, str]:
    model = tmp_path / "coin.prism"
    model.write_text("dtmc\nmodule m\n x : [0..1] init 0;\n [] x=0 -> 0.5:(x'=1) + 0.5:(x'=0);\n"
                     " [] x=1 -> true;\nendmodule\nlabel \"one\" = x=1;\n")
    props = tmp_path / "coin.props"
    props.write_text('// RESULT: 1\nP=? [ F "one" ]\n')
    return str(model), str(props)


@pytest.mark.parametrize(("args", "words"), [
    # ValueError: expected non-negative integer (numpy's seed), after building the model
    ((*CHECK, "--seed", "-1"), "Invalid value for '--seed': -1 is not in the range x>=0"),
    ((*SIMULATE, "--seed", "-1"), "Invalid value for '--seed': -1 is not in the range x>=0"),
    # OverflowError: Python int too large to convert to C long
    ((*CHECK, "--memory", "99999999999999999999"),
     "Invalid value for '--memory': '99999999999999999999': memory sizes go up to 10000"),
    # a range of 10**20 sizes, listed before anything else
    ((*CHECK, "--memory", "rover=1..99999999999999999999"),
     "Invalid value for '--memory': 'rover=1..99999999999999999999': memory sizes go up to"),
    ((*CHECK, "--memory", "3..1"), "Invalid value for '--memory': '3..1': a range K1..K2 goes up"),
    ((*CHECK, "--memory", "0..2"), "Invalid value for '--memory': '0..2': memory sizes start at 1"),
    # nan: no deadline at all
    ((*CHECK, "--timeout", "nan"), "Invalid value for --timeout: nan is not a positive finite"),
    ((*CHECK, "--timeout", "inf"), "Invalid value for --timeout: inf is not a positive finite"),
    (("pareto", POSG, "--prop", REACH, "--cost", COST, "--budget", "nan"),
     "Invalid value for --budget: nan is not a finite number"),
    (("pareto", POSG, "--prop", REACH, "--cost", COST, "--weights", "1,nan"),
     "--weights:1:3: error: --weights: 'nan' is not a number"),
    # the defaults were used silently
    (("pareto", POSG, "--prop", REACH, "--cost", COST, "--weights", ""),
     "--weights:1:1: error: --weights: '' is not a number"),
    # wrote BUDGET=0/ into the working directory
    (("pareto", POSG, "--prop", REACH, "--sweep", "N=1:2", "--strategies", ""),
     "error: --strategies: an empty path"),
])
def test_out_of_range_values_are_refused_by_name(args: tuple[str, ...], words: str) -> None:
    r = run(*args)
    assert r.exit_code == 2, r.output
    assert words in r.output and "internal error" not in r.output
    assert "Model " not in r.output  # refused before the model was built


@pytest.mark.parametrize(("value", "words"), [
    ("nan", "Invalid value for --tolerance: nan is not a finite number"),
    ("-1", "Invalid value for --tolerance: -1.0 is negative"),
])
def test_test_tolerance_must_be_finite_and_not_negative(
        test_files: tuple[str, str], value: str, words: str) -> None:
    r = run("test", *test_files, "--tolerance", value)
    assert r.exit_code == 2 and words in r.output and "PASS" not in r.output


def test_a_result_beyond_a_double_is_a_positioned_error(test_files: tuple[str, str]) -> None:
    """``// RESULT: 1e999`` was an internal OverflowError; PRISM reads it as Infinity, so the
    message says to write that."""
    model, props = test_files
    Path(props).write_text('// RESULT: 1e999\nP=? [ F "one" ]\n')
    r = run("test", model, props)
    assert r.exit_code == 2
    assert f"{props}:1:4: error: RESULT value '1e999' is beyond the range of a double" in r.output
    assert "write Infinity for an infinite value" in r.output
