"""The kernels' tests run on small models: the size below which the engines keep their numpy
paths (``scc.COMPILED_MIN_SIZE``) is lowered to 0 for every test here."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from posgmc.engines import scc


@pytest.fixture(autouse=True)
def compiled_at_any_size() -> Iterator[None]:
    saved = scc.COMPILED_MIN_SIZE
    scc.COMPILED_MIN_SIZE = 0
    yield
    scc.COMPILED_MIN_SIZE = saved
