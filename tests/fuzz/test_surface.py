"""Bounded fuzzing of strategy files, option values and library arguments in the default run;
``benchmarks/fuzz.py --surface ...`` is the long run (``docs/robustness.md``)."""

from __future__ import annotations

import random
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzz import surface
from tests.fuzz.mutate import scratch


def test_the_strategy_corpus_is_there() -> None:
    assert len(surface.STRATEGY_FILES) >= 7  # models/rover (3) and models/convoy (4)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_mutated_strategy_files(seed: int) -> None:
    model, text = surface.strategy_text(random.Random(seed))
    with scratch() as tmp:
        surface.check_strategy_text(model, text, Path(tmp))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_hostile_library_arguments(seed: int) -> None:
    with scratch() as tmp:
        name, arg, value = surface.api_call(random.Random(seed), Path(tmp))
        surface.check_api_call(name, arg, value, Path(tmp))


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_hostile_option_values(seed: int) -> None:
    with scratch() as tmp:
        surface.check_option_arguments(surface.option_arguments(random.Random(seed)), Path(tmp))
