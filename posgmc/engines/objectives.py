"""The objectives posgmc computes on fully observable models (dtmc, mdp, turn-based smg).

Every function takes the optimisation direction per state (``maximize``: bool[S], True where the
state's owner maximises the quantity; see :func:`maximize_mask`) and returns an
:class:`~posgmc.engines.result.EngineResult` for every state. The pattern is always the same:

1. graph precomputation settles the states with a qualitative answer exactly (probability 0 or 1,
   reward 0 or infinite; for games the attractor-based versions, see :mod:`posgmc.engines.graph`);
2. the rest becomes a :class:`~posgmc.engines.iteration.System` solved by sound interval iteration
   (default), plain value iteration, or policy iteration / direct solves;
3. a memoryless strategy is extracted; where the player who wants the target reached has end
   components, its choices are fixed by an attractor towards the target among its (near-)optimal
   choices, so that the strategy really reaches the target.

Step-bounded objectives (``U<=k``, ``X``, ``C<=k``, ``I=k``) are exact up to floating point: k
Bellman steps. Discounted objectives get sound bounds from the contraction factor.

Rewards are per choice (state reward + action reward, :meth:`RewardModel.choice_rewards`) and must
be non-negative for the undiscounted objectives (PRISM's rule), except ``R[F]``/``R[Fc]`` when
every strategy profile reaches the target almost surely (see :mod:`posgmc.engines.signed`). Reach
rewards follow PRISM: the reward of a target state is not collected (the target is absorbing for the computation).
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, replace
import numpy as np
import scipy.sparse as sp
from posgmc.engines import exact as ex
from posgmc.engines.graph import (
    Structure,
    almost_sure_reach,
    attractor,
    positive_buchi,
    positive_reach,
    safe_region,
    structure_of,
)
from posgmc.engines.iteration import (
    Bounds,
    EndComponents,
    System,
    argopt_rows,
    bellman,
    build_system,
    choose,
    reduce_rows,
    solve,
    solve_discounted,
)
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.rational import exact_rational_reach
from posgmc.engines.signed import proper_region, solve_proper, start_bounds, value_iteration
from posgmc.engines.result import EngineResult
from posgmc.errors import PosgmcError, UnsupportedError
from posgmc.model.explicit import ExplicitModel, make_model
from posgmc.syntax.ast import Direction, ModelType

__all__ = [
    "ReachRewardMode",
    "maximize_mask",
    "reach_probability",
    "bounded_reach_probability",
    "next_probability",
    "expected_reach_reward",
    "cumulative_reward",
    "instantaneous_reward",
    "total_reward",
    "discounted_total_reward",
    "discounted_reach_reward",
    "induced_chain",
    "exact_rational_reach",
]


class ReachRewardMode(enum.Enum):
    """What a path that never reaches the target collects (PRISM-games' three semantics)."""

    INFINITY = "F"  # infinite, so the value is infinite unless the target is reached almost surely
    ZERO = "F0"  # nothing
    CUMULATIVE = "Fc"  # what it collects along the way (possibly infinite)


def maximize_mask(
    model: ExplicitModel, *, direction: Direction, coalition: frozenset[int] | None
) -> np.ndarray:
    """bool[S]: which states maximise.

    Args:
        model: the model.
        direction: the query's direction (``Pmax``/``Rmax`` -> MAX).
        coalition: for a game, the 0-based indices of the players in ``<<C>>``; they optimise in
            ``direction``, all other players in the opposite one. None: every player is in it.

    Returns:
        bool[S] (for a dtmc the direction is irrelevant; the mask is still filled).
    """
    S = model.num_states
    want_max = direction is Direction.MAX
    if coalition is None or not model.model_type.is_game:
        return np.full(S, want_max, dtype=bool)
    members = np.zeros(
        max(len(model.player_names), int(model.state_players.max(initial=0)) + 1), dtype=bool
    )
    for p in coalition:
        if 0 <= p < members.size:
            members[p] = True
    in_coalition = members[model.state_players]
    return np.where(in_coalition, want_max, not want_max)


# ---------------------------------------------------------------------------------------------
# shared helpers
# ---------------------------------------------------------------------------------------------


def _bool(a: np.ndarray | None, S: int, default: bool) -> np.ndarray:
    if a is None:
        return np.full(S, default, dtype=bool)
    out = np.asarray(a, dtype=bool)
    if out.shape != (S,):
        raise PosgmcError(f"expected a boolean state vector of length {S}, got shape {out.shape}")
    return out


def _directions(model: ExplicitModel, maximize: np.ndarray) -> np.ndarray:
    mx = np.asarray(maximize, dtype=bool)
    if mx.shape != (model.num_states,):
        raise PosgmcError(
            f"maximize needs one entry per state ({model.num_states}), got {mx.shape}"
        )
    if model.model_type is ModelType.DTMC:
        return np.ones(model.num_states, dtype=bool)
    return mx


def _check_rewards(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    nonnegative: bool,
    objective: str = "this objective",
    hint: str = "PRISM requires non-negative rewards for expected-reward properties",
) -> np.ndarray:
    """float64[C]: the rewards, checked (one finite entry per choice; ``nonnegative``: none < 0,
    else UnsupportedError naming ``objective``, with ``hint``)."""
    r = np.asarray(rewards, dtype=np.float64)
    if r.shape != (model.num_choices,):
        raise PosgmcError(f"rewards need one entry per choice ({model.num_choices}), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise PosgmcError("rewards must be finite")
    if nonnegative and r.size and r.min() < 0:
        c = int(np.flatnonzero(r < 0)[0])
        where = _state_text(model, int(np.searchsorted(model.row_groups, c, side="right") - 1))
        raise UnsupportedError(
            f"negative rewards are not supported for {objective} (e.g. {r[c]:g} in {where})",
            hint=hint,
        )
    return r


def _first_choices(model: ExplicitModel) -> np.ndarray:
    return model.row_groups[:-1].astype(np.int64).copy()


def _any_choice_avoiding(g: Structure, avoid: np.ndarray, states: np.ndarray) -> np.ndarray:
    """int64[S]: for each state in ``states`` a choice with no edge into ``avoid`` (-1 if none)."""
    hits = np.asarray(g.transitions @ avoid.astype(np.float64)) > 0
    out = np.full(g.num_states, -1, dtype=np.int64)
    idx = np.flatnonzero(~hits & states[g.choice_state])
    out[g.choice_state[idx[::-1]]] = idx[::-1]  # the first such choice wins
    return out


@dataclass(frozen=True)
class _Solved:
    """The outcome on the unknown states (global vectors filled by the caller)."""

    lower: np.ndarray
    upper: np.ndarray
    iterations: int
    converged: bool
    sound: bool
    best_rows: np.ndarray | None  # int64[n] global choices
    candidates: np.ndarray | None  # bool[C] global choices that are not provably suboptimal
    needs_fix: bool = False  # the reacher has end components: the attractor fix is required


def _solve_system(
    sys: System,
    options: SolverOptions,
    *,
    cap: float,
    ec: EndComponents,
    num_choices: int,
    outer_max: bool,
    idle_min: bool,
    unbounded: bool = False,
    initial_rows: np.ndarray | None = None,
    is_chain: bool = False,
) -> _Solved:
    """Dispatch on the method (see :mod:`posgmc.engines.iteration`, :mod:`posgmc.engines.exact`)."""
    n = sys.n
    if n == 0:
        z = np.zeros(0)
        return _Solved(
            z, z.copy(), 0, True, options.method is not Method.VALUE, np.zeros(0, np.int64), None
        )
    if options.method in (Method.EXACT, Method.POLICY):
        gr = ex.grouped(sys)
        if initial_rows is None:
            start = gr.row_groups[:-1].copy()
        else:
            # map System rows (local) to grouped rows
            inv = np.empty(gr.source.size, dtype=np.int64)
            inv[gr.source] = np.arange(gr.source.size)
            start = inv[initial_rows]
        if is_chain:
            x = ex.evaluate(gr, start)
            rows = start
            rounds = 1
        else:
            x, rows, rounds = ex.policy_iteration(
                gr,
                start,
                outer_max=outer_max,
                idle_min=idle_min,
                unbounded=unbounded,
                max_rounds=options.max_iterations,
            )
        best = sys.rows[gr.source[rows]]
        cand = np.zeros(num_choices, dtype=bool)
        cand[best] = True
        return _Solved(x, x.copy(), rounds, True, True, best, cand)
    bounds: Bounds = solve(sys, options, cap=cap, ec=ec)
    best_rows = None
    cand = None
    if options.want_strategy:
        lo = bounds.lower
        hi = bounds.upper if options.method is not Method.VALUE else bounds.lower
        b, c = choose(sys, lo, hi)
        best_rows = sys.rows[b]
        cand = np.zeros(num_choices, dtype=bool)
        cand[sys.rows[c]] = True
    return _Solved(
        bounds.lower,
        bounds.upper,
        bounds.iterations,
        bounds.converged,
        bounds.sound,
        best_rows,
        cand,
        bounds.end_components or ec is EndComponents.NONE and not is_chain,
    )


def _result(
    model: ExplicitModel,
    known: np.ndarray,
    known_values: np.ndarray,
    sys: System | None,
    solved: _Solved | None,
    *,
    method: Method,
    started: float,
    strategy: np.ndarray | None,
) -> EngineResult:
    S = model.num_states
    lower = np.where(known, known_values, 0.0).astype(np.float64)
    upper = lower.copy()
    values = lower.copy()
    iterations = 0
    converged = True
    sound = True
    if sys is not None and solved is not None and sys.n:
        lower[sys.states] = solved.lower
        upper[sys.states] = solved.upper
        if method is Method.VALUE:
            values[sys.states] = solved.lower
        else:
            with np.errstate(invalid="ignore"):
                mid = np.where(
                    np.isfinite(solved.upper), 0.5 * (solved.lower + solved.upper), solved.lower
                )
            values[sys.states] = mid
        iterations = solved.iterations
        converged = solved.converged
        sound = solved.sound
    if method is Method.VALUE:
        sound = False
    return EngineResult(
        values=values,
        lower=lower,
        upper=upper,
        iterations=iterations,
        converged=converged,
        method=method,
        seconds=time.perf_counter() - started,
        sound=sound,
        strategy=strategy,
    )


def _reacher_fix(
    g: Structure,
    strategy: np.ndarray,
    solved: _Solved,
    sys: System,
    *,
    goal: np.ndarray,
    goal_choices: np.ndarray | None,
    reacher: np.ndarray,
) -> None:
    """Attractor-based strategy fix (in place): among their not-provably-suboptimal choices, the
    states of the player who wants ``goal`` reached pick one that makes progress towards it; the
    opponent is universal over its own candidate choices."""
    if solved.candidates is None or solved.best_rows is None or not solved.needs_fix:
        return
    unknown = np.zeros(g.num_states, dtype=bool)
    unknown[sys.states] = True
    preferred = np.full(g.num_states, -1, dtype=np.int64)
    preferred[sys.states] = solved.best_rows
    allowed = solved.candidates | ~unknown[g.choice_state]
    inside, witness = attractor(
        g,
        goal,
        existential=reacher,
        candidates=unknown,
        allowed=allowed,
        initial_choices=None if goal_choices is None else goal_choices & allowed,
        preferred=preferred,
    )
    fix = unknown & reacher & (witness >= 0)
    strategy[fix] = witness[fix]


# ---------------------------------------------------------------------------------------------
# reachability
# ---------------------------------------------------------------------------------------------


def reach_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[remain U target]`` optimised per state (``remain`` None: ``F target``).

    Args:
        model: a dtmc, mdp or smg (a pomdp/posg is read as fully observable).
        target: bool[S].
        remain: bool[S] or None.
        maximize: bool[S], True where the state's owner maximises the probability.
        options: solver options.

    Returns:
        The :class:`EngineResult`; qualitative answers (0 and 1) are exact. The strategy (if asked)
        is optimal up to the precision and reaches the target: the maximiser's choices come from
        the almost-sure attractor on the value-1 states and from an attractor among its
        near-optimal choices elsewhere; the minimiser stays out of the positive region where its
        value is 0.
    """
    started = time.perf_counter()
    S = model.num_states
    tgt = _bool(target, S, False)
    rem = _bool(remain, S, True)
    mx = _directions(model, maximize)
    g = structure_of(model)
    layer = np.full(S, -1, dtype=np.int64)
    pos = positive_reach(g, tgt, rem, existential=mx, layer=layer)
    one, one_witness = almost_sure_reach(g, tgt, rem, existential=mx, start=pos)
    zero = ~pos
    unknown = pos & ~one
    known_values = one.astype(np.float64)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(g, unknown, maximize=mx, fixed=known_values, layer=layer)
        nondet = model.model_type is not ModelType.DTMC
        solved = _solve_system(
            sys,
            options,
            cap=1.0,
            ec=EndComponents.DEFLATE if nondet else EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=True,
            is_chain=not nondet,
        )
    strategy = None
    if options.want_strategy:
        strategy = _first_choices(model)
        if model.model_type is not ModelType.DTMC:
            # value 1: the maximiser follows the almost-sure attractor
            w = one & mx & (one_witness >= 0)
            strategy[w] = one_witness[w]
            # value 0: the minimiser keeps out of the positive region
            avoid = _any_choice_avoiding(g, pos, zero & ~mx & ~tgt)
            a = avoid >= 0
            strategy[a] = avoid[a]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                _reacher_fix(
                    g, strategy, solved, sys, goal=tgt | one, goal_choices=None, reacher=mx
                )
            # target states and states outside ``remain`` decide nothing
            strategy[tgt | ~rem] = -1
    return _result(
        model,
        ~unknown,
        known_values,
        sys,
        solved,
        method=options.method,
        started=started,
        strategy=strategy,
    )


def bounded_reach_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[remain U<=steps target]``: exactly ``steps`` Bellman steps (no strategy: it needs a step
    counter).

    Args:
        model, target, remain, maximize, options: as for :func:`reach_probability`.
        steps: the step bound k >= 0.

    Returns:
        The :class:`EngineResult` (``lower = upper = values``, ``strategy = None``).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    S = model.num_states
    tgt = _bool(target, S, False)
    rem = _bool(remain, S, True)
    mx = _directions(model, maximize)
    g = structure_of(model)
    pos = positive_reach(g, tgt, rem, existential=mx)
    unknown = pos & ~tgt
    x = tgt.astype(np.float64)
    iterations = 0
    if unknown.any() and steps > 0:
        sys = build_system(g, unknown, maximize=mx, fixed=x)
        local = np.zeros(sys.n)
        for _ in range(steps):
            local = bellman(sys, local)
            iterations += 1
        x[sys.states] = local
    return _exact_result(x, iterations, options.method, started)


def next_probability(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``P[X target]``: one step, optimised per state.

    Returns:
        The :class:`EngineResult` with the optimal choice per state as strategy.
    """
    started = time.perf_counter()
    S = model.num_states
    tgt = _bool(target, S, False)
    mx = _directions(model, maximize)
    g = structure_of(model)
    sys = build_system(g, np.ones(S, dtype=bool), maximize=mx, fixed=tgt.astype(np.float64))
    # all states are unknown, so the target mass must enter through the offset
    y = np.asarray(model.transitions[sys.rows] @ tgt.astype(np.float64)).ravel()
    local = reduce_rows(sys, y)
    x = np.zeros(S)
    x[sys.states] = local
    strategy = None
    if options.want_strategy:
        strategy = np.full(S, -1, dtype=np.int64)
        strategy[sys.states] = sys.rows[argopt_rows(sys, y)]
    return _exact_result(x, 1, options.method, started, strategy=strategy)


def _exact_result(
    x: np.ndarray,
    iterations: int,
    method: Method,
    started: float,
    *,
    strategy: np.ndarray | None = None,
) -> EngineResult:
    return EngineResult(
        values=x,
        lower=x.copy(),
        upper=x.copy(),
        iterations=iterations,
        converged=True,
        method=method,
        seconds=time.perf_counter() - started,
        sound=True,
        strategy=strategy,
    )


# ---------------------------------------------------------------------------------------------
# rewards
# ---------------------------------------------------------------------------------------------


def _local_rows(sys: System, initial: np.ndarray) -> np.ndarray:
    """int64[n]: local System rows from global choices (first row where not usable)."""
    inv = np.full(int(sys.rows.max(initial=-1)) + 1, -1, dtype=np.int64)
    inv[sys.rows] = np.arange(sys.m, dtype=np.int64)
    rows = sys.first_row
    g_init = initial[sys.states]
    ok = (g_init >= 0) & (g_init < inv.size)
    cand = np.where(ok, inv[np.where(ok, g_init, 0)], -1)
    return np.where(cand >= 0, cand, rows)


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
    tgt = _bool(target, model.num_states, False)
    if mode is ReachRewardMode.ZERO:
        r = _check_rewards(
            model,
            rewards,
            nonnegative=True,
            objective="R[F0 ...] (as in PRISM-games)",
            hint="use R[F ...]: it accepts negative rewards when every strategy reaches the target "
            "with probability 1",
        )
        return _reach_reward_zero(model, r, tgt, _directions(model, maximize), options)
    r = _check_rewards(model, rewards, nonnegative=False)
    mx = _directions(model, maximize)
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
    allowed = ~_unsafe(g, finite)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(g, unknown, maximize=mx, allowed=allowed, choice_offset=r)
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
                initial_rows=_local_rows(sys, finite_witness),
            )
        else:
            solved = _solve_system(
                sys,
                options,
                cap=np.inf,
                ec=EndComponents.INFLATE if has_min else EndComponents.NONE,
                num_choices=model.num_choices,
                outer_max=False,
                idle_min=False,
                initial_rows=_local_rows(sys, finite_witness),
                is_chain=dtmc,
            )
    strategy = None
    if options.want_strategy:
        strategy = _first_choices(model)
        if not dtmc:
            w = finite & reacher & (finite_witness >= 0)
            strategy[w] = finite_witness[w]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                _reacher_fix(g, strategy, solved, sys, goal=tgt, goal_choices=None, reacher=reacher)
            if (infinite & mx).any():
                # the maximiser keeps away from the target with positive probability: a positive
                # Büchi strategy for "any choice outside the target" (target absorbing)
                _, keep_away = positive_buchi(g, ~tgt[g.choice_state], ~tgt, existential=mx)
                w = infinite & mx & (keep_away >= 0)
                strategy[w] = keep_away[w]
        strategy[tgt] = -1
    return _result(
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
) -> _Solved:
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
        return _solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=False,
            idle_min=False,
            initial_rows=initial_rows,
            is_chain=model.model_type is ModelType.DTMC,
        )
    if options.method is Method.VALUE:
        bounds = value_iteration(sys, options)
    else:
        lower0, upper0, aux_iterations = start_bounds(
            g, unknown, r, allowed=allowed, options=options
        )
        bounds = solve_proper(sys, options, lower=lower0[sys.states], upper=upper0[sys.states])
        bounds = replace(bounds, iterations=bounds.iterations + aux_iterations)
    best_rows = None
    candidates = None
    if options.want_strategy:
        # all policies are proper, so the greedy choice needs no attractor fix
        best, cand = choose(sys, bounds.lower, bounds.upper)
        best_rows = sys.rows[best]
        candidates = np.zeros(model.num_choices, dtype=bool)
        candidates[sys.rows[cand]] = True
    return _Solved(
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
        f"{_state_text(model, int(g.choice_state[c]))}) is only supported when every strategy "
        f"profile reaches the target with probability 1 {scope}; from {_state_text(model, s)} "
        "some profile avoids the target with positive probability (it can stay in an end "
        f"component forever){why}",
        hint="make the target reachable with probability 1 under every strategy (no end "
        "component outside the target), keep the rewards non-negative, or use a discounted "
        "reward (R[Fdiscount=g ...])",
    )


def _state_text(model: ExplicitModel, s: int) -> str:
    """``state 3 (x=1, y=0)`` (the valuation when the model has variables)."""
    names = model.variable_names
    values = model.state_values
    if names and values.ndim == 2 and values.shape == (model.num_states, len(names)):
        return f"state {s} (" + ", ".join(f"{n}={int(v)}" for n, v in zip(names, values[s])) + ")"
    return f"state {s}"


def _unsafe(g: Structure, region: np.ndarray) -> np.ndarray:
    return np.asarray(g.transitions @ (~region).astype(np.float64)) > 0


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
    allowed = ~_unsafe(g, finite)
    sys = None
    solved = None
    if unknown.any():
        sys = build_system(g, unknown, maximize=mx, allowed=allowed, choice_offset=r)
        reach_zero, zero_witness = almost_sure_reach(g, zero | tgt, finite, existential=~spoiler)
        solved = _solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.DEFLATE if not dtmc else EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=True,
            unbounded=True,
            initial_rows=_local_rows(sys, np.where(reach_zero, zero_witness, -1)),
            is_chain=dtmc,
        )
    strategy = None
    if options.want_strategy:
        strategy = _first_choices(model)
        if not dtmc:
            z = zero & ~spoiler & (zero_choice >= 0)
            strategy[z] = zero_choice[z]
            if sys is not None and solved is not None and solved.best_rows is not None:
                strategy[sys.states] = solved.best_rows
                # the maximiser must not idle in a zero-reward end component it could leave
                _reacher_fix(
                    g, strategy, solved, sys, goal=zero | tgt, goal_choices=good, reacher=spoiler
                )
            w = infinite & spoiler & (infinite_witness >= 0)
            strategy[w] = infinite_witness[w]
        strategy[tgt] = -1
    return _result(
        model,
        ~unknown,
        known_values,
        sys,
        solved,
        method=options.method,
        started=started,
        strategy=strategy,
    )


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
    r = _check_rewards(
        model,
        rewards,
        nonnegative=True,
        objective="the expected total reward R[C]",
        hint="without a target, rewards of mixed sign can sum to -infinity or have no expected "
        "value; use R[Cdiscount=g], R[C<=k], or R[F target] with a target every strategy "
        "reaches with probability 1",
    )
    return _total(
        model, r, np.zeros(model.num_states, dtype=bool), _directions(model, maximize), options
    )


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
        return _exact_result(np.zeros(S), prob.iterations, options.method, started)
    # bounds on r * p give bounds on the (linear, monotone) solution
    sys_lo = build_system(g, unknown, maximize=mx, choice_offset=r * p_lo[g.choice_state])
    sys_hi = build_system(g, unknown, maximize=mx, choice_offset=r * p_hi[g.choice_state])
    a = _solve_system(
        sys_lo,
        options,
        cap=np.inf,
        ec=EndComponents.NONE,
        num_choices=model.num_choices,
        outer_max=True,
        idle_min=True,
        is_chain=True,
    )
    b = _solve_system(
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
        strategy=_first_choices(model) if options.want_strategy else None,
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


def cumulative_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[C<=k]``: the choice rewards of the first ``steps`` steps, by k Bellman steps.

    Returns:
        The :class:`EngineResult` (exact up to floating point; no strategy).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    r = _check_rewards(model, rewards, nonnegative=False)
    mx = _directions(model, maximize)
    S = model.num_states
    x = np.zeros(S)
    if steps > 0:
        sys = build_system(
            structure_of(model), np.ones(S, dtype=bool), maximize=mx, choice_offset=r
        )
        local = np.zeros(S)
        for _ in range(steps):
            local = bellman(sys, local)
        x[sys.states] = local
    return _exact_result(x, steps, options.method, started)


def instantaneous_reward(
    model: ExplicitModel,
    state_rewards: np.ndarray,
    *,
    steps: int,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[I=k]``: the expected state reward of the state occupied after ``steps`` steps.

    Returns:
        The :class:`EngineResult` (exact up to floating point; no strategy).
    """
    started = time.perf_counter()
    if steps < 0:
        raise PosgmcError(f"a step bound must be non-negative, got {steps}")
    S = model.num_states
    sr = np.asarray(state_rewards, dtype=np.float64)
    if sr.shape != (S,):
        raise PosgmcError(f"state rewards need one entry per state ({S}), got {sr.shape}")
    mx = _directions(model, maximize)
    x = sr.copy()
    if steps > 0:
        sys = build_system(structure_of(model), np.ones(S, dtype=bool), maximize=mx)
        local = sr[sys.states]
        for _ in range(steps):
            local = bellman(sys, local)
        x = np.empty(S)
        x[sys.states] = local
    return _exact_result(x, steps, options.method, started)


def _discounted(
    model: ExplicitModel,
    r: np.ndarray,
    unknown: np.ndarray,
    discount: float,
    mx: np.ndarray,
    options: SolverOptions,
) -> EngineResult:
    """``x = opt(r + discount * T x)`` on ``unknown`` (other states 0)."""
    started = time.perf_counter()
    if not 0.0 <= discount < 1.0:
        raise PosgmcError(f"a discount factor must lie in [0, 1), got {discount}")
    S = model.num_states
    g = structure_of(model)
    x = np.zeros(S)
    lower = np.zeros(S)
    upper = np.zeros(S)
    strategy = np.full(S, -1, dtype=np.int64) if options.want_strategy else None
    if not unknown.any():
        return _exact_result(x, 0, options.method, started, strategy=strategy)
    base = build_system(g, unknown, maximize=mx, choice_offset=r)
    scaled = base.matrix.copy()
    scaled.data *= discount
    # every row leaks probability 1 - discount, so no part of the system is closed
    sys = replace(base, matrix=scaled, stays=np.zeros(base.m, dtype=bool))
    iterations = 0
    converged = True
    if options.method in (Method.EXACT, Method.POLICY) and sys.n:
        solved = _solve_system(
            sys,
            options,
            cap=np.inf,
            ec=EndComponents.NONE,
            num_choices=model.num_choices,
            outer_max=True,
            idle_min=False,
            is_chain=model.model_type is ModelType.DTMC,
        )
        lo = hi = solved.lower
        iterations = solved.iterations
        best = solved.best_rows
    else:
        bounds, best_local = solve_discounted(sys, options)
        lo, hi = bounds.lower, bounds.upper
        iterations, converged = bounds.iterations, bounds.converged
        best = sys.rows[best_local]
    lower[sys.states] = lo
    upper[sys.states] = hi
    x[sys.states] = 0.5 * (lo + hi)
    if strategy is not None and best is not None:
        strategy[sys.states] = best
    return EngineResult(
        values=x,
        lower=lower,
        upper=upper,
        iterations=iterations,
        converged=converged,
        method=options.method,
        seconds=time.perf_counter() - started,
        sound=options.method is not Method.VALUE,
        strategy=strategy,
    )


def discounted_total_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    *,
    discount: float,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """``R[Cdiscount=g]`` = E[sum_t g^t r_t]; bounds from the contraction factor
    (``|x_k - x*| <= g / (1 - g) |x_k - x_{k-1}|``), so rewards of any sign are fine.

    Returns:
        The :class:`EngineResult` with an optimal memoryless strategy.
    """
    r = _check_rewards(model, rewards, nonnegative=False)
    S = model.num_states
    return _discounted(
        model, r, np.ones(S, dtype=bool), float(discount), _directions(model, maximize), options
    )


def discounted_reach_reward(
    model: ExplicitModel,
    rewards: np.ndarray,
    target: np.ndarray,
    *,
    discount: float,
    maximize: np.ndarray,
    options: SolverOptions = SolverOptions(),
) -> EngineResult:
    """Discounted reward collected until ``target`` (absorbing, nothing collected there).

    Returns:
        The :class:`EngineResult` with an optimal memoryless strategy.
    """
    r = _check_rewards(model, rewards, nonnegative=False)
    tgt = _bool(target, model.num_states, False)
    return _discounted(model, r, ~tgt, float(discount), _directions(model, maximize), options)


# ---------------------------------------------------------------------------------------------
# strategies
# ---------------------------------------------------------------------------------------------


def induced_chain(model: ExplicitModel, strategy: np.ndarray) -> ExplicitModel:
    """The dtmc a memoryless deterministic strategy induces.

    Args:
        model: any model type.
        strategy: int64[S], a global choice index per state; -1 takes the state's first choice.

    Returns:
        A dtmc with the same states, labels, valuations and initial states; its reward models carry
        the chosen choices' rewards (state + action reward) as choice rewards.

    Raises:
        PosgmcError: a choice does not belong to its state.
    """
    S = model.num_states
    st = np.asarray(strategy, dtype=np.int64)
    if st.shape != (S,):
        raise PosgmcError(f"a strategy needs one entry per state ({S}), got {st.shape}")
    rows = np.where(st < 0, model.row_groups[:-1], st)
    owner_ok = (rows >= model.row_groups[:-1]) & (rows < model.row_groups[1:])
    if not owner_ok.all():
        s = int(np.flatnonzero(~owner_ok)[0])
        raise PosgmcError(f"strategy: choice {int(rows[s])} does not belong to state {s}")
    from posgmc.model.explicit import RewardModel

    rms = tuple(
        RewardModel(name=rm.name, state=None, choice=rm.choice_rewards(model.row_groups)[rows])
        for rm in model.reward_models
    )
    return make_model(
        ModelType.DTMC,
        np.arange(S + 1, dtype=np.int64),
        model.transitions[rows],
        initial_states=model.initial_states,
        choice_actions=model.choice_actions[rows],
        action_names=model.action_names,
        labels=dict(model.labels),
        reward_models=rms,
        variable_names=model.variable_names,
        state_values=model.state_values,
        deadlocks=model.deadlocks,
    )
