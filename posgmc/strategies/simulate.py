"""Monte Carlo simulation of a model under finite-state strategies: estimates with confidence
intervals, and sampled paths (traces).

Runs are simulated together as arrays on the product of the model with the given strategies
(:mod:`posgmc.strategies.product`), where a player with a strategy has one mixed row per
(state, memory): sampling that row samples its action, next memory node and successor jointly.
A player without a strategy plays uniformly at random over its choices, or (``opponent="best"``)
the optimal memoryless strategy of the product, which for it is the full-observation optimum.
Successors are drawn with one uniform number per run and a search in the CSR rows' cumulative
sums; everything is reproducible from the seed (``numpy.random.default_rng``).

Estimates: for a probability, the Wilson score interval at 95 %. A run is decided when it
reaches the target (true), can no longer reach it or leaves the ``U``'s left side (false), or
reaches the formula's step bound (``F<=k``: false after k steps). Runs that reach ``max_steps``
before any of these are undecided: they count as failures for the lower end and as successes for
the upper end, so the interval covers them (and the report says how many there were), and there
is then no point estimate (``estimate`` is None). For an expected reward, the mean with a normal
95 % interval (an estimate from the central limit theorem, said so); an undecided run's reward is
unknown (it may never reach the target), so with undecided runs the interval's upper end is
infinite, its lower end is that of the rewards collected so far (a lower estimate when no reward is
negative, else -inf too) and there is no point estimate.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from posgmc.checking.property_checker import (
    CheckOptions,
    CoalitionResolver,
    PropertyChecker,
    ScalarEvaluator,
)
from posgmc.checking.states import evaluate_states
from posgmc.engines.graph import positive_reach, structure_of
from posgmc.errors import LimitError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.resources import available_bytes
from posgmc.semantics.queries import reward_structure
from posgmc.strategies.binding import BoundStrategy, bind
from posgmc.strategies.fss import FiniteStateStrategy
from posgmc.strategies.product import StrategyProduct, strategy_product
from posgmc.syntax.ast import (
    Expr,
    ProbQuery,
    RewardKind,
    RewardQuery,
    Temporal,
    TemporalOp,
)

__all__ = ["Simulation", "TraceStep", "simulate", "wilson"]

Z95 = 1.959963984540054


@dataclass(frozen=True)
class TraceStep:
    """One step of a sampled path: the state (its variables), its owner, each player's
    observation and each strategy's memory node before the move, and the action taken."""

    step: int
    owner: str
    state: str
    observations: tuple[tuple[str, str], ...]
    memory: tuple[tuple[str, int], ...]
    action: str


@dataclass(frozen=True)
class Simulation:
    """An estimate with its 95 % interval. ``kind`` is "probability" (Wilson interval) or
    "reward" (normal interval, an estimate); ``undecided`` runs reached ``max_steps`` first, and
    then ``estimate`` is None (the interval covers whatever they would have done)."""

    property: str
    kind: str
    estimate: float | None
    lower: float
    upper: float
    runs: int
    undecided: int
    seed: int
    trace: tuple[TraceStep, ...] = ()

    def to_json(self) -> dict[str, object]:
        return {"property": self.property, "kind": self.kind, "estimate": self.estimate,
                "lower": self.lower, "upper": self.upper, "runs": self.runs,
                "undecided": self.undecided, "seed": self.seed}


def wilson(successes: int, runs: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion."""
    if runs == 0:
        return 0.0, 1.0
    p = successes / runs
    denom = 1 + z * z / runs
    centre = (p + z * z / (2 * runs)) / denom
    half = z * math.sqrt(p * (1 - p) / runs + z * z / (4 * runs * runs)) / denom
    # exactly 0 (1) when no run succeeded (failed): centre - half is then 0 only up to rounding
    lower = 0.0 if successes == 0 else max(0.0, centre - half)
    upper = 1.0 if successes == runs else min(1.0, centre + half)
    return lower, upper


def _objective(expr: Expr) -> tuple[str, Expr | None, Expr, int | None, RewardQuery | None]:
    """(kind, remain, target, step bound, reward query) of a supported property."""
    if isinstance(expr, ProbQuery) and expr.threshold is None:
        path = expr.path
        if isinstance(path, Temporal) and path.op in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL):
            bound = path.bound
            if bound is None or (bound.lower is None and bound.upper is not None):
                remain = path.operands[0] if path.op is TemporalOp.UNTIL else None
                return "probability", remain, path.operands[-1], None, None
    if (
        isinstance(expr, RewardQuery)
        and expr.threshold is None
        and expr.objective.kind is RewardKind.REACH
    ):
        assert expr.objective.target is not None  # noqa: S101 - F has a target
        return "reward", None, expr.objective.target, None, expr
    raise UnsupportedError(
        "simulation estimates P=? [ F φ ], P=? [ a U b ], their step-bounded forms, and "
        "R=? [ F φ ]",
        expr.span,
        hint="write the property in one of these forms",
    )


def _step_bound(expr: Expr, scalar: ScalarEvaluator) -> int | None:
    if isinstance(expr, ProbQuery) and isinstance(expr.path, Temporal) and expr.path.bound:
        upper = expr.path.bound.upper
        if upper is not None:
            k = int(scalar(upper))
            return k - 1 if expr.path.bound.upper_strict else k
    return None


_BYTES_PER_RUN = 160
"""What one run holds at the peak of a step: its state, flags and reward (18 bytes) and the
step's temporaries over the active runs (indices, uniform numbers, rows, successors and the
row search's arrays: about 17 arrays of 8 bytes)."""


def _check_room(runs: int) -> None:
    """Refuse ``runs`` whose arrays would not fit in the memory available now
    (:func:`posgmc.resources.available_bytes`; nothing is refused where it cannot be read), before
    anything is allocated: numpy's MemoryError, or the kernel's OOM killer, otherwise.

    Raises:
        LimitError: with the memory needed and available, and the most runs that fit.
    """
    available = available_bytes()
    need = runs * _BYTES_PER_RUN
    if available is None or need <= 0.9 * available:
        return
    fit = int(0.9 * available // _BYTES_PER_RUN)
    raise LimitError(
        f"{runs} runs: simulating them together needs about {need / 1e9:.1f} GB, but "
        f"{available / 1e9:.1f} GB of memory is available",
        hint=f"simulate at most {fit} runs (--runs; the interval narrows with the square root of "
        "the runs)",
    )


def _sample_rows(csr_indptr: np.ndarray, cum: np.ndarray, indices: np.ndarray, rows: np.ndarray,
                 u: np.ndarray) -> np.ndarray:
    """A successor of each row, drawn by its probabilities (one uniform number each)."""
    start, end = csr_indptr[rows], csr_indptr[rows + 1]
    base = np.where(start > 0, cum[np.maximum(start - 1, 0)], 0.0)
    total = cum[end - 1] - base
    pos = np.searchsorted(cum, base + u * total, side="right")
    out: np.ndarray = indices[np.clip(pos, start, end - 1)]
    return out


def simulate(
    model: ExplicitModel,
    expr: Expr,
    strategies: Mapping[str, FiniteStateStrategy],
    *,
    text: str,
    coalition_of: CoalitionResolver,
    scalar: ScalarEvaluator,
    runs: int = 10_000,
    seed: int = 0,
    max_steps: int = 10_000,
    opponent: str = "uniform",
    trace: bool = False,
) -> Simulation:
    """Estimate a property of ``model`` under the given strategies by ``runs`` simulations.

    Args:
        model: the compiled model.
        expr: ``P=? [F φ]``, ``P=? [a U b]`` (optionally ``F<=k``/``U<=k``) or ``R=? [F φ]``.
        strategies: finite-state strategies by player name.
        text: the property as written (for the report).
        coalition_of, scalar: as for :class:`~posgmc.checking.property_checker.PropertyChecker`.
        runs, seed, max_steps: how many runs, the random seed, the longest run.
        opponent: "uniform" or "best" for players without a strategy.
        trace: also sample one path and return it step by step.

    Raises:
        UnsupportedError: another kind of property.
        StrategyError: a strategy does not fit the model or misses a reached rule.
    """
    if runs < 1 or max_steps < 0:
        raise UnsupportedError("runs must be at least 1 and max-steps non-negative")
    _check_room(runs)
    kind, remain_e, target_e, _, reward_q = _objective(expr)
    bound = _step_bound(expr, scalar)
    horizon = max_steps if bound is None else min(bound, max_steps)
    bound_strategies = [bind(model, f) for f in strategies.values()]
    prod: StrategyProduct = strategy_product(model, bound_strategies)
    pm = prod.model
    S = pm.num_states
    target = evaluate_states(model, target_e)[prod.state_of].astype(bool)
    remain = (np.ones(S, dtype=bool) if remain_e is None
              else evaluate_states(model, remain_e)[prod.state_of].astype(bool))
    # a run in a state that cannot reach the target any more has failed (graph search)
    alive = positive_reach(structure_of(pm), target, remain, existential=np.ones(S, dtype=bool))

    choice = _choices(pm, expr, opponent, coalition_of, scalar, S)
    counts = np.diff(pm.row_groups)
    T = pm.transitions
    cum = np.cumsum(T.data)
    rewards = None
    if reward_q is not None:
        rm = reward_structure(pm, reward_q)
        rewards = rm.choice_rewards(pm.row_groups)

    rng = np.random.default_rng(seed)
    start = prod.initial_map[0]
    cur = np.full(runs, start, dtype=np.int64)
    done = target[cur].copy()
    failed = (~remain[cur] | ~alive[cur]) & ~done
    total = np.zeros(runs)
    for _ in range(horizon):
        active = np.flatnonzero(~done & ~failed)
        if active.size == 0:
            break
        states = cur[active]
        u_choice, u_succ = rng.random(active.size), rng.random(active.size)
        rows = np.where(
            choice[states] >= 0,
            choice[states],
            pm.row_groups[states] + np.minimum((u_choice * counts[states]).astype(np.int64),
                                               counts[states] - 1),
        )
        if rewards is not None:
            total[active] += rewards[rows]
        nxt = _sample_rows(T.indptr, cum, T.indices, rows, u_succ)
        cur[active] = nxt
        done[active] = target[nxt]
        failed[active] = (~remain[nxt] | ~alive[nxt]) & ~target[nxt]
    if bound is not None and bound <= max_steps:
        # the formula's step bound is reached: a run that has not reached the target by then
        # has failed
        failed |= ~done
    undecided = int(np.count_nonzero(~done & ~failed))
    estimate: float | None
    if kind == "probability":
        successes = int(np.count_nonzero(done))
        lower, _ = wilson(successes, runs)
        _, upper = wilson(successes + undecided, runs)
        estimate = successes / runs if undecided == 0 else None
    else:
        # PRISM: the reward is infinite unless the target is reached surely
        if np.any(failed):
            estimate = lower = upper = math.inf
        else:
            mean = float(total.mean())
            half = Z95 * float(total.std(ddof=1)) / math.sqrt(runs) if runs > 1 else math.inf
            lower, upper = mean - half, mean + half
            estimate = mean
            if undecided:
                # an undecided run's reward is unknown: the collected part bounds it from below
                # when no reward is negative; nothing bounds it from above
                assert rewards is not None  # noqa: S101 - a reward query
                estimate, upper = None, math.inf
                if np.any(rewards < 0):
                    lower = -math.inf
    path = (
        _trace(model, prod, choice, target, remain, alive, horizon, rng, bound_strategies)
        if trace
        else ()
    )
    return Simulation(text, kind, estimate, lower, upper, runs, undecided, seed, path)


def _choices(
    pm: ExplicitModel,
    expr: Expr,
    opponent: str,
    coalition_of: CoalitionResolver,
    scalar: ScalarEvaluator,
    S: int,
) -> np.ndarray:
    """int64[S]: the product row each state plays (-1: uniform among its rows)."""
    if opponent == "uniform":
        return np.full(S, -1, dtype=np.int64)
    if opponent != "best":
        raise UnsupportedError(f"unknown opponent {opponent!r}: use uniform or best")
    if not isinstance(expr, (ProbQuery, RewardQuery)):  # (_objective accepts only these)
        raise UnsupportedError("the best opponent is defined for P and R queries", expr.span)
    checker = PropertyChecker(pm, coalition_of=coalition_of, scalar=scalar,
                              options=CheckOptions(keep_strategy=True))
    bare: ProbQuery | RewardQuery = expr
    if isinstance(expr, ProbQuery) and isinstance(expr.path, Temporal) and expr.path.bound:
        # step-bounded optima need a step counter: play the unbounded optimum instead
        from dataclasses import replace

        bare = replace(expr, path=replace(expr.path, bound=None))
    q = checker.query(bare)
    strategy = q.engine.strategy if q.engine is not None else None
    return (
        np.asarray(strategy, dtype=np.int64) if strategy is not None else np.full(S, -1, np.int64)
    )


def _trace(
    model: ExplicitModel,
    prod: StrategyProduct,
    choice: np.ndarray,
    target: np.ndarray,
    remain: np.ndarray,
    alive: np.ndarray,
    horizon: int,
    rng: np.random.Generator,
    bound_strategies: Sequence[BoundStrategy],
) -> tuple[TraceStep, ...]:
    """One path, sampled step by step with explicit actions (a loop over the path's steps)."""
    pm = prod.model
    by_player = {b.player: b for b in bound_strategies}
    names = model.player_names or ("",)
    steps: list[TraceStep] = []
    p = int(prod.initial_map[0])
    for k in range(horizon + 1):
        s = int(prod.state_of[p])
        owner = int(model.state_players[s]) if model.player_names else 0
        obs = tuple(
            (names[o.player] or "agent",
             ", ".join(f"{n}={v}" for n, v in zip(o.names, o.values[o.state_ids[s]].tolist()))
             if o.names else str(int(o.state_ids[s])))
            for o in model.observations
        )
        memory = tuple((b.view.name or "agent", int(prod.memory_of[p, i]))
                       for i, b in enumerate(prod.strategies))
        if target[p] or not remain[p] or not alive[p] or k == horizon:
            steps.append(TraceStep(k, names[owner], model.describe_state(s), obs, memory, "-"))
            break
        rows = range(int(pm.row_groups[p]), int(pm.row_groups[p + 1]))
        if owner in by_player:
            b = by_player[owner]
            i = list(prod.strategies).index(b)
            n = int(prod.memory_of[p, i])
            mrows = np.arange(int(model.row_groups[s]), int(model.row_groups[s + 1]))
            w = b.action_probability(model, np.full(mrows.size, n), mrows)
            c = int(mrows[rng.choice(mrows.size, p=w / w.sum())])
            nodes, d = b.update_distribution(model, n, c)
            n2 = int(nodes[rng.choice(d.size, p=d / d.sum())])
            row = model.transitions.getrow(c)
            s2 = int(row.indices[rng.choice(row.nnz, p=row.data / row.data.sum())])
            action = model.action_names[model.choice_actions[c]] or "(unlabelled)"
            mem = prod.memory_of[p].copy()
            mem[i] = n2
            cand = np.flatnonzero((prod.state_of == s2) & np.all(prod.memory_of == mem, axis=1))
            p_next = int(cand[0])
        else:
            r = int(choice[p]) if choice[p] >= 0 else int(rng.choice(list(rows)))
            row = pm.transitions.getrow(r)
            p_next = int(row.indices[rng.choice(row.nnz, p=row.data / row.data.sum())])
            action = pm.action_names[pm.choice_actions[r]] or "(unlabelled)"
        steps.append(TraceStep(k, names[owner], model.describe_state(s), obs, memory, action))
        p = p_next
    return tuple(steps)
