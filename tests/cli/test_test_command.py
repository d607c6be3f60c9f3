"""`posgmc test`: PRISM's RESULT convention for CI, and its JUnit report."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main
from tests.cli.helpers import CHAIN as MODEL

ROOT = Path(__file__).resolve().parents[2]


PROPS = """// RESULT: 1
P=? [ F x=2 ];
// RESULT (p=0.5): 0.5
// RESULT (p=1/2): 0.5
P=? [ F (x=1 & (X x=2)) ];
// RESULT: [1.0,2.0]
R{"steps"}=? [ F x=2 ];
// RESULT: true
P>=1 [ F x=2 ];
// RESULT: Infinity
R{"steps"}=? [ F x=3 ];
// RESULT: Error:unknown
R{"nope"}=? [ F x=2 ];
// RESULT: ?
P=? [ X x=1 ];
P=? [ X x=2 ];
"""


def _files(tmp_path: Path, props: str = PROPS) -> tuple[str, str]:
    m, p = tmp_path / "m.prism", tmp_path / "m.props"
    m.write_text(MODEL)
    p.write_text(props)
    return str(m), str(p)


def test_every_result_form(tmp_path: Path) -> None:
    m, p = _files(tmp_path)
    junit = tmp_path / "report.xml"
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5", "--junit", str(junit)])
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == "6 passed, 0 failed, 2 skipped"
    xml = junit.read_text()
    assert 'tests="8"' in xml and 'failures="0"' in xml and 'skipped="2"' in xml


def test_a_failing_result_names_file_and_line(tmp_path: Path) -> None:
    m, p = _files(tmp_path, "// RESULT: 0.3\nP=? [ F x=1 ];\n")
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
    assert r.exit_code == 1
    assert f"FAIL {p}:2: P=? [ F x=1 ]: expected 0.3, got 0.5" in r.output
    assert "0 passed, 1 failed" in r.output


def test_constant_specific_results_over_a_sweep(tmp_path: Path) -> None:
    m, p = _files(
        tmp_path, "// RESULT (p=0.5): 0.5\n// RESULT (p=1): 1\nP=? [ F (x=1 & (X x=2)) ];\n"
    )
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5:0.5:1"])
    assert r.exit_code == 0, r.output
    assert "2 passed, 0 failed" in r.output


def test_a_malformed_result_line_is_an_input_error(tmp_path: Path) -> None:
    m, p = _files(tmp_path, "// RESULT (p): 0.3\nP=? [ F x=1 ];\n")
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
    assert r.exit_code == 2 and f"{p}:1:4: error: badly formed RESULT specification" in r.output
    m, p = _files(tmp_path, "// RESULT: zero\nP=? [ F x=1 ];\n")
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
    assert r.exit_code == 2 and "RESULT value 'zero' is not a number" in r.output


def test_named_number_of_a_strategy_result(tmp_path: Path) -> None:
    props = tmp_path / "rover.props"
    props.write_text(
        '// RESULT (guaranteed): 0.9215685684\n<<rover>> Pmax=? [ !"crash" U "goal" ];\n'
        '// RESULT (upper_bound): 0.5\n<<rover>> Pmax=? [ F "goal" ];\n'
    )
    r = CliRunner().invoke(
        main,
        [
            "test",
            str(ROOT / "models" / "rover.posg"),
            str(props),
            "--strategy",
            f"rover={ROOT / 'models' / 'rover' / 'forward.fss.json'}",
        ],
    )
    assert r.exit_code == 1, r.output
    assert "PASS" in r.output and "(guaranteed)" in r.output
    assert "expected 0.5 (upper_bound), got the result has no upper_bound number" in r.output


def test_bundled_models_pass_their_results() -> None:
    r = CliRunner().invoke(
        main, ["test", str(ROOT / "models" / "rover.smg"), str(ROOT / "models" / "rover.props")]
    )
    assert r.exit_code == 0 and "5 passed, 0 failed" in r.output


def test_check_writes_a_junit_report(tmp_path: Path) -> None:
    report = tmp_path / "check.xml"
    r = CliRunner().invoke(
        main,
        [
            "check",
            str(ROOT / "models" / "rover.smg"),
            "--prop",
            '<<rover>> P>=0.99 [ F "goal" ]',
            "--prop",
            '<<rover>> Pmax=? [ F "goal" ]',
            "--prop",
            'R{"nope"}max=? [ F "goal" ]',
            "--junit",
            str(report),
        ],
    )
    assert r.exit_code == 2  # the third property is an error
    xml = report.read_text()
    assert 'tests="3"' in xml and 'failures="1"' in xml and 'errors="1"' in xml


def test_an_interval_may_have_spaces_inside(tmp_path: Path) -> None:
    """``// RESULT: [1.0, 2.0]`` as people write it (PRISM's own files write ``[1.0,2.0]``); the
    expected steps are 1.5 at p=0.5, so the first passes and the second fails."""
    m, p = _files(tmp_path, '// RESULT: [ 1.0 , 2.0 ]\nR{"steps"}=? [ F x=2 ];\n'
                            '// RESULT: [1.6, 2.0]\nR{"steps"}=? [ F x=2 ];\n')
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
    assert r.output.strip().splitlines()[-1] == "1 passed, 1 failed", r.output
    assert "expected [1.6,2.0]" in r.output


def test_false_plain_error_and_a_fraction(tmp_path: Path) -> None:
    """``false``, a bare ``Error`` (any error passes) and ``1/2``, each passing and each failing
    when the outcome differs (p=0.5: P(F x=1) = 1/2, so P<0.4 is false)."""
    m, p = _files(
        tmp_path,
        '// RESULT: false\nP<0.4 [ F x=1 ];\n// RESULT: Error\nR{"nope"}=? [ F x=2 ];\n'
        "// RESULT: 1/2\nP=? [ F x=1 ];\n// RESULT: false\nP>=0.4 [ F x=1 ];\n"
        "// RESULT: Error\nP=? [ F x=1 ];\n// RESULT: 1/3\nP=? [ F x=1 ];\n",
    )
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
    assert r.exit_code == 1
    lines = r.output.strip().splitlines()
    assert lines[-1] == "3 passed, 3 failed", r.output
    assert f"FAIL {p}:8: P>=0.4 [ F x=1 ]: expected false, got true" in lines
    assert f"FAIL {p}:10: P=? [ F x=1 ]: expected Error, got 0.5" in lines
    assert f"FAIL {p}:12: P=? [ F x=1 ]: expected 1/3, got 0.5" in lines


def test_a_missing_result_is_skipped_not_passed(tmp_path: Path) -> None:
    """A property without a RESULT line is reported as skipped (JUnit: "no RESULT line"), and a
    file with no RESULT line at all passes nothing."""
    m, p = _files(tmp_path, "P=? [ F x=1 ];\nP=? [ F x=2 ];\n")
    junit = tmp_path / "r.xml"
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5", "--junit", str(junit)])
    assert r.exit_code == 0
    assert r.output.strip().splitlines()[-1] == "0 passed, 0 failed, 2 skipped"
    assert junit.read_text().count("no RESULT line") == 2


@pytest.mark.parametrize(("line", "message"), [
    ("[1,2,3]", "RESULT interval '[1,2,3]' is not [lo, hi] with two numbers"),
    ("[a, 2]", "RESULT interval '[a,2]' is not [lo, hi] with two numbers"),
    ("[2, 1]", "RESULT interval '[2,1]' is empty"),
    ("zero", "RESULT value 'zero' is not a number"),
])
def test_malformed_values_are_input_errors_even_when_the_property_fails(tmp_path: Path, line: str,
                                                                       message: str) -> None:
    """Checked before the outcome is looked at: the second property is itself an error."""
    for prop in ("P=? [ F x=1 ]", 'R{"nope"}=? [ F x=2 ]'):
        m, p = _files(tmp_path, f"// RESULT: {line}\n{prop};\n")
        r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5"])
        assert r.exit_code == 2, r.output
        assert f"{p}:1:4: error: {message}" in r.output


def test_a_malformed_line_stops_the_run_before_any_check(tmp_path: Path) -> None:
    """Nothing half-reported: a bad RESULT line further down is found before the first property is
    checked, so no PASS line and no JUnit file appear."""
    m, p = _files(tmp_path, "// RESULT: 1\nP=? [ F x=2 ];\n// RESULT: [1, 2, 3]\nP=? [ F x=1 ];\n")
    junit = tmp_path / "r.xml"
    r = CliRunner().invoke(main, ["test", m, p, "--const", "p=0.5", "--junit", str(junit)])
    assert r.exit_code == 2
    assert "PASS" not in r.output and f"{p}:3:4: error: RESULT interval" in r.output
    assert not junit.exists()


# -- PRISM's test mode over files and folders, with argument files ------------------------------


def _suite(tmp_path: Path) -> Path:
    """A folder holding one model (MODEL, by hand: P(F (x=1 & X x=2)) = p) with two properties
    files and their argument files: PRISM's switches, an ignored engine switch, one run per
    line."""
    folder = tmp_path / "suite"
    folder.mkdir()
    (folder / "m.prism").write_text(MODEL)
    (folder / "m.props").write_text("// RESULT: 1\nP=? [ F x=2 ];\n")
    (folder / "m.props.args").write_text("// one run\n-const p=0.5 -ex -epsilon 1e-8\n")
    (folder / "extra.props").write_text(
        "// RESULT (p=0.25): 0.25\n// RESULT (p=0.5): 0.5\nP=? [ F (x=1 & X x=2) ];\n"
    )
    (folder / "extra.props.args").write_text("-const p=0.25\n--const p=0.5\n")
    return folder


def test_a_folder_runs_every_model_with_its_argument_files(tmp_path: Path) -> None:
    folder = _suite(tmp_path)
    junit = tmp_path / "all.xml"
    r = CliRunner().invoke(main, ["test", str(folder), "--junit", str(junit)])
    assert r.exit_code == 0, r.output
    lines = r.output.strip().splitlines()
    # extra.props (name order) once per line of its argument file, then m.props
    heads = [ln for ln in lines if ln.startswith("== ")]
    assert [h.split("  (")[0].split(" ", 2)[2] for h in heads] == [
        "extra.props --const p=0.25",
        "extra.props --const p=0.5",
        "m.props --const p=0.5",
    ]
    assert heads[0].endswith(f"({folder / 'extra.props.args'}:1)")
    assert lines[-1] == "3 passed, 0 failed"
    assert 'tests="3"' in junit.read_text() and 'failures="0"' in junit.read_text()


def test_a_model_file_finds_its_properties(tmp_path: Path) -> None:
    folder = _suite(tmp_path)
    (folder / "m.props.args").write_text("-const p=0.5\n")
    (folder / "extra.props.args").unlink()
    r = CliRunner().invoke(main, ["test", str(folder / "m.prism"), "--const", "p=0.25"])
    # the command line's p=0.25 for extra.props (its RESULT for p=0.25 passes); m.props'
    # argument line sets p=0.5 in place of it (P(F x=2) = 1 whatever p)
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == "2 passed, 0 failed"


def test_a_failing_run_fails_the_total(tmp_path: Path) -> None:
    folder = _suite(tmp_path)
    (folder / "extra.props.args").write_text("-const p=0.25\n-const p=0.75\n")
    r = CliRunner().invoke(main, ["test", str(folder)])
    # p=0.75 has no RESULT line of its own: skipped, not failed; make one fail instead
    assert r.exit_code == 0, r.output
    (folder / "extra.props").write_text("// RESULT: 0.5\nP=? [ F (x=1 & X x=2) ];\n")
    r = CliRunner().invoke(main, ["test", str(folder)])
    assert r.exit_code == 1
    assert r.output.strip().splitlines()[-1] == "1 passed, 2 failed"
    assert "FAIL " in r.output and "expected 0.5, got 0.25" in r.output


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("-sparse -bogus\n", "unknown switch -bogus in an argument file"),
        ("-const\n", "-const needs a value"),
        ("--no-such-option\n", "No such option '--no-such-option'"),
    ],
)
def test_a_bad_argument_line_names_its_file_and_line(
    tmp_path: Path, line: str, message: str
) -> None:
    folder = _suite(tmp_path)
    (folder / "m.props.args").write_text("// comment\n" + line)
    r = CliRunner().invoke(main, ["test", str(folder / "m.prism")])
    assert r.exit_code == 2
    assert message in r.output
    assert f"{folder / 'm.props.args'}:2" in r.output


def test_the_shipped_smg_models_pass_in_folder_mode() -> None:
    # the cheap folders (no synthesis): their argument files hold the runs tests/
    # test_model_library.py lists: tennis twice (receiver first or not), red_and_black swept
    r = CliRunner().invoke(main, ["test", str(ROOT / "models" / "tennis"),
                                  str(ROOT / "models" / "red_and_black")])
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == "19 passed, 0 failed, 6 skipped"


def test_exact_mode_reads_decimal_results_as_roundings() -> None:
    # red_and_black at start=3: "casino" is exactly 608/6305 = 0.09643140364..., written
    # 0.0964314037 in its RESULT line; "bold" is 32/125 = 0.256 exactly
    where = ROOT / "models" / "red_and_black"
    r = CliRunner().invoke(main, ["test", str(where / "red_and_black.smg"),
                                  str(where / "red_and_black.props"), "--const", "start=3",
                                  "--exact"])
    assert r.exit_code == 0, r.output
    assert r.output.strip().splitlines()[-1] == "3 passed, 0 failed"
