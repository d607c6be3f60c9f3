"""benchmarks/synthesis_bench.py's PAYNT columns: a PAYNT that was not run says so, it does not
fail; one that ran is compared with posgmc's proven bounds."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from posgmc.checking.results import Bound

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def _bench() -> ModuleType:
    sys.path.insert(0, str(BENCHMARKS))  # the script imports its sibling _locations
    try:
        spec = importlib.util.spec_from_file_location("synthesis_bench",
                                                      BENCHMARKS / "synthesis_bench.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(BENCHMARKS))
    return module


G = Bound(0.5, 0.4999995, 0.5000005)


def test_paynt_not_run_says_not_run() -> None:
    cells = _bench().paynt_cells
    for why in ("--no-paynt", "set POSGMC_REFERENCE_PYTHON (benchmarks/README.md)"):
        theirs, seconds, better = cells({"skipped": why}, G, True)
        assert (theirs, seconds, better) == ("not run", "-", "- (PAYNT not run)")
        assert "fail" not in theirs + better
        assert cells({"skipped": why}, None, True) == ("not run", "-", "-")


def test_paynt_that_ran_is_compared_or_said_to_fail() -> None:
    cells = _bench().paynt_cells
    failed = {"error": "RuntimeError: boom", "seconds": 4.8}
    assert cells(failed, G, True) == ("fails: RuntimeError: boom", "4.8", "posgmc (PAYNT fails)")
    # equal within 2e-6 of the proven bound's side; better by more
    assert cells({"value": 0.4999990, "seconds": 60.0}, G, True)[2] == "equal"
    assert cells({"value": 0.49, "seconds": 60.0}, G, True)[2] == "posgmc"
    assert cells({"value": 0.51, "seconds": 60.0}, G, True)[2] == "PAYNT"
    # minimising: lower is better, posgmc's side is its upper bound
    assert cells({"value": 0.51, "seconds": 60.0}, G, False)[2] == "posgmc"
    assert cells({"value": 0.51, "seconds": 1.0}, None, True) == ("0.510000", "1.0", "PAYNT")
