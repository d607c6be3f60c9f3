"""The command line: options, output formats and exit codes (docs/cli.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import __version__
from posgmc.cli import EXIT_ERROR, EXIT_OK, EXIT_PROPERTY_FALSE, main

ROOT = Path(__file__).resolve().parents[2]
ROVER = str(ROOT / "models" / "rover.smg")
ROVER_POSG = str(ROOT / "models" / "rover.posg")


@pytest.fixture
def run():  # type: ignore[no-untyped-def]
    runner = CliRunner()

    def invoke(*args: str):  # type: ignore[no-untyped-def]
        return runner.invoke(main, list(args), catch_exceptions=False)

    return invoke


def test_version_and_help(run) -> None:  # type: ignore[no-untyped-def]
    r = run("--version")
    assert r.exit_code == 0 and __version__ in r.output
    r = run("--help")
    assert r.exit_code == 0
    for verb in ("lint", "build", "check"):
        assert verb in r.output


def test_every_option_of_every_command_has_help_text() -> None:
    import click

    def options(command: click.Command, name: str) -> list[tuple[str, click.Option]]:
        if isinstance(command, click.Group):
            return [o for n, c in command.commands.items() for o in options(c, f"{name} {n}")]
        return [(name, p) for p in command.params if isinstance(p, click.Option)]

    missing = [(name, o.opts) for name, o in options(main, "posgmc") if not o.help]
    assert missing == []


def test_lint_clean(run) -> None:  # type: ignore[no-untyped-def]
    r = run("lint", ROVER_POSG, str(ROOT / "models" / "rover.props"))
    assert r.exit_code == EXIT_OK, r.output
    assert "ok" in r.output


def test_lint_reports_every_error_with_position(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.prism"
    bad.write_text(
        "mdp\n"
        "module m\n"
        "  x : [0..3] init 0;\n"
        "  [] x=0 -> (y'=1);\n"  # y undefined
        "  [] x=1 -> (x'=true);\n"  # bool assigned to int
        "endmodule\n"
    )
    r = run("lint", str(bad))
    assert r.exit_code == EXIT_ERROR
    assert f"{bad}:4:13:" in r.output  # the assignment (y'=1)
    assert f"{bad}:5:" in r.output
    assert "^" in r.output  # caret under the offending text
    assert "Traceback" not in r.output


def test_lint_syntax_error_position(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.prism"
    bad.write_text("mdp\nmodule m\n  x : [0..3] init 0;\n  [] x=0 -> (x'=1)\nendmodule\n")
    r = run("lint", str(bad))
    assert r.exit_code == EXIT_ERROR
    assert f"{bad}:5:1: error:" in r.output, r.output


def test_lint_undefined_constants_are_not_errors(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    m = tmp_path / "c.prism"
    m.write_text(
        "mdp\nconst int N;\nmodule m\n  x : [0..N] init 0;\n  [] x<N -> (x'=x+1);\nendmodule\n"
    )
    assert run("lint", str(m)).exit_code == EXIT_OK
    assert run("lint", str(m), "--const", "N=3").exit_code == EXIT_OK
    r = run("lint", str(m), "--const", "N=0.5")
    assert r.exit_code == EXIT_ERROR


def test_missing_file(run) -> None:  # type: ignore[no-untyped-def]
    r = run("build", "no/such/model.prism")
    assert r.exit_code == EXIT_ERROR
    assert "no such file" in r.output


def test_build_json_keys(run) -> None:  # type: ignore[no-untyped-def]
    r = run("build", ROVER, "--json")
    assert r.exit_code == EXIT_OK, r.output
    stats = json.loads(r.stdout)
    for key in ("type", "states", "choices", "transitions", "build_seconds"):
        assert key in stats
    assert stats["type"] == "smg"
    assert isinstance(stats["states"], int) and stats["states"] > 0
    assert set(stats["players"]) == {"rover", "attacker"}


def test_build_posg_reports_observations(run) -> None:  # type: ignore[no-untyped-def]
    stats = json.loads(run("build", ROVER_POSG, "--json").stdout)
    assert stats["type"] == "posg"
    # the rover observes x in 0..6: 7 observations, all reachable
    assert stats["observations"] == {"rover": 7}


def test_build_export_drn_round_trip(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "rover.drn"
    r = run("build", ROVER, "--export", "drn", str(out))
    assert r.exit_code == EXIT_OK, r.output
    a = json.loads(run("build", ROVER, "--json").stdout)
    b = json.loads(run("build", str(out), "--json").stdout)
    assert (a["states"], a["choices"], a["transitions"]) == (
        b["states"],
        b["choices"],
        b["transitions"],
    )


def test_const_errors_point_into_the_option(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    m = tmp_path / "c.prism"
    m.write_text(
        "mdp\nconst int N;\nmodule m\n  x : [0..N] init 0;\n  [] x<N -> (x'=x+1);\nendmodule\n"
    )
    r = run("build", str(m), "--const", "N=3,M")
    assert r.exit_code == EXIT_ERROR
    assert "--const:1:5" in r.output


def test_exit_codes_constants() -> None:
    assert (EXIT_OK, EXIT_PROPERTY_FALSE, EXIT_ERROR) == (0, 1, 2)
