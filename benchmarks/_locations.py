"""Where the benchmark scripts find the reference interpreter and the benchmark models.

Both come from the environment (see benchmarks/README.md), so that no script names one machine:

* ``POSGMC_REFERENCE_PYTHON``: an interpreter with stormpy and paynt (Storm's and PAYNT's side of
  every comparison). Unset: the scripts run posgmc alone and say that the reference was skipped.
* ``POSGMC_SHARED_BENCHMARKS``: the benchmark models folder (PAYNT's, PRISM-games' and the scale
  models, laid out as ``pomdp/``, ``posmg/``, ``smg/``, ``scale/``). Unset: the copy vendored for
  the tests, ``tests/data/benchmarks`` of this checkout.

Not part of the ``posgmc`` package.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

REFERENCE_PYTHON_VARIABLE = "POSGMC_REFERENCE_PYTHON"
SHARED_BENCHMARKS_VARIABLE = "POSGMC_SHARED_BENCHMARKS"


def reference_python() -> Path | None:
    """The interpreter with stormpy and paynt named by ``POSGMC_REFERENCE_PYTHON``, or None."""
    value = os.environ.get(REFERENCE_PYTHON_VARIABLE, "").strip()
    return Path(value) if value else None


def shared_benchmarks() -> Path:
    """The benchmark models folder: ``POSGMC_SHARED_BENCHMARKS``, else the vendored test copy."""
    value = os.environ.get(SHARED_BENCHMARKS_VARIABLE, "").strip()
    return Path(value).resolve() if value else ROOT / "tests" / "data" / "benchmarks"
