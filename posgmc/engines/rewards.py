"""Expected reward until a target, ``R[F target]`` and its variants ``Fc`` and ``F0``
(:class:`ReachRewardMode`), including rewards of mixed sign.

Rewards are per choice (state reward + action reward, :meth:`RewardModel.choice_rewards`) and must
be non-negative (PRISM's rule), except ``R[F]``/``R[Fc]`` when every strategy profile reaches the
target almost surely (see :mod:`posgmc.engines.signed`). Reach rewards follow PRISM: the reward of
a target state is not collected (the target is absorbing for the computation). The value is
infinite exactly where the minimiser cannot force reaching the target almost surely (graph
analysis); the rest is solved as a :class:`~posgmc.engines.system.System`. ``Fc`` with
non-negative rewards is the total reward until the target (:mod:`posgmc.engines.total`); ``F0`` is
in :mod:`posgmc.engines.zero_reward`.
"""

from __future__ import annotations

import enum
import time
from dataclasses import replace

import numpy as np

from posgmc.engines.graph import (
    Structure,
    almost_sure_reach,
    attractor,
    positive_buchi,
    structure_of,
)
from posgmc.engines.iteration import Bounds, EndComponents
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.signed import proper_region, solve_proper, start_bounds, value_iteration
from posgmc.engines.solving import (
    Solved,
    bool_mask,
    check_rewards,
    directions_of,
    engine_result,
    first_choices,
    local_rows,
    reacher_fix,
    solve_system,
    state_text,
    unsafe_states,
)
from posgmc.engines.system import System, build_system, choose
from posgmc.engines.total import _total
from posgmc.engines.zero_reward import _reach_reward_zero
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["ReachRewardMode", "expected_reach_reward"]


class ReachRewardMode(enum.Enum):
    """What a path that never reaches the target collects (PRISM-games' three semantics)."""

    INFINITY = "F"  # infinite, so the value is infinite unless the target is reached almost surely
    ZERO = "F0"  # nothing
    CUMULATIVE = "Fc"  # what it collects along the way (possibly infinite)


def expected_reach_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    target: np.ndarray,
    *,
    maximize: np.ndarray,
    mode: ReachRewardMode = ReachRewardMode.INFINITY,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """Expected reward collected until ``target`` (``R[F target]`` and its variants).

    Rewards of mixed sign (``ReachRewardMode.INFINITY``, PRISM's ``R[F ...]``):

    * the value is +inf exactly where the player who minimises cannot force reaching the target
      almost surely (PRISM's rule; graph analysis, independent of the reward signs);
    * on the other states, if no usable choice there has a negative reward, the non-negative
      algorithm runs unchanged;
    * otherwise negative rewards are supported when *every* strategy profile reaches the target
      almost surely from every state of finite value: the problem is then a stochastic shortest path
      problem whose policies are all proper, the Bellman operator is monotone and a contraction (in
      a weighted sup norm) with a unique fixpoint, the value. Interval iteration starts from proven
      bounds ``-max E[total r-] <= value <= max E[total r+]`` (``r = r+ - r-``, both maxima solved
      soundly as non-negative problems) and iterates both (see :mod:`posgmc.engines.signed`);
      ``Method.EXACT``/``POLICY`` use policy iteration, ``Method.VALUE`` value iteration from 0;
    * if instead some profile can avoid the target with positive probability from a state of finite
      value (an end component the play can stay in), the value may be -inf or undefined: this is
      rejected with UnsupportedError.

    ``ReachRewardMode.CUMULATIVE`` (``Fc``) with a negative reward outside the target is supported
    only when every profile reaches the target almost surely from *every* state (then it equals
    ``F``); ``ReachRewardMode.ZERO`` (``F0``) needs non-negative rewards (PRISM-games).

    Args:
        model: a dtmc, mdp or smg.
        rewards: float64[C], reward per choice (state + action reward), any sign (see above).
        target: bool[S]; rewards in target states are not collected.
        maximize: bool[S], True where the state's owner maximises the reward.
        mode: what paths that never reach the target collect, see :class:`ReachRewardMode`.
        options: solver options.

    Returns:
        The :class:`EngineResult`; infinite values are exact (graph analysis), finite ones have
        proven bounds. ``ReachRewardMode.ZERO`` on an mdp or smg returns no strategy (optimal
        strategies must count the collected reward). With negative rewards the strategy is the
        optimal choice per state for the converged bounds (every strategy reaches the target).

    Raises:
        UnsupportedError: negative rewards where some strategy profile may not reach the target
            almost surely (see above), or with ``ReachRewardMode.ZERO``;
            ``ReachRewardMode.ZERO`` on an mdp or smg with non-integer rewards (as in PRISM-games)
            or with unbounded rewards before the target.
    """
    tgt = bool_mask(target, model.num_states, False)
    if mode is ReachRewardMode.ZERO:
        r = check_rewards(
            model,
            rewards,
            nonnegative=True,
            objective="R[F0 ...] (as in PRISM-games)",
            hint="use R[F ...]: it accepts negative rewards when every strategy reaches the target "
            "with probability 1",
        )
        return _reach_reward_zero(model, r, tgt, directions_of(model, maximize), options)
    r = check_rewards(model, rewards, nonnegative=False)
    mx = directions_of(model, maximize)
    if mode is ReachRewardMode.CUMULATIVE:
        if np.any((r < 0) & ~tgt[structure_of(model).choice_state]):
            return _reach_reward_cumulative_signed(model, r, tgt, mx, options)
        return _total(model, r, tgt, mx, options)
    return _reach_reward_infinity(model, r, tgt, mx, options)


def _reach_reward_infinity(
    model: ExplicitModel, r: np.ndarray, tgt: np.ndarray, mx: np.ndarray, options: SolverOptions
) -> EngineResult:
    started = time.perf_counter()
    S = model.num_states
    g = structure_of(model)
    everywhere = np.ones(S, dtype=bool)
    dtmc = model.model_type is ModelType.DTMC
    reacher = ~mx if not dtmc else np.ones(S, dtype=bool)
    # finite exactly where the minimiser reaches the target almost surely against everything
    finite, finite_witness = almost_sure_reach(g, tgt, everywhere, existential=reacher)
    infinite = ~finite
    unknown = finite & ~tgt
    known_values = np.where(infinite, np.inf, 0.0)
    allowed = ~unsafe_states(g, finite)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(
            g, unknown, maximize=mx, allowed=allowed, choice_offset=r, topological=True
        )
        has_min = sys.num_max < sys.n and not dtmc
        if sys.offset.min(initial=0.0) < 0:
            # a usable choice has a negative reward (the offsets are the usable choices' rewards)
            solved = _solve_signed(
                model,
                g,
                sys,
                r,
                tgt,
                finite=finite,
                allowed=allowed,
                options=options,
                initial_rows=local_rows(sys, finite_witness),
            )
        else:
            solved = solve_system(
                sys,
                options,
                cap=np.inf,
                ec=EndComponents.INFLATE if has_min else EndComponents.NONE,
                num_choices=model.num_choices,
                outer_max=False,
                idle_min=False,
                initial_rows=local_rows(sys, finite_witness),
                is_chain=dtmc,
            )
    strategy = None
    if options.want_strategy:
        strategy = first_choices(model)
        if not dtmc:
            w = finite & reacher & (finite_witness >= 0)
            strategy[w] = finite_witness[w]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                reacher_fix(g, strategy, solved, sys, goal=tgt, goal_choices=None, reacher=reacher)
            if (infinite & mx).any():
                # the maximiser keeps away from the target with positive probability: a positive
                # Büchi strategy for "any choice outside the target" (target absorbing)
                _, keep_away = positive_buchi(g, ~tgt[g.choice_state], ~tgt, existential=mx)
                w = infinite & mx & (keep_away >= 0)
                strategy[w] = keep_away[w]
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


def _solve_signed(
    model: ExplicitModel,
    g: Structure,
    sys: System,
    r: np.ndarray,
    tgt: np.ndarray,
    *,
    finite: np.ndarray,
    allowed: np.ndarray,
    options: SolverOptions,
    initial_rows: np.ndarray,
) -> Solved:
    """``R[F tgt]`` on ``sys`` (the finite, non-target states) when a usable choice has a negative
    reward: supported when every strategy profile over the usable choices reaches the target almost
    surely (a stochastic shortest path problem whose policies are all proper, see
    :mod:`posgmc.engines.signed`), rejected otherwise."""
    S = model.num_states
    unknown = np.zeros(S, dtype=bool)
    unknown[sys.states] = True
    improper = unknown & ~proper_region(g, tgt, finite, allowed=allowed)
    if improper.any():
        raise _improper_error(
            model,
            g,
            r,
            improper,
            negative=(r < 0) & allowed & unknown[g.choice_state],
            allowed=allowed,
            objective="R[F ...]",
            scope="from every state where the value is finite",
        )
    if options.method in (Method.EXACT, Method.POLICY):
        # every policy is proper: policy evaluation is a non-singular linear solve and strict
        # improvements terminate at the optimum, whatever the reward signs
        return solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=False,
            idle_min=False,
            initial_rows=initial_rows,
            is_chain=model.model_type is ModelType.DTMC,
            interval=lambda: _proper_bounds(g, unknown, r, allowed, sys, options),
        )
    if options.method is Method.VALUE:
        bounds = value_iteration(sys, options)
    else:
        bounds = _proper_bounds(g, unknown, r, allowed, sys, options)
    best_rows = None
    candidates = None
    if options.want_strategy:
        # all policies are proper, so the greedy choice needs no attractor fix
        best, cand = choose(sys, bounds.lower, bounds.upper)
        best_rows = sys.rows[best]
        candidates = np.zeros(model.num_choices, dtype=bool)
        candidates[sys.rows[cand]] = True
    return Solved(
        bounds.lower,
        bounds.upper,
        bounds.iterations,
        bounds.converged,
        bounds.sound,
        best_rows,
        candidates,
        needs_fix=False,
    )


def _reach_reward_cumulative_signed(
    model: ExplicitModel, r: np.ndarray, tgt: np.ndarray, mx: np.ndarray, options: SolverOptions
) -> EngineResult:
    """``R[Fc tgt]`` with a negative reward outside the target: when every strategy profile reaches
    the target almost surely from every state, nothing is collected after "never reaching", so
    ``Fc`` equals ``F`` (solved by :func:`_reach_reward_infinity`); otherwise rejected."""
    g = structure_of(model)
    S = model.num_states
    everywhere = np.ones(S, dtype=bool)
    improper = ~proper_region(g, tgt, everywhere, allowed=None)
    if improper.any():
        raise _improper_error(
            model,
            g,
            r,
            improper,
            negative=(r < 0) & ~tgt[g.choice_state],
            allowed=None,
            objective="R[Fc ...]",
            scope="from every state (then it equals R[F ...])",
        )
    return _reach_reward_infinity(model, r, tgt, mx, options)


def _improper_error(
    model: ExplicitModel,
    g: Structure,
    r: np.ndarray,
    improper: np.ndarray,
    *,
    negative: np.ndarray,
    allowed: np.ndarray | None,
    objective: str,
    scope: str,
) -> UnsupportedError:
    """The error for negative rewards where some profile avoids the target with positive
    probability: it names a negative reward and a state where the target can be avoided (one that
    can also reach a negative reward if there is one)."""
    S = model.num_states
    c = int(np.flatnonzero(negative)[0])
    exposed, _ = attractor(
        g,
        np.zeros(S, dtype=bool),
        existential=np.ones(S, dtype=bool),
        candidates=improper,
        allowed=allowed,
        initial_choices=negative,
    )
    culprits = improper & exposed
    s = int(np.flatnonzero(culprits if culprits.any() else improper)[0])
    why = (
        ", where negative rewards can make the expected reward -infinity or undefined"
        if culprits.any()
        else ""
    )
    return UnsupportedError(
        f"{objective} with negative rewards (e.g. {r[c]:g} in "
        f"{state_text(model, int(g.choice_state[c]))}) is only supported when every strategy "
        f"profile reaches the target with probability 1 {scope}; from {state_text(model, s)} "
        "some profile avoids the target with positive probability (it can stay in an end "
        f"component forever){why}",
        hint="make the target reachable with probability 1 under every strategy (no end "
        "component outside the target), keep the rewards non-negative, or use a discounted "
        "reward (R[Fdiscount=g ...])",
    )


def _proper_bounds(
    g: Structure,
    unknown: np.ndarray,
    r: np.ndarray,
    allowed: np.ndarray,
    sys: System,
    options: SolverOptions,
) -> Bounds:
    """Proven bounds of a system whose policies are all proper (:mod:`posgmc.engines.signed`):
    value iteration between the sound start bounds."""
    lower0, upper0, aux_iterations = start_bounds(g, unknown, r, allowed=allowed, options=options)
    options = replace(options, method=Method.INTERVAL)
    bounds = solve_proper(sys, options, lower=lower0[sys.states], upper=upper0[sys.states])
    return replace(bounds, iterations=bounds.iterations + aux_iterations)
