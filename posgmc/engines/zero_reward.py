"""``R[F0 target]``: the reward collected until the target, counted only on paths that reach it
(PRISM-games' ``F0``), i.e. ``E[reward until target * 1(target reached)]``.

For a dtmc a linear system weighted by the reach probability; for an mdp or smg the level-by-level
"rich man's" construction of PRISM-games (Chen et al.), which needs integer, non-negative rewards
and returns no strategy (optimal strategies must count the collected reward). Reached through
:func:`posgmc.engines.rewards.expected_reach_reward` with ``ReachRewardMode.ZERO``.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from posgmc.engines.graph import structure_of
from posgmc.engines.iteration import EndComponents, solve
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.reach import reach_probability
from posgmc.engines.result import EngineResult
from posgmc.engines.solving import exact_result, first_choices, solve_system
from posgmc.engines.system import build_system
from posgmc.engines.total import _total
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.model.types import ModelType

__all__: list[str] = []


def _reach_reward_zero(
    model: ExplicitModel, r: np.ndarray, tgt: np.ndarray, mx: np.ndarray, options: SolverOptions
) -> EngineResult:
    """``R[F0 target]`` = E[reward until target * 1(target reached)], for a dtmc:
    ``x = r * p + A x`` on the states with reach probability ``p > 0``."""
    if model.model_type is not ModelType.DTMC:
        return _reach_reward_zero_nondet(model, r, tgt, mx, options)
    started = time.perf_counter()
    S = model.num_states
    prob = reach_probability(model, tgt, maximize=mx, options=options)
    p_lo, p_hi = prob.lower, prob.upper
    g = structure_of(model)
    unknown = (p_hi > 0) & ~tgt
    if not unknown.any():
        return exact_result(np.zeros(S), prob.iterations, options.method, started)
    # bounds on r * p give bounds on the (linear, monotone) solution
    sys_lo = build_system(g, unknown, maximize=mx, choice_offset=r * p_lo[g.choice_state])
    sys_hi = build_system(g, unknown, maximize=mx, choice_offset=r * p_hi[g.choice_state])
    a = solve_system(
        sys_lo,
        options,
        cap=np.inf,
        ec=EndComponents.NONE,
        num_choices=model.num_choices,
        outer_max=True,
        idle_min=True,
        is_chain=True,
    )
    b = solve_system(
        sys_hi,
        options,
        cap=np.inf,
        ec=EndComponents.NONE,
        num_choices=model.num_choices,
        outer_max=True,
        idle_min=True,
        is_chain=True,
    )
    lower = np.zeros(S)
    upper = np.zeros(S)
    lower[sys_lo.states] = a.lower
    upper[sys_hi.states] = b.upper
    values = 0.5 * (lower + upper) if options.method is not Method.VALUE else lower.copy()
    return EngineResult(
        values=values,
        lower=lower,
        upper=upper,
        iterations=prob.iterations + a.iterations + b.iterations,
        converged=prob.converged and a.converged and b.converged,
        method=options.method,
        seconds=time.perf_counter() - started,
        sound=options.method is not Method.VALUE,
        strategy=first_choices(model) if options.want_strategy else None,
    )


def _reach_reward_zero_nondet(
    model: ExplicitModel,
    r: np.ndarray,
    tgt: np.ndarray,
    mx: np.ndarray,
    options: SolverOptions,
    *,
    extra_levels: int = 0,
) -> EngineResult:
    """``R[F0 target]`` on an mdp or smg, following PRISM-games (Chen et al.): with integer rewards,
    the value of state s after collecting ``a`` is ``W(s, a) = opt E[(a + R) * 1(reach)]``.

    For large ``a`` probability dominates: the "rich man's" strategies first optimise the reach
    probability P, then the reward weighted by it, ``Q = opt over P-optimal choices of
    E[sum_t r_t P(s_t)]``, and ``W(s, a) = a P(s) + Q(s)`` for ``a >= B``, B the largest level at
    which a one-step deviation from a P-optimal choice still pays. Below B the levels are solved
    from ``B - 1`` down to 0: a choice with reward k > 0 reads level ``a + k``, a zero-reward choice
    the level itself (a least-fixpoint problem solved with bounds, the higher levels' bounds giving
    the row constants). P and Q are computed exactly (policy iteration). The optimal strategies need
    the collected reward as memory, so no strategy is returned.
    """
    started = time.perf_counter()
    if not np.all(r == np.round(r)):
        raise UnsupportedError(
            "R[F0 ...] on an mdp or smg needs integer rewards (as in PRISM-games)",
            hint="scale the rewards to integers, or use R[F ...] or R[Fc ...]",
        )
    S = model.num_states
    g = structure_of(model)
    cs = g.choice_state
    T = model.transitions
    exact = replace(options, method=Method.EXACT, want_strategy=False)
    P = reach_probability(model, tgt, maximize=mx, options=exact).values
    Pc = np.asarray(T @ P).ravel()
    # the probability-optimal choices ("the rich man's")
    optimal = (np.abs(Pc - P[cs]) <= 1e-9) | tgt[cs]
    missing = np.bincount(cs[optimal], minlength=S) == 0
    optimal |= missing[cs]  # (only by rounding) keep every choice of such a state
    rows = np.flatnonzero(optimal)
    counts = np.bincount(cs[rows], minlength=S)
    sub = make_model(
        model.model_type,
        np.concatenate([[0], np.cumsum(counts)]),
        T[rows],
        state_players=model.state_players,
        player_names=model.player_names,
    )
    Q = _total(sub, r[rows] * P[cs[rows]], tgt, mx, exact).values
    live = ~tgt & (P > 0)
    if np.any(np.isinf(Q[live])):
        raise UnsupportedError(
            "R[F0 ...]: the reward collected before reaching the target is unbounded here",
            hint="use R[Fc ...] (it is infinite as well)",
        )
    Q = np.where(live, Q, 0.0)
    Qc = np.asarray(T @ Q).ravel()
    # the last level where deviating from the rich man's choice pays, over all one-step deviations
    dev = live[cs] & ~optimal
    with np.errstate(divide="ignore", invalid="ignore"):
        # deviating to c at level a pays iff a P_c + r P_c + Q_c beats a P + Q (max: >, min: <)
        gain = (r * Pc + Qc - Q[cs]) / (P[cs] - Pc)
    B = int(np.ceil(np.max(gain[dev], initial=0.0))) + 1 if dev.any() else 0
    B = max(B, 0) + extra_levels  # extra levels: tests check that B is large enough

    def rich(level: int) -> np.ndarray:
        return np.where(tgt, float(level), level * P + Q)

    lower = rich(0)
    upper = lower.copy()
    iterations = 0
    converged = True
    if B > 0 and live.any():
        base = build_system(g, live, maximize=mx)
        rew = r[base.rows].astype(np.int64)
        zero_rows = rew == 0
        keep = sp.diags(zero_rows.astype(np.float64)) @ base.matrix
        keep = sp.csr_matrix(keep)
        keep.eliminate_zeros()
        level_sys = replace(base, matrix=keep, stays=base.stays & zero_rows)
        T_rows = T[base.rows]
        # bounds of the levels a .. a + max reward, newest first
        kmax = int(rew.max(initial=0))
        window_lo: dict[int, np.ndarray] = {B + k: rich(B + k) for k in range(kmax + 1)}
        window_hi = {a: v.copy() for a, v in window_lo.items()}
        for a in range(B - 1, -1, -1):
            bounds = []
            for window in (window_lo, window_hi):
                known = np.where(tgt, float(a), 0.0)
                offset = np.asarray(T_rows @ known).ravel()
                for k in np.unique(rew[~zero_rows]):
                    sel = rew == k
                    offset[sel] = np.asarray(
                        T_rows[np.flatnonzero(sel)] @ window[a + int(k)]
                    ).ravel()
                b = solve(
                    replace(level_sys, offset=offset), options, cap=np.inf, ec=EndComponents.DEFLATE
                )
                iterations += b.iterations
                converged &= b.converged
                bounds.append(b)
            lo = np.where(tgt, float(a), 0.0)
            hi = lo.copy()
            lo[base.states] = bounds[0].lower
            hi[base.states] = bounds[1].upper
            window_lo[a], window_hi[a] = lo, hi
            window_lo.pop(a + kmax + 1, None)
            window_hi.pop(a + kmax + 1, None)
        lower, upper = window_lo[0], window_hi[0]
    values = lower.copy() if options.method is Method.VALUE else 0.5 * (lower + upper)
    return EngineResult(
        values=values,
        lower=lower,
        upper=upper,
        iterations=iterations,
        converged=converged,
        method=options.method,
        seconds=time.perf_counter() - started,
        sound=options.method is not Method.VALUE,
        strategy=None,
    )
