"""A solver library's own prints kept off standard output (posgmc/synthesis/solver_output.py):
scipy's HiGHS prints a debug line from C to descriptor 1 during some MIP solves, which broke
``check --json`` on the secure-autonomy case study."""

from __future__ import annotations

import ctypes
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from posgmc.synthesis.solver_output import c_stdout_silenced

ROOT = Path(__file__).resolve().parents[2]


def _c_print(text: str) -> None:
    """printf from C, buffered by C's stdio as HiGHS's line is."""
    libc = ctypes.CDLL(None)
    libc.printf(text.encode())


def test_what_c_prints_inside_the_block_is_dropped_and_the_rest_kept(
        capfd: pytest.CaptureFixture[str]) -> None:
    print("before", flush=True)
    with c_stdout_silenced():
        _c_print("from C\n")
        os.write(1, b"raw descriptor\n")
    print("after", flush=True)
    out = capfd.readouterr().out
    assert out.splitlines() == ["before", "after"]


def test_output_buffered_before_the_block_is_not_lost(
        capfd: pytest.CaptureFixture[str]) -> None:
    sys.stdout.write("pending, not flushed\n")
    _c_print("C pending\n")
    with c_stdout_silenced():
        pass
    out = capfd.readouterr().out
    assert "pending, not flushed" in out and "C pending" in out


@pytest.mark.slow
def test_check_json_on_the_case_study_is_one_json_document() -> None:
    """The case study without take-downs (models/secure_autonomy, N=3, B=0; its README's bracket
    table): the MILP composition runs, and HiGHS printed its line into the JSON before."""
    r = subprocess.run(
        [sys.executable, "-m", "posgmc", "check",
         str(ROOT / "models" / "secure_autonomy" / "secure_autonomy.posg"),
         "--const", "N=3,flash=false,B=0", "--prop", '<<planner>> Pmax=? [ F "retrieved" ]',
         "--memory", "1", "--json"],
        capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=600, check=False)
    assert r.returncode == 0, r.stderr
    assert "Highs" not in r.stdout + r.stderr
    result = json.loads(r.stdout)["results"][0]
    assert result["sound"] is True
