"""posgmc.deep_stack: work on a deep-stack thread, exceptions and the recursion limit handed
back."""

from __future__ import annotations

import sys
import threading

import pytest

from posgmc.deep_stack import deep_call, deep_generator
from posgmc.errors import LimitError


def _nest(n: int) -> int:
    return 0 if n == 0 else 1 + _nest(n - 1)


def test_deep_recursion_runs_and_the_limit_comes_back() -> None:
    before = sys.getrecursionlimit()
    assert deep_call(lambda: _nest(20_000)) == 20_000
    assert sys.getrecursionlimit() == before


def test_exceptions_reach_the_caller() -> None:
    with pytest.raises(KeyError):
        deep_call(lambda: {}["x"])
    with pytest.raises(KeyboardInterrupt):
        deep_call(lambda: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(LimitError, match="nests too deeply"):
        deep_call(lambda: _nest(10**6))


def test_nested_calls_stay_on_one_worker() -> None:
    names = deep_call(
        lambda: [
            threading.current_thread().name,
            deep_call(lambda: threading.current_thread().name),
        ]
    )
    assert names == ["posgmc-deep", "posgmc-deep"]


def test_concurrent_callers_never_lower_each_others_limit() -> None:
    before = sys.getrecursionlimit()
    results: list[int] = []
    threads = [
        threading.Thread(target=lambda: results.append(deep_call(lambda: _nest(15_000))))
        for _ in range(4)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == [15_000] * 4 and sys.getrecursionlimit() == before


def test_generators_step_on_the_worker() -> None:
    @deep_generator
    def gen():  # type: ignore[no-untyped-def]
        for i in range(3):
            yield (i, threading.current_thread().name, _nest(5000))

    assert [x[0] for x in gen()] == [0, 1, 2] and {x[1] for x in gen()} == {"posgmc-deep"}
