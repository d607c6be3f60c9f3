"""Micro-benchmark of the numerical engines on large models built directly as arrays.

Two families, both generated with numpy only (no parser, no builder):

* ``robots N``: the mdp of ``scale/two_robots.nm`` of the benchmarks folder (two robots on an N x N
  grid, slip 0.1, fault 0.002; one robot moves per step), every position pair with and without the
  fault flag (2 N^4 states; N=32 gives 2.1M states, 8.4M choices, 23M transitions, close to Storm's
  2,096,127 / 9,167,100 / 25,404,148 which only counts reachable states). Property: ``Pmax F goal``.
* ``random S``: a random sparse mdp or smg with S states, 1-8 choices per state, 1-3 successors
  per choice (mostly near the state index, some far) plus small leaks to an absorbing goal and
  sink; property ``Pmax/Pmin F goal``.

Usage::

    python benchmarks/engine_bench.py robots 32
    python benchmarks/engine_bench.py random 2000000 --smg
    python benchmarks/engine_bench.py robots 20 --method value

Prints model sizes, build time, and the time, iterations and value at the initial state of
``reach_probability`` (and, with ``--rewards``, of ``Rmin F goal`` for the robots).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse as sp

from posgmc.engines import objectives as obj
from posgmc.engines.options import Method, SolverOptions
from posgmc.model.explicit import ExplicitModel, RewardModel
from posgmc.syntax.ast import ModelType


def _model(
    model_type: ModelType,
    row_groups: np.ndarray,
    T: sp.csr_matrix,
    init: int,
    labels: dict[str, np.ndarray],
    players: np.ndarray | None = None,
    rewards: tuple[RewardModel, ...] = (),
) -> ExplicitModel:
    """Assemble without the validating constructor's O(nnz) checks (the arrays are right by
    construction; validation alone would dominate the build time)."""
    S = row_groups.size - 1
    C = int(row_groups[-1])
    return ExplicitModel(
        model_type=model_type,
        initial_states=np.array([init], dtype=np.int64),
        row_groups=row_groups,
        transitions=T,
        choice_actions=np.zeros(C, dtype=np.int32),
        action_names=("",),
        state_players=np.zeros(S, dtype=np.int32) if players is None else players,
        player_names=("p0", "p1") if players is not None else (),
        labels=labels,
        reward_models=rewards,
        state_values=np.zeros((S, 0), dtype=np.int64),
    )


def robots(N: int, s: float = 0.1, f: float = 0.002) -> tuple[ExplicitModel, np.ndarray]:
    """The two-robots mdp; returns the model and the goal label."""
    S = 2 * N**4
    idx = np.arange(S, dtype=np.int64)
    dead = idx % 2
    rest = idx // 2
    y2 = rest % N
    x2 = (rest // N) % N
    y1 = (rest // N**2) % N
    x1 = rest // N**3
    collide = (x1 == x2) & (y1 == y2)
    goal_pos = (x1 == N - 1) & (y1 == N - 1) & (x2 == 0) & (y2 == 0)
    done = goal_pos | collide | (dead == 1)
    goal = goal_pos & ~collide & (dead == 0)

    def sid(
        a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, e: np.ndarray
    ) -> np.ndarray:
        return (((a * N + b) * N + c) * N + d) * 2 + e

    moves = []  # (valid mask, successor index) for each of the 8 moves
    for robot in (1, 2):
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            if robot == 1:
                nx, ny = x1 + dx, y1 + dy
                valid = (nx >= 0) & (nx < N) & (ny >= 0) & (ny < N)
                succ = sid(np.clip(nx, 0, N - 1), np.clip(ny, 0, N - 1), x2, y2, dead)
            else:
                nx, ny = x2 + dx, y2 + dy
                valid = (nx >= 0) & (nx < N) & (ny >= 0) & (ny < N)
                succ = sid(x1, y1, np.clip(nx, 0, N - 1), np.clip(ny, 0, N - 1), dead)
            moves.append((valid & ~done, succ))
    counts = np.zeros(S, dtype=np.int64)
    for valid, _ in moves:
        counts += valid
    counts[done] = 1  # self-loop
    rg = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(counts, out=rg[1:])
    C = int(rg[-1])
    # row position of move j of state i: rg[i] + number of valid moves before j
    before = np.zeros(S, dtype=np.int64)
    rows_l, cols_l, vals_l = [], [], []
    dead_succ = idx | 1
    for valid, succ in moves:
        st = np.flatnonzero(valid)
        row = rg[st] + before[st]
        before[st] += 1
        rows_l += [row, row, row]
        cols_l += [succ[st], st, dead_succ[st]]
        vals_l += [np.full(st.size, 1 - s - f), np.full(st.size, s), np.full(st.size, f)]
    st = np.flatnonzero(done)
    rows_l.append(rg[st])
    cols_l.append(st)
    vals_l.append(np.ones(st.size))
    rows = np.concatenate(rows_l)
    cols = np.concatenate(cols_l)
    vals = np.concatenate(vals_l)
    order = np.lexsort((cols, rows))
    indptr = np.zeros(C + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=C), out=indptr[1:])
    T = sp.csr_matrix(
        (vals[order], cols[order].astype(np.int32), indptr.astype(np.int32)), shape=(C, S)
    )
    init = int(sid(np.array(0), np.array(0), np.array(N - 1), np.array(N - 1), np.array(0)))
    rewards = (RewardModel(name="moves", choice=np.where(done[np.repeat(idx, counts)], 0.0, 1.0)),)
    return _model(ModelType.MDP, rg, T, init, {"goal": goal}, rewards=rewards), goal


def pursuit(N: int, s: float = 0.1, q: float = 0.7) -> tuple[ExplicitModel, np.ndarray]:
    """The smg of ``scale/pursuit.smg`` of the benchmarks folder (evader vs pursuer on an N x N
    grid, turn-based); returns the model (player 0 = evader) and the "escaped" label."""
    S = 2 * N**4
    idx = np.arange(S, dtype=np.int64)
    turn = idx % 2
    rest = idx // 2
    py = rest % N
    px = (rest // N) % N
    ey = (rest // N**2) % N
    ex = rest // N**3
    caught = (ex == px) & (ey == py)
    escaped = (ex == N - 1) & (ey == N - 1) & ~caught
    over = caught | escaped

    def sid(
        a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, t: np.ndarray
    ) -> np.ndarray:
        return (((a * N + b) * N + c) * N + d) * 2 + t

    moves = []  # (valid, [(successor, probability), ...])
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        nx, ny = ex + dx, ey + dy
        valid = (turn == 0) & ~over & (nx >= 0) & (nx < N) & (ny >= 0) & (ny < N)
        moved = sid(np.clip(nx, 0, N - 1), np.clip(ny, 0, N - 1), px, py, 1 - turn)
        stay = sid(ex, ey, px, py, 1 - turn)
        moves.append((valid, [(moved, 1 - s), (stay, s)]))
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        nx, ny = px + dx, py + dy
        valid = (turn == 1) & ~over & (nx >= 0) & (nx < N) & (ny >= 0) & (ny < N)
        moved = sid(ex, ey, np.clip(nx, 0, N - 1), np.clip(ny, 0, N - 1), 1 - turn)
        stay = sid(ex, ey, px, py, 1 - turn)
        moves.append((valid, [(moved, q), (stay, 1 - q)]))
    wait = (turn == 1) & ~over
    moves.append((wait, [(sid(ex, ey, px, py, 1 - turn), 1.0)]))
    counts = np.zeros(S, dtype=np.int64)
    for valid, _ in moves:
        counts += valid
    counts[over] = 1
    rg = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(counts, out=rg[1:])
    C = int(rg[-1])
    before = np.zeros(S, dtype=np.int64)
    rows_l, cols_l, vals_l = [], [], []
    for valid, succs in moves:
        st = np.flatnonzero(valid)
        row = rg[st] + before[st]
        before[st] += 1
        for succ, p in succs:
            rows_l.append(row)
            cols_l.append(succ[st])
            vals_l.append(np.full(st.size, p))
    st = np.flatnonzero(over)
    rows_l.append(rg[st])
    cols_l.append(st)
    vals_l.append(np.ones(st.size))
    T = sp.csr_matrix(
        (np.concatenate(vals_l), (np.concatenate(rows_l), np.concatenate(cols_l))), shape=(C, S)
    )
    T.sum_duplicates()
    T.sort_indices()
    init = int(sid(np.array(0), np.array(0), np.array(N - 1), np.array(0), np.array(0)))
    players = turn.astype(np.int32)
    return _model(ModelType.SMG, rg, T, init, {"escaped": escaped}, players=players), escaped


def random_model(S: int, *, smg: bool, seed: int = 0) -> tuple[ExplicitModel, np.ndarray]:
    """A random sparse mdp/smg with goal state S-2 and sink S-1 (both absorbing).

    Every state has 1-8 choices; every choice has 1-3 random successors near the state (plus a 2%
    chance of a far one) and, like the faults of two_robots, a small leak: 0-4% to the goal and 2-4%
    to the sink, so that value iteration contracts (a random game without leaks has huge end
    components and converges very slowly -- a different benchmark).
    """
    rng = np.random.default_rng(seed)
    counts = rng.integers(1, 9, size=S)
    counts[-2:] = 1
    rg = np.zeros(S + 1, dtype=np.int64)
    np.cumsum(counts, out=rg[1:])
    C = int(rg[-1])
    owner = np.repeat(np.arange(S), counts)
    k = rng.integers(1, 4, size=C)
    src = np.repeat(owner, k)
    nnz = int(k.sum())
    local = src + rng.integers(-40, 41, size=nnz)
    far = rng.random(nnz) < 0.02
    local[far] = rng.integers(0, S - 2, size=int(far.sum()))
    cols = np.clip(local, 0, S - 3)
    rows = np.repeat(np.arange(C), k)
    w = rng.random(nnz) + 0.05
    sums = np.bincount(rows, weights=w, minlength=C)
    to_goal = rng.uniform(0.0, 0.04, size=C)
    to_sink = rng.uniform(0.02, 0.04, size=C)
    vals = (1.0 - to_goal - to_sink)[rows] * w / sums[rows]
    # the leaks, and the absorbing goal and sink
    body = np.arange(C - 2)
    rows = np.concatenate([rows, body, body, [C - 2, C - 1]])
    cols = np.concatenate([cols, np.full(C - 2, S - 2), np.full(C - 2, S - 1), [S - 2, S - 1]])
    vals = np.concatenate([vals, to_goal[: C - 2], to_sink[: C - 2], [1.0, 1.0]])
    keep = rows < C - 2
    keep[-2:] = True
    keep[nnz : nnz + 2 * (C - 2)] = True
    T = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(C, S))
    T.sum_duplicates()
    players = (np.arange(S) % 2).astype(np.int32) if smg else None
    goal = np.zeros(S, dtype=bool)
    goal[S - 2] = True
    mtype = ModelType.SMG if smg else ModelType.MDP
    return _model(mtype, rg, T, 0, {"goal": goal}, players=players), goal


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("family", choices=["robots", "pursuit", "random"])
    ap.add_argument("size", type=int)
    ap.add_argument(
        "--smg", action="store_true", help="random: a two-player game (alternating owners)"
    )
    ap.add_argument("--min", action="store_true", help="minimise instead of maximise")
    ap.add_argument("--method", default="interval", choices=[m.value for m in Method])
    ap.add_argument("--precision", type=float, default=1e-6)
    ap.add_argument("--rewards", action="store_true", help="robots: also Rmin F goal")
    ap.add_argument("--no-strategy", action="store_true")
    args = ap.parse_args()

    t0 = time.perf_counter()
    if args.family == "robots":
        model, goal = robots(args.size)
    elif args.family == "pursuit":
        model, goal = pursuit(args.size)
    else:
        model, goal = random_model(args.size, smg=args.smg)
    t1 = time.perf_counter()
    print(
        f"{args.family} {args.size}: {model.num_states:,} states, {model.num_choices:,} choices, "
        f"{model.num_transitions:,} transitions; built in {t1 - t0:.2f} s"
    )
    options = SolverOptions(
        method=Method(args.method), precision=args.precision, want_strategy=not args.no_strategy
    )
    if model.model_type is ModelType.SMG:
        maximize = model.state_players == (1 if args.min else 0)
    else:
        maximize = np.full(model.num_states, not args.min)
    init = int(model.initial_states[0])
    for round_ in ("first call (incl. transpose)", "second call"):
        t2 = time.perf_counter()
        c2 = time.process_time()
        res = obj.reach_probability(model, goal, maximize=maximize, options=options)
        t3 = time.perf_counter()
        c3 = time.process_time()
        print(
            f"  P{'min' if args.min else 'max'} F goal [{round_}]: "
            f"{t3 - t2:.2f} s wall, {c3 - c2:.2f} s cpu, "
            f"{res.iterations} iterations, converged={res.converged}, "
            f"value {res.values[init]:.10f} in [{res.lower[init]:.10f}, {res.upper[init]:.10f}]"
        )
    if args.rewards and args.family == "robots":
        rm = model.reward_models[0].choice_rewards(model.row_groups)
        t2 = time.perf_counter()
        res = obj.expected_reach_reward(
            model,
            rm,
            goal | model.labels["goal"],
            maximize=np.zeros(model.num_states, bool),
            options=options,
        )
        t3 = time.perf_counter()
        print(
            f"  Rmin F goal: {t3 - t2:.2f} s, {res.iterations} iterations, value {res.values[init]}"
        )


if __name__ == "__main__":
    main()
