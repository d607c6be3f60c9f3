"""``posgmc lint --each`` (the pre-commit hook, .pre-commit-hooks.yaml): every argument a model,
the .props file beside it checked with it, .props arguments skipped."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]
GOOD = "dtmc\nmodule m x : [0..1] init 0; [] x=0 -> (x'=1); endmodule\nlabel \"one\" = x=1;\n"


def test_each_argument_is_a_model_with_its_props(tmp_path: Path) -> None:
    (tmp_path / "a.prism").write_text(GOOD)
    (tmp_path / "a.props").write_text('P=? [ F "one" ]\n')
    (tmp_path / "b.prism").write_text(GOOD)
    r = CliRunner().invoke(
        main,
        [
            "lint",
            "--each",
            str(tmp_path / "a.prism"),
            str(tmp_path / "b.prism"),
            str(tmp_path / "a.props"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert r.output.splitlines() == [f"{tmp_path / 'a.prism'}: ok", f"{tmp_path / 'b.prism'}: ok"]


def test_a_bad_props_file_beside_a_model_fails_the_hook(tmp_path: Path) -> None:
    (tmp_path / "a.prism").write_text(GOOD)
    (tmp_path / "a.props").write_text('P=? [ F "two" ]\n')
    r = CliRunner().invoke(main, ["lint", "--each", str(tmp_path / "a.prism")])
    assert r.exit_code == 2
    assert "a.props:1:" in r.output and '"two"' in r.output


def test_the_hooks_file_names_the_commands() -> None:
    # read without a YAML library (not a dependency): each hook is "- id: ..." then its keys
    text = (ROOT / ".pre-commit-hooks.yaml").read_text()
    hooks = {}
    for chunk in text.split("- id: ")[1:]:
        lines = chunk.splitlines()
        keys = dict(line.strip().split(": ", 1) for line in lines[1:] if ": " in line)
        hooks[lines[0].strip()] = keys
    assert hooks["posgmc-lint"]["entry"] == "posgmc lint --each"
    assert hooks["posgmc-test"]["entry"] == "posgmc test"
