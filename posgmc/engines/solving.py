"""The pieces every fully observable objective shares: argument checks, the solve dispatch, the
assembly of an :class:`~posgmc.engines.result.EngineResult`, and the attractor-based strategy fix.

* :func:`maximize_mask` turns a query's direction and coalition into the per-state optimisation
  direction the objectives take; ``bool_mask``/``directions_of``/``check_rewards`` check the
  arguments
  (rewards are per choice: state reward + action reward, :meth:`RewardModel.choice_rewards`);
* ``solve_system`` solves the :class:`~posgmc.engines.system.System` on the unknown states by
  the chosen :class:`~posgmc.engines.options.Method` (sound interval iteration, plain value
  iteration, or policy iteration / direct solves, see :mod:`posgmc.engines.policy_iteration`) and
  returns a ``Solved``;
* ``engine_result``/``exact_result`` put the known and the solved values into one result;
* ``reacher_fix``: where the player who wants the target reached has end components, its choices
  are fixed by an attractor towards the target among its (near-)optimal choices, so that the
  strategy really reaches the target.

Nothing here depends on a particular objective: the objective modules import from here, never the
other way round.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from posgmc.engines import policy_iteration as ex
from posgmc.engines.certify import certify
from posgmc.engines.graph import Structure, attractor, leaving_choices
from posgmc.engines.iteration import Bounds, EndComponents, gap_ok, solve, widen
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.result import EngineResult
from posgmc.engines.system import System, choose
from posgmc.engines.topological import solve_topological
from posgmc.errors import PosgmcError, UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import Direction, ModelType

__all__ = [
    "maximize_mask", "bool_mask", "directions_of", "check_rewards", "state_text", "first_choices",
    "local_rows", "unsafe_states", "Solved", "solve_system", "engine_result", "exact_result",
    "reacher_fix",
]


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


def bool_mask(a: np.ndarray | None, S: int, default: bool) -> np.ndarray:
    if a is None:
        return np.full(S, default, dtype=bool)
    out = np.asarray(a, dtype=bool)
    if out.shape != (S,):
        raise PosgmcError(f"expected a boolean state vector of length {S}, got shape {out.shape}")
    return out


def directions_of(model: ExplicitModel, maximize: np.ndarray) -> np.ndarray:
    mx = np.asarray(maximize, dtype=bool)
    if mx.shape != (model.num_states,):
        raise PosgmcError(
            f"maximize needs one entry per state ({model.num_states}), got {mx.shape}"
        )
    if model.model_type is ModelType.DTMC:
        return np.ones(model.num_states, dtype=bool)
    return mx


def check_rewards(
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
        where = state_text(model, int(np.searchsorted(model.row_groups, c, side="right") - 1))
        raise UnsupportedError(
            f"negative rewards are not supported for {objective} (e.g. {r[c]:g} in {where})",
            hint=hint,
        )
    return r


def state_text(model: ExplicitModel, s: int) -> str:
    """``state 3 (x=1, y=0)`` (the valuation when the model has variables)."""
    names = model.variable_names
    values = model.state_values
    if names and values.ndim == 2 and values.shape == (model.num_states, len(names)):
        return f"state {s} (" + ", ".join(f"{n}={int(v)}" for n, v in zip(names, values[s])) + ")"
    return f"state {s}"


def first_choices(model: ExplicitModel) -> np.ndarray:
    return model.row_groups[:-1].astype(np.int64).copy()


def local_rows(sys: System, initial: np.ndarray) -> np.ndarray:
    """int64[n]: local System rows from global choices (first row where not usable)."""
    inv = np.full(int(sys.rows.max(initial=-1)) + 1, -1, dtype=np.int64)
    inv[sys.rows] = np.arange(sys.m, dtype=np.int64)
    rows = sys.first_row
    g_init = initial[sys.states]
    ok = (g_init >= 0) & (g_init < inv.size)
    cand = np.where(ok, inv[np.where(ok, g_init, 0)], -1)
    return np.where(cand >= 0, cand, rows)


def unsafe_states(g: Structure, region: np.ndarray) -> np.ndarray:
    return leaving_choices(g, region)


@dataclass(frozen=True)
class Solved:
    """The outcome on the unknown states (global vectors filled by the caller)."""

    lower: np.ndarray
    upper: np.ndarray
    iterations: int
    converged: bool
    sound: bool
    best_rows: np.ndarray | None  # int64[n] global choices
    candidates: np.ndarray | None  # bool[C] global choices that are not provably suboptimal
    needs_fix: bool = False  # the reacher has end components: the attractor fix is required
    estimate: np.ndarray | None = None  # policy iteration's values (reported inside the bounds)


_STIFF_STEPS = 2_000
"""Interval iteration that has not converged after this many steps is stiff (a loop left with a
tiny probability): policy iteration with a certificate is tried before it goes on."""

_STIFF_LIMIT = 200_000
"""Up to this many unknowns, policy iteration's sparse LU solves are affordable for that."""


def _policy_solution(
    sys: System,
    gr: ex.Grouped,
    initial_rows: np.ndarray | None,
    *,
    outer_max: bool,
    idle_min: bool,
    unbounded: bool,
    is_chain: bool,
    max_rounds: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Policy iteration (a direct solve for a chain): values, the local row of each state,
    rounds."""
    if initial_rows is None:
        start = gr.row_groups[:-1].copy()
    else:
        inv = np.empty(gr.source.size, dtype=np.int64)  # local rows -> grouped rows
        inv[gr.source] = np.arange(gr.source.size)
        start = inv[initial_rows]
    if is_chain:
        return ex.evaluate(gr, start), gr.source[start], 1
    x, rows, rounds = ex.policy_iteration(
        gr, start, outer_max=outer_max, idle_min=idle_min, unbounded=unbounded,
        max_rounds=max_rounds,
    )
    return x, gr.source[rows], rounds


def _candidates(sys: System, rows: np.ndarray, num_choices: int) -> tuple[np.ndarray, np.ndarray]:
    best = sys.rows[rows]
    cand = np.zeros(num_choices, dtype=bool)
    cand[best] = True
    return best, cand


def _interval(sys: System, options: SolverOptions, *, cap: float, ec: EndComponents) -> Bounds:
    """Interval (or value) iteration: band by band when the system has a topological layout
    (:mod:`posgmc.engines.topological`), else (or if a band cannot be solved alone) at once."""
    if sys.bands is not None and options.method is not Method.VALUE:
        bounds = solve_topological(sys, options, cap=cap, ec=ec)
        if bounds is not None:
            return bounds
    return solve(sys, options, cap=cap, ec=ec)


def solve_system(
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
    interval: Callable[[], Bounds] | None = None,
) -> Solved:
    """Dispatch on the method (see :mod:`posgmc.engines.iteration`,
    :mod:`posgmc.engines.policy_iteration`).

    Policy iteration's values get proven bounds from :func:`~posgmc.engines.certify.certify`, or,
    where no certificate is found, from ``interval()`` (default: :func:`solve` by interval
    iteration; objectives with another sound solver pass theirs). Interval iteration that turns
    out stiff (not converged after :data:`_STIFF_STEPS` steps) tries the same certificate on
    policy iteration's solution before it goes on."""
    n = sys.n
    if n == 0:
        z = np.zeros(0)
        return Solved(
            z, z.copy(), 0, True, options.method is not Method.VALUE, np.zeros(0, np.int64), None
        )
    # An objective whose minimiser's end components count as infinite (INFLATE) is still a least
    # fixpoint wherever the certificate applies: it needs finite step counts, i.e. no end
    # components of either player among the unknowns (certify returns None otherwise).
    certifiable = not unbounded

    def policy(
        start: np.ndarray | None, prove: bool = True
    ) -> tuple[np.ndarray, np.ndarray, int, Solved | None]:
        """Policy iteration; with ``prove`` a certified result or None, else an unproven one."""
        x, rows, rounds = _policy_solution(
            sys, ex.grouped(sys), start, outer_max=outer_max, idle_min=idle_min,
            unbounded=unbounded, is_chain=is_chain, max_rounds=options.max_iterations,
        )
        best, cand = _candidates(sys, rows, num_choices)
        if not prove:
            return (
                x,
                rows,
                rounds,
                Solved(x, x.copy(), rounds, True, False, best, cand, estimate=x),
            )
        proven = (
            certify(sys, x, rows, cap=cap, precision=options.precision, relative=options.relative)
            if certifiable else None
        )
        if proven is None:
            return x, rows, rounds, None
        lower, upper = widen(*proven)
        met = gap_ok(lower, upper, options.precision, options.relative)
        return x, rows, rounds, Solved(lower, upper, rounds, met, True, best, cand,
                                        estimate=np.clip(x, lower, upper))

    if options.method in (Method.EXACT, Method.POLICY):
        x, rows, rounds, solved = policy(initial_rows, prove=options.prove)
        if solved is not None:
            return solved
        # No certificate (end components, infinite values, a gap above the precision): the same
        # optimal strategy, with bounds proven by interval iteration.
        if interval is None:
            bounds = _interval(sys, replace(options, method=Method.INTERVAL), cap=cap, ec=ec)
        else:
            bounds = interval()
        best, candidates = _candidates(sys, rows, num_choices)
        return Solved(bounds.lower, bounds.upper, rounds + bounds.iterations, bounds.converged,
                       bounds.sound, best, candidates,
                       estimate=np.clip(x, bounds.lower, bounds.upper))
    if (options.method is Method.INTERVAL and certifiable and n <= _STIFF_LIMIT
            and options.max_iterations > _STIFF_STEPS and options.stiff_certificate):
        bounds = _interval(sys, replace(options, max_iterations=_STIFF_STEPS), cap=cap, ec=ec)
        if not bounds.converged:
            start, _ = choose(sys, bounds.lower, bounds.upper)
            x_pi, _, _, solved = policy(start)
            if solved is not None:  # both are proven: keep their intersection
                lower = np.maximum(solved.lower, bounds.lower)
                upper = np.minimum(solved.upper, bounds.upper)
                return replace(solved, lower=lower, upper=upper,
                               iterations=bounds.iterations + solved.iterations,
                               estimate=np.clip(x_pi, lower, upper))
            bounds = _interval(sys, options, cap=cap, ec=ec)
    else:
        bounds = _interval(sys, options, cap=cap, ec=ec)
    best_rows: np.ndarray | None = None
    cand: np.ndarray | None = None
    if options.want_strategy:
        lo = bounds.lower
        hi = bounds.upper if options.method is not Method.VALUE else bounds.lower
        b, c = choose(sys, lo, hi)
        best_rows = sys.rows[b]
        cand = np.zeros(num_choices, dtype=bool)
        cand[sys.rows[c]] = True
    return Solved(
        bounds.lower,
        bounds.upper,
        bounds.iterations,
        bounds.converged,
        bounds.sound,
        best_rows,
        cand,
        bounds.end_components or ec is EndComponents.NONE and not is_chain,
    )


def engine_result(
    model: ExplicitModel,
    known: np.ndarray,
    known_values: np.ndarray,
    sys: System | None,
    solved: Solved | None,
    *,
    method: Method,
    started: float,
    strategy: np.ndarray | None,
) -> EngineResult:
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
        elif solved.estimate is not None:
            values[sys.states] = solved.estimate
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


def exact_result(
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


def reacher_fix(
    g: Structure,
    strategy: np.ndarray,
    solved: Solved,
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
