"""Shared test fixtures: where the vendored benchmark models and the reference interpreter are.

The benchmark models (PAYNT's, PRISM-games' and the scale models) are vendored under
``tests/data/benchmarks`` with their provenance and licences in ``tests/data/README.md``, so a
clone of this repository runs every test that needs them. Storm and PAYNT are not vendored: the
tests that run them ask for ``POSGMC_REFERENCE_PYTHON`` (an interpreter with stormpy and paynt, see
benchmarks/README.md) and skip, saying so, when it is not set.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "tests" / "data" / "benchmarks"
REFERENCE_PYTHON_VARIABLE = "POSGMC_REFERENCE_PYTHON"
NO_REFERENCE_PYTHON = (
    f"needs Storm: set {REFERENCE_PYTHON_VARIABLE} to an interpreter with stormpy and paynt "
    "(benchmarks/README.md)"
)


def reference_python() -> Path | None:
    """The reference interpreter (stormpy, paynt) named by ``POSGMC_REFERENCE_PYTHON``, if any."""
    value = os.environ.get(REFERENCE_PYTHON_VARIABLE, "").strip()
    if not value or not Path(value).exists():
        return None
    return Path(value)


@pytest.fixture(scope="session")
def benchmarks() -> Path:
    """The vendored benchmark models folder (``pomdp/``, ``posmg/``, ``smg/``, ``scale/``)."""
    return BENCHMARKS


@pytest.fixture(scope="session")
def storm_python() -> Path:
    """The reference interpreter; the test skips (saying what it needs) when there is none."""
    python = reference_python()
    if python is None:
        pytest.skip(NO_REFERENCE_PYTHON)
    return python
