"""Expected total reward ``R[C]`` and the non-negative total reward until a target (``R[Fc]``).

Graph precomputation settles the infinite values (the maximiser collects rewards infinitely often
with positive probability: positive Büchi) and the zeros (the minimiser avoids every reward
forever: a safe region) exactly; the rest is a :class:`~posgmc.engines.system.System` with
end-component deflation. Rewards must be non-negative here (PRISM's rule); reach rewards of mixed
sign are in :mod:`posgmc.engines.rewards`.
"""

from __future__ import annotations

import time

import numpy as np

from posgmc.engines.graph import almost_sure_reach, positive_buchi, safe_region, structure_of
from posgmc.engines.iteration import EndComponents
from posgmc.engines.options import SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.solving import (
    check_rewards,
    directions_of,
    engine_result,
    first_choices,
    local_rows,
    reacher_fix,
    solve_system,
    unsafe_states,
)
from posgmc.engines.system import build_system
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["total_reward"]


def total_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """Expected total reward ``R[C]`` (possibly infinite).

    Args:
        model: a dtmc, mdp or smg.
        rewards: float64[C], non-negative.
        maximize: bool[S].
        options: solver options.

    Returns:
        The :class:`EngineResult`: infinite exactly where the maximiser can collect rewards
        infinitely often with positive probability (graph analysis), 0 exactly where the minimiser
        avoids every reward forever, bounds elsewhere.
    """
    r = check_rewards(
        model,
        rewards,
        nonnegative=True,
        objective="the expected total reward R[C]",
        hint="without a target, rewards of mixed sign can sum to -infinity or have no expected "
        "value; use R[Cdiscount=g], R[C<=k], or R[F target] with a target every strategy "
        "reaches with probability 1",
    )
    return _total(
        model, r, np.zeros(model.num_states, dtype=bool), directions_of(model, maximize), options
    )


def _total(
    model: ExplicitModel, r: np.ndarray, tgt: np.ndarray, mx: np.ndarray, options: SolverOptions
) -> EngineResult:
    """Total reward until ``tgt`` (absorbing, nothing collected there); ``tgt`` empty: ``R[C]``."""
    started = time.perf_counter()
    S = model.num_states
    g = structure_of(model)
    dtmc = model.model_type is ModelType.DTMC
    spoiler = mx if not dtmc else np.ones(S, dtype=bool)
    good = (r > 0) & ~tgt[g.choice_state]
    # infinite exactly where the maximiser collects rewards infinitely often with positive
    # probability
    infinite, infinite_witness = positive_buchi(g, good, ~tgt, existential=spoiler)
    finite = ~infinite
    # zero exactly where the minimiser avoids every reward forever
    zero, zero_choice = safe_region(g, finite & ~tgt, existential=~spoiler, good=~good, frozen=tgt)
    unknown = finite & ~zero & ~tgt
    known_values = np.where(infinite, np.inf, 0.0)
    allowed = ~unsafe_states(g, finite)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(g, unknown, maximize=mx, allowed=allowed, choice_offset=r)
        reach_zero, zero_witness = almost_sure_reach(g, zero | tgt, finite, existential=~spoiler)
        solved = solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.DEFLATE if not dtmc else EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=True,
            unbounded=True,
            initial_rows=local_rows(sys, np.where(reach_zero, zero_witness, -1)),
            is_chain=dtmc,
        )
    strategy = None
    if options.want_strategy:
        strategy = first_choices(model)
        if not dtmc:
            z = zero & ~spoiler & (zero_choice >= 0)
            strategy[z] = zero_choice[z]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                # the maximiser must not idle in a zero-reward end component it could leave
                reacher_fix(
                    g, strategy, solved, sys, goal=zero | tgt, goal_choices=good, reacher=spoiler
                )
            w = infinite & spoiler & (infinite_witness >= 0)
            strategy[w] = infinite_witness[w]
        strategy[tgt] = -1
    return engine_result(
        model,
        ~unknown,
        known_values,
        sys,
        solved,
        method=options.method,
        started=started,
        strategy=strategy,
    )
