"""Bounded mutation fuzzing in the default run; ``benchmarks/fuzz.py`` is the long run.

Every model and properties file under models/ and tests/ (the vendored benchmarks included) is
mutated (tokens deleted, duplicated, swapped; numbers made extreme; strange characters and huge
literals inserted; the text cut) and the oracle of :mod:`tests.fuzz.mutate` applied.
"""

from __future__ import annotations

import random
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzz.mutate import check_model_text, check_properties_text, corpus, mutate, scratch

MODELS, PAIRS = corpus()


def test_the_corpus_is_there() -> None:
    # the vendored benchmarks alone hold 71 model files and 50 properties files beside a model
    assert len(MODELS) >= 71 and len(PAIRS) >= 50


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(MODELS), st.integers(0, 2**32 - 1), st.integers(1, 3))
def test_mutated_models(path: Path, seed: int, steps: int) -> None:
    text = mutate(path.read_text(encoding="utf-8"), random.Random(seed), steps)
    with scratch() as tmp:
        check_model_text(text, path.suffix, Path(tmp))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(PAIRS), st.integers(0, 2**32 - 1), st.integers(1, 3))
def test_mutated_properties(pair: tuple[Path, Path], seed: int, steps: int) -> None:
    model, props = pair
    text = mutate(props.read_text(encoding="utf-8"), random.Random(seed), steps)
    with scratch() as tmp:
        check_properties_text(model, text, Path(tmp))
