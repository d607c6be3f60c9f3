"""Independent calls on an executor (posgmc.synthesis.fanout): results in the calls' order
whatever order the workers finish in, a call's own error re-raised, a dead worker named, and
where the calls ran recorded. The Ray side runs in tests/synthesis/test_ray_pool.py."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc.errors import InputError, WorkerError
from posgmc.resources import usable_cpus
from posgmc.synthesis.fanout import Spread, each_result, workers_for
from posgmc.synthesis.tasks import Placement
from tests.synthesis import fanned

TWO = Placement("local", 2)


def _slow_square(x: int, pause: float) -> int:
    time.sleep(pause)
    return x * x


def _fails_at(x: int, bad: int) -> int:
    if x == bad:
        raise InputError(f"call {x} refuses")
    return x


def _dies_at(x: int, bad: int) -> int:
    if x == bad:
        os._exit(9)  # a worker killed mid-call (as by the kernel's out-of-memory killer)
    return x


@settings(max_examples=5, deadline=None)
@given(st.lists(st.integers(0, 3), min_size=2, max_size=5))
def test_results_come_in_call_order_whatever_finishes_first(pauses: list[int]) -> None:
    """The later calls may finish first (shorter pauses); the results are still in call order
    and equal to one process's."""
    calls = [(i, p / 100) for i, p in enumerate(pauses)]
    here = list(each_result(_slow_square, calls, Placement()))
    assert here == [i * i for i in range(len(pauses))]
    assert list(each_result(_slow_square, calls, TWO)) == here


@pytest.mark.skipif(usable_cpus() < 2, reason="a local pool needs two usable processors")
def test_the_spread_says_where_the_calls_ran() -> None:
    spread = Spread()
    out = list(each_result(_slow_square, [(1, 0.0), (2, 0.0), (3, 0.0)], TWO, spread=spread,
                           phase="point"))
    assert out == [1, 4, 9]
    assert (spread.executor, spread.workers) == ("local", 2)
    assert spread.ledger.counts == {"point": 3}
    assert spread.to_json()["tasks"]["point"]["count"] == 3


def test_one_call_or_one_worker_runs_here() -> None:
    spread = Spread()
    assert list(each_result(os.getpid, [()], TWO, spread=spread)) == [os.getpid()]
    assert spread.workers == 1
    assert workers_for(Placement("local", 8), 3) <= 3
    assert workers_for(Placement("local", 1), 3) == 1


def test_a_calls_error_is_raised_in_order() -> None:
    """The error of call 2 comes after the result of call 1, as in one process."""
    seen: list[int] = []
    with pytest.raises(InputError, match="call 2 refuses"):
        for x in each_result(_fails_at, [(i, 2) for i in range(5)], TWO):
            seen.append(x)
    assert seen == [0, 1]


@pytest.mark.skipif(usable_cpus() < 2, reason="a local pool needs two usable processors")
def test_a_dead_worker_is_named() -> None:
    with pytest.raises(WorkerError, match=r"w=3 failed: its worker process died"):
        list(each_result(_dies_at, [(i, 3) for i in range(5)], TWO,
                         labels=[f"w={i}" for i in range(5)]))


def test_stopping_early_ends_the_pool() -> None:
    """A caller that stops reading (Ctrl-C seen, an error) does not wait for the calls still
    running: the generator's close ends them."""
    results = each_result(_slow_square, [(0, 0.0), (1, 30.0), (2, 30.0)], TWO)
    assert next(results) == 0
    t0 = time.perf_counter()
    results.close()
    assert time.perf_counter() - t0 < 20


@pytest.mark.skipif(usable_cpus() < 2, reason="a local pool needs two usable processors")
@pytest.mark.parametrize("name", list(fanned.EXIT))
def test_commands_on_two_workers_print_one_process_s_output(name: str, tmp_path: Path) -> None:
    """Every number and line of a sweep, a front and test runs on a pool of two equals
    ``--jobs 1``'s, in the same order (the seconds aside)."""
    one, two = fanned.agrees_with_one_process(name, fanned.commands(tmp_path)[name],
                                              ["--jobs", "2"])
    if name == "check sweep":
        assert json.loads(two)["points"]["tasks"]["constant point"]["count"] == 2
        assert json.loads(two)["points"]["workers"] == 2
    if name == "test runs":
        assert "FAIL" in one and one.count("PASS") == 2
