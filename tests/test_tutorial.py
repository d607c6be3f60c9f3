"""docs/tutorial.md stays true: every ``$ posgmc ...`` command in a ``console`` block is run (from
a scratch directory that sees the repository's ``models/``), and its output must equal the one
shown, line by line, once times (``0.013 s``) are masked (synthesis is counted in its own units,
not timed, so its numbers are the same on any machine)."""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "tutorial.md"
_BLOCK = re.compile(r"```console\n(.*?)```", re.S)
_TIME = re.compile(r"\d+\.\d+ s\b")


def _commands() -> list[tuple[str, list[str]]]:
    out = []
    for block in _BLOCK.findall(TUTORIAL.read_text()):
        lines = block.rstrip("\n").split("\n")
        assert lines[0].startswith("$ posgmc "), lines[0]
        out.append((lines[0][2:], lines[1:]))
    return out


def _mask(lines: list[str]) -> list[str]:
    return [_TIME.sub("<t> s", line.rstrip()) for line in lines]


def test_the_tutorial_has_its_commands() -> None:
    names = [shlex.split(c)[1] for c, _ in _commands()]
    assert names == ["lint", "build", "check", "check", "show-strategy", "simulate", "test"]


def test_every_tutorial_command_prints_what_the_tutorial_shows(tmp_path: Path) -> None:
    os.symlink(ROOT / "models", tmp_path / "models")
    cwd = Path.cwd()
    os.chdir(tmp_path)
    try:
        for command, expected in _commands():  # in order: later commands read earlier files
            result = CliRunner().invoke(main, shlex.split(command)[1:])
            assert result.exit_code == 0, (command, result.output)
            assert _mask(result.output.rstrip("\n").split("\n")) == _mask(expected), command
    finally:
        os.chdir(cwd)


@pytest.mark.parametrize("path", [ROOT / "models" / "beacon" / "beacon.posg"])
def test_the_shown_player_blocks_are_the_models(path: Path) -> None:
    text = path.read_text()
    block = TUTORIAL.read_text().split("```\nplayer rover", 1)[1].split("```", 1)[0]
    for line in ("player rover" + block).strip().splitlines():
        assert line in text, line
