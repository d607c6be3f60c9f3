"""Synthesis jobs on a Ray cluster (posgmc.synthesis.ray_pool): the numbers of one process, jobs
on every node, a worker killed mid-job (retried), a worker that keeps dying (a clear error
naming the job), and the CLI's ``--executor ray``.

CI (``.ci/run``) starts a two-node Ray cluster on the machine (one CPU each) and points
``RAY_ADDRESS`` at it; without it, the tests start a Ray on this machine."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from click.testing import CliRunner

ray = pytest.importorskip("ray", reason="the test extra installs Ray (pip install -e '.[test]')")

from posgmc.cli import main  # noqa: E402
from posgmc.errors import InputError, WorkerError  # noqa: E402
from posgmc.synthesis.double_oracle import RankJob, VersusJob  # noqa: E402
from posgmc.synthesis.executors import InProcess  # noqa: E402
from posgmc.synthesis.problem import Problem  # noqa: E402
from posgmc.synthesis.ray_pool import (  # noqa: E402
    RETRIES,
    RayPool,
    _connect,
    _reachable,
    _Shared,
    shared_fields,
)
from posgmc.synthesis.tasks import Placement  # noqa: E402
from tests.random_games import random_posg  # noqa: E402
from tests.synthesis import fanned  # noqa: E402
from tests.synthesis.helpers import (  # noqa: E402
    SMALL,
    reach_problem,
    synthesised,
    without_times,
)

ROOT = Path(__file__).resolve().parents[2]
BEACON = ROOT / "models" / "beacon" / "beacon.posg"


@pytest.fixture(scope="module")
def cluster() -> Any:
    """Ray, connected the way ``--executor ray`` connects (RAY_ADDRESS, else a local Ray);
    the jobs below are defined here, so they travel by value."""
    started_here = not ray.is_initialized()
    _connect(ray, None)
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    yield ray
    ray.cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    if started_here:
        ray.shutdown()


@dataclass(frozen=True)
class _Where:
    """Which node ran the job, after ``seconds``."""

    PHASE: ClassVar[str] = "where"
    seconds: float

    def run(self, problem: Problem) -> str:
        import time

        import ray as worker_ray

        time.sleep(self.seconds)
        return str(worker_ray.get_runtime_context().get_node_id())


@dataclass(frozen=True)
class _DiesOnce:
    """Kills its worker the first time it runs (a file marks that it did), then returns the
    number of states."""

    PHASE: ClassVar[str] = "dies once"
    marker: str

    def run(self, problem: Problem) -> int:
        if not os.path.exists(self.marker):
            Path(self.marker).touch()
            os._exit(1)
        return int(problem.model.num_states)


@dataclass(frozen=True)
class _AlwaysDies:
    PHASE: ClassVar[str] = "always dies"

    def run(self, problem: Problem) -> int:
        os._exit(1)


def test_ray_gives_the_numbers_of_one_process(cluster: Any) -> None:
    """The whole synthesis (search starts, ranking, composition, double oracle, evaluations) on
    two Ray workers: every number, strategy and task count equals --jobs 1's (the budget does
    not bind: SMALL finishes far within it, even on a loaded machine)."""
    model = random_posg(3)
    options = replace(SMALL, memory=(1, 2), adversaries=3, timeout=600)
    one = synthesised(model, options)
    on_ray = synthesised(model, replace(options, jobs=2, executor="ray"))
    assert without_times(on_ray.to_json()) == without_times(one.to_json())
    for a, b in zip(one.strategies, on_ray.strategies, strict=True):
        assert np.array_equal(a.action, b.action) and np.array_equal(a.update, b.update)
    here, there = one.synthesis["synthesis"], on_ray.synthesis["synthesis"]
    assert (there["executor"], there["workers"]) == ("ray", 2)
    assert {p: t["count"] for p, t in there["tasks"].items()} == \
        {p: t["count"] for p, t in here["tasks"].items()}
    assert there["tasks"]["adversaries: ranking"]["count"] > 1


def test_cli_check_on_ray_prints_the_numbers_of_one_process(cluster: Any) -> None:
    """``posgmc check --executor ray`` on beacon (memory 1, a budget that does not bind): every
    number of the JSON equals ``--jobs 1``'s; the JSON says where the jobs ran."""
    runner = CliRunner()
    base = ["check", str(BEACON), "--prop", '<<rover>> Pmax=? [ F "safe" ]', "--memory", "1",
            "--timeout", "300", "--json"]
    runs = {}
    for name, extra in (("one", []), ("ray", ["--executor", "ray", "--jobs", "2"])):
        out = runner.invoke(main, base + extra, catch_exceptions=False)
        assert out.exit_code == 0, out.output
        runs[name] = json.loads(out.output)
    assert runs["one"]["model"] == runs["ray"]["model"]
    one, on_ray = (runs[n]["results"][0] for n in ("one", "ray"))
    assert one["guaranteed"]["value"] == pytest.approx(0.5, abs=1e-6)  # models/beacon/README.md
    assert without_times(on_ray) == without_times(one)
    assert (on_ray["synthesis"]["executor"], on_ray["synthesis"]["workers"]) == ("ray", 2)
    assert (one["synthesis"]["executor"], one["synthesis"]["workers"]) == ("local", 1)


@pytest.mark.parametrize("name", list(fanned.EXIT))
def test_sweeps_fronts_and_test_runs_on_ray_print_one_process_s_output(
        cluster: Any, name: str, tmp_path: Path) -> None:
    """Each constant point, front weight and test run a Ray task (on both nodes of CI's
    cluster): every number and line equals ``--jobs 1``'s, in the same order."""
    _, on_ray = fanned.agrees_with_one_process(name, fanned.commands(tmp_path)[name],
                                               ["--executor", "ray"])
    if name == "check sweep":
        points = json.loads(on_ray)["points"]
        assert points["executor"] == "ray" and points["tasks"]["constant point"]["count"] == 2


def test_a_failing_ray_task_is_raised_in_order(cluster: Any) -> None:
    from posgmc.synthesis.fanout import each_result

    seen = []
    with pytest.raises(InputError, match="no such file"):
        for x in each_result(_load_or_fail, [("a",), ("",), ("b",)], Placement("ray", 2)):
            seen.append(x)
    assert seen == ["a"]


def _load_or_fail(name: str) -> str:
    if not name:
        raise InputError("no such file")
    return name


def test_an_address_where_no_cluster_answers_is_an_input_error() -> None:
    with pytest.raises(InputError, match=r"--ray-address 127\.0\.0\.1:1: no Ray cluster"):
        _reachable("127.0.0.1:1")
    with pytest.raises(InputError, match=r"give HOST:PORT"):
        _reachable("headnode")


def test_cli_ray_address_needs_the_ray_executor() -> None:
    out = CliRunner().invoke(main, ["check", str(BEACON), "--prop", '<<rover>> Pmax=? [ F "safe" ]',
                                    "--ray-address", "127.0.0.1:6379"])
    assert out.exit_code == 2 and "--ray-address" in out.output and "--executor ray" in out.output


# the pool tests last: the last leaves one of the pool's actors dead, holding nothing, while the
# pool lives (until the end of the module)


def test_workers_build_a_model_read_from_text_themselves(cluster: Any) -> None:
    """A model built from text goes to the workers as its recipe (the text and constants), not
    built; each worker builds it and gives the numbers of one process. (Before the pool
    fixture below, which holds the cluster's CPUs from its first test on.)"""
    import pickle

    from posgmc import api
    from posgmc.syntax import parser
    from posgmc.synthesis.adversaries import enumerate_adversaries
    from posgmc.synthesis.ray_pool import shipped
    from posgmc.synthesis.search import problem_of

    model = api.build(api.load(BEACON)).model
    resolver = api._resolver(model, False)
    expr = parser.parse_property('<<rover>> Pmax=? [ F "safe" ]').expr
    player = next(iter(resolver.coalition_of(expr.coalition) or {0}))
    problem = problem_of(model, expr, player=player, adversary=1 - player,
                         coalition_of=resolver.coalition_of, scalar=api._scalar)
    light, recipe = shipped(problem)
    assert recipe is not None and light.model is None
    assert len(pickle.dumps((light, recipe))) < len(pickle.dumps(problem))
    assert problem.adversary is not None
    jobs = [RankJob(a) for a in enumerate_adversaries(model, problem.adversary, memory=1,
                                                      limit=4).strategies]
    assert len(jobs) > 1
    pool = RayPool(problem, Placement("ray", 2))
    try:
        assert pool.map(jobs) == InProcess(problem).map(jobs)
    finally:
        pool.close()


@pytest.fixture(scope="module")
def pool(cluster: Any) -> Any:
    """Two actors holding a small problem, shared by the tests below (starting an actor starts
    a Python process); the last of them leaves an actor dead for good."""
    workers = RayPool(reach_problem(random_posg(3)), Placement("ray", 2))
    yield workers
    workers.close()


def test_jobs_run_on_every_node(cluster: Any, pool: RayPool) -> None:
    """One actor per CPU: on CI's two one-CPU nodes, the jobs run on both."""
    nodes = [n for n in cluster.nodes() if n["Alive"] and n["Resources"].get("CPU", 0) >= 1]
    assert pool.workers == 2
    where = pool.map([_Where(0.2) for _ in range(6)])
    assert len(where) == 6 and pool.ledger.counts["where"] == 6
    assert len(set(where)) == min(2, len(nodes))


def test_a_shared_defence_goes_once_and_gives_the_same_values(pool: RayPool) -> None:
    """The candidate evaluation's jobs share the defence: it is put in the object store once
    for the batch, the jobs carry a reference, and the values are those of one process."""
    problem = pool.problem
    search = synthesised(problem.model, replace(SMALL, adversaries=3))
    defence, adversary = search.strategies[0], search.strategies[1]
    jobs = [VersusJob(defence, adversary), VersusJob(defence, adversary)]
    stored: list[object] = []
    sent = shared_fields(jobs, lambda v: stored.append(v) or len(stored))
    assert stored == [defence, adversary]  # each shared value once, in field order
    assert all(isinstance(j, VersusJob) and j.defence == _Shared(1) and j.adversary == _Shared(2)
               for j in sent)
    lone = [VersusJob(defence, adversary), RankJob(adversary)]
    assert shared_fields(lone, lambda v: 0)[0].defence is defence  # one job only: sent whole
    assert pool.map(jobs) == InProcess(problem).map(jobs)


def test_a_killed_worker_has_its_job_retried(pool: RayPool, tmp_path: Path) -> None:
    """The worker dies in the middle of a job; Ray restarts it with the problem and the job runs
    again, the batch's results in order."""
    got = pool.map([_DiesOnce(str(tmp_path / "first")), _DiesOnce(str(tmp_path / "second"))])
    assert got == [pool.problem.model.num_states] * 2
    assert (tmp_path / "first").exists() and pool.ledger.counts["dies once"] == 2


def test_a_worker_that_keeps_dying_fails_the_run_naming_the_job(pool: RayPool) -> None:
    """After RETRIES restarts the run stops (no hang) with an error naming the job; the job in
    the same batch on the other worker is not waited for in vain."""
    with pytest.raises(WorkerError, match=rf"job 2 of 2 \(always dies\) failed: its Ray "
                                          rf"worker died {RETRIES + 1} times"):
        pool.map([_Where(0.0), _AlwaysDies()])


def _session_processes(session: int) -> list[str]:
    """The command lines of the processes still running in ``session`` (zombies aside)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            if os.getsid(int(entry)) != session:
                continue
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                command = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if stat[stat.rfind(")") + 2] not in "ZX":
            out.append(command or stat.split(" ")[1])
    return out


@pytest.mark.slow
@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads Linux's /proc")
@pytest.mark.parametrize("interrupt", [False, True])
def test_a_ray_started_for_the_run_leaves_no_process_behind(interrupt: bool,
                                                           tmp_path: Path) -> None:
    """``--executor ray`` without an address starts a Ray for the run; when the run ends — on
    its own, or by Ctrl-C once the Ray's tasks run — none of its processes is left (Ray's
    shutdown alone leaves its dashboard and runtime-environment agents running)."""
    import signal
    import subprocess
    import time

    args = fanned.commands(tmp_path)["pareto sweep"]
    if interrupt:
        args = [*args[:-5], "--memory", "2", "--effort", "20", "-q"]  # still running when cut
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env["PYTHONPATH"] = str(ROOT)
    run = subprocess.Popen([sys.executable, "-m", "posgmc", *args, "--executor", "ray"],
                           env=env, start_new_session=True, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        if interrupt:
            deadline = time.monotonic() + 120
            while not any("ray::_call" in c or "ray::IDLE" in c
                          for c in _session_processes(run.pid)):
                assert run.poll() is None and time.monotonic() < deadline
                time.sleep(0.2)
            time.sleep(1.0)
            os.killpg(run.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole group
        out, err = run.communicate(timeout=300)
        assert run.returncode == (130 if interrupt else 0), err
        time.sleep(2)
        assert _session_processes(run.pid) == []
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
