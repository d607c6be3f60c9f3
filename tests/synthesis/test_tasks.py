"""What executors run and record (posgmc.synthesis.tasks): phases, the ledger of what ran,
deadlines moved into another machine's clock, the placement an executor is chosen from; and the
local executors' ledgers (posgmc.synthesis.executors)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from posgmc.synthesis.deterministic import DeterministicJob
from posgmc.synthesis.double_oracle import RankJob, VersusJob
from posgmc.synthesis.executors import InProcess, ProcessPool, executor_for
from posgmc.synthesis.options import SynthesisOptions
from posgmc.synthesis.search import AscendJob
from posgmc.synthesis.tasks import Placement, TaskLedger, phase_of, rebased
from tests.random_games import random_posg
from tests.synthesis.helpers import reach_problem


@dataclass(frozen=True)
class _Square:
    PHASE: ClassVar[str] = "squares"
    x: int

    def run(self, problem: object) -> int:
        return self.x * self.x


@dataclass(frozen=True)
class _Staged:
    """A job with a deadline per stage."""

    deadlines: tuple[float | None, ...]

    def run(self, problem: object) -> None:
        return None


def test_each_job_kind_names_its_phase() -> None:
    """The phases of the JSON's task counts are the names of the result's "phases" timings."""
    assert phase_of(RankJob.__new__(RankJob)) == "adversaries: ranking"
    assert phase_of(VersusJob.__new__(VersusJob)) == "adversaries: evaluation"
    assert phase_of(AscendJob.__new__(AscendJob)) == "gradient search"
    assert phase_of(DeterministicJob((1,), None, (10,))) == "deterministic search"
    assert phase_of(_Square(2)) == "squares"


def test_executors_record_what_ran_by_phase() -> None:
    """In this process and in a pool of two: the same results and task counts."""
    problem = reach_problem(random_posg(3))
    jobs = [_Square(i) for i in range(5)]
    for executor in (InProcess(problem), ProcessPool(problem, 2)):
        try:
            assert executor.map(jobs) == [0, 1, 4, 9, 16]
            assert executor.map(jobs[:1]) == [0]  # a batch of one runs here, recorded too
            assert executor.ledger.counts == {"squares": 6}
            assert executor.ledger.seconds["squares"] >= 0.0
        finally:
            executor.close()


def test_ledger_json() -> None:
    ledger = TaskLedger()
    for phase, seconds in (("a", 0.5), ("b", 1.0), ("a", 0.25)):
        ledger.record(phase, seconds)
    assert ledger.to_json() == {"a": {"count": 2, "worker_seconds": 0.75},
                                "b": {"count": 1, "worker_seconds": 1.0}}


def test_placement_of_the_options() -> None:
    """--jobs 1 runs in this process, more in a local pool; --executor and --ray-address are
    carried to the placement."""
    problem = reach_problem(random_posg(3))
    assert isinstance(executor_for(problem, 1), InProcess)
    pool = executor_for(problem, Placement("local", 2))
    pool.close()
    assert isinstance(pool, ProcessPool) and pool.workers == 2
    options = SynthesisOptions(jobs=3, executor="ray", ray_address="10.0.0.5:6379")
    assert options.placement == Placement("ray", 3, "10.0.0.5:6379")


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)


@given(deadline=st.none() | finite, ends=st.lists(st.none() | finite, max_size=3),
       offset=finite)
def test_rebased_moves_every_clock_field_and_nothing_else(
        deadline: float | None, ends: list[float | None], offset: float) -> None:
    """A deadline and each of a job's deadlines move by the offset (None stays None); memory
    sizes, logits and the like do not."""
    logits = np.arange(4.0).reshape(2, 2)
    job = AscendJob(2, logits, logits, 60, 0.3, deadline)
    moved = rebased(job, offset)
    assert isinstance(moved, AscendJob)
    assert moved.deadline == (None if deadline is None else deadline + offset)
    assert (moved.memory, moved.iterations, moved.learning_rate) == (2, 60, 0.3)
    assert moved.logits_action is logits
    several = rebased(_Staged(tuple(ends)), offset)
    assert isinstance(several, _Staged)
    assert several.deadlines == tuple(None if e is None else e + offset for e in ends)
    assert rebased(job, 0.0) is job and rebased(_Square(3), offset) == _Square(3)
