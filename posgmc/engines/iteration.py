"""Sound iterative solution of min/max fixpoint equations on the states whose value is unknown.

A :class:`System` is the part of a model left after graph precomputation: ``n`` unknown states,
``m`` rows (their usable choices), a sparse matrix ``A`` [m, n] and a constant ``b`` [m] per row,
so that the Bellman operator is::

    B(x)(s) = opt_{r in rows(s)} ( b[r] + sum_t A[r, t] x[t] ),   opt = max or min per state.

Every objective posgmc solves iteratively is a least fixpoint of such an operator (reachability
probabilities, total and reach rewards with non-negative rewards), possibly after an end-component
correction. :func:`solve` returns proven bounds ``lower <= lfp <= upper``:

* **lower bound**: value iteration from 0. Every iterate of a monotone operator started below the
  least fixpoint stays below it, so the lower bound needs no check.
* **upper bound**: optimistic value iteration (Hartmanns & Kaminski, CAV 2020). Once the lower
  iteration stalls, guess ``U = L + eps`` and apply the operator ``F``; if ``F(U) <= U`` then ``U``
  is a pre-fixpoint and, by Park induction (Knaster-Tarski), ``U >= lfp F``. From then on
  ``F^k(U)`` decreases and stays above the fixpoint. A failed guess shrinks the stopping threshold
  of the lower iteration and retries.
* **end components of the maximiser** (``EndComponents.DEFLATE``): inside an end component of the
  maximising player the upper iterate cannot decrease (the gfp exceeds the lfp). We deflate
  (Kelmendi et al., CAV 2018; Eisentraut et al.): for a set T whose minimiser states each keep a
  choice inside T and whose internal choices have b = 0, the value of every state of T is at most
  ``max(0, max over maximiser rows r of T that are not internal of b[r] + A[r] value)``, because
  the minimiser can stay in T until the maximiser leaves. Let ``F = D o B`` with D that cap,
  computed from the same iterate. F is monotone, the value is a fixpoint of F, and by induction
  ``F^k(0) >= B^k(0)`` (the k-step value of a state of T never exceeds the cap of the (k-1)-step
  values), so ``lfp F = lfp B`` and Park induction applies to F, *for every* such family of sets.
  For an mdp the family is the maximal end components of the zero-``b`` rows (computed once); in a
  game it is recomputed with the minimiser restricted to its rows optimal for the current lower
  bound, as in Kelmendi et al.: lazily, once a guessed upper bound has failed to verify without
  it for half the verification budget, then at every later guess and every 32 steps.
* **zero-reward end components of the minimiser** (``EndComponents.INFLATE``, expected reward until
  a target with "infinite unless reached" semantics): the least fixpoint undercounts (staying in a
  zero-reward cycle costs nothing but never reaches the target). The lower iterate is inflated: in
  a set T where the maximiser keeps a zero-reward choice inside, the minimiser must leave through
  one of its exits, so ``value >= min over minimiser exits r of (b[r] + A_out[r] x) / P_out[r]``
  (renewal argument). Park induction cannot prove an upper bound here, so the upper bound starts
  from the problem with every zero constant raised to the smallest positive one: that problem
  has a larger value and no zero-reward end components (a unique fixpoint, which optimistic
  iteration proves as above); B^k of an upper bound stays above the value (a fixpoint of the
  monotone B), and iterating B from above converges to the value of the proper strategies
  (Bertsekas & Yu, 2016), which is the value sought.
* **floating point**: ``F(U) <= U`` is accepted up to a relative four ulps (rounding noise of one
  step; without it a guess sitting exactly on the fixpoint could never be confirmed), and the final
  bounds are widened outwards by a relative 1e-10, which covers the rounding of all iterations.
  Bounds are therefore proven up to floating-point error, like every float-based checker's. A
  guess is given up as below the value only when the upper iterate falls below the lower one by
  more than that 1e-10: the lower iterate's own rounding can put it some ulps above an upper
  iterate that deflation has set exactly to the value, and a tighter test failed every guess
  there (a maximiser's end component through single-choice minimiser states, as in a game with
  the minimiser's strategy fixed).

The layout of the system and the Bellman kernels are in :mod:`posgmc.engines.system`; this
module runs them. Blocks (large systems only) are consecutive backward-search layers of the
positive region, so the values flow from the known states through the blocks in order. The lower
iteration and the verification sweep them Gauss-Seidel style: each block is evaluated against the
vector already updated by the blocks before it, which carries a value across all the layers in one
sweep instead of one layer per Jacobi step (pursuit N=30: 75 sweeps instead of 260 steps).
Soundness is unchanged: a lower value is ``B`` of a vector below the least fixpoint; an upper
sweep whose result is below its input has produced a pre-fixpoint (see :func:`_sweep_pair`). The
end-component corrections (deflation, inflation) need a whole Jacobi step and switch the sweeps
off.
Without blocks, while only the lower bound is iterated, the row values are updated incrementally
(``y += A (x_new - x_old)``, recomputed every 64 steps) and one vector is multiplied; during
verification both bounds share one pass over the matrix.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from posgmc.engines import scc
from posgmc.engines.graph import end_components, row_of_entries
from posgmc.engines.options import Method, SolverOptions
from posgmc.engines.system import (
    HAVE_KERNELS,
    System,
    accumulate_rows,
    argopt_rows,
    choice_values,
    multiply_into,
    reduce_entries,
    reduce_into,
)

__all__ = [
    "Bounds",
    "EndComponents",
    "gap_ok",
    "max_change",
    "solve",
    "solve_discounted",
    "widen",
]


# ---------------------------------------------------------------------------------------------
# end components
# ---------------------------------------------------------------------------------------------


class EndComponents(enum.Enum):
    """How end components are treated (see the module docstring)."""

    NONE = "none"
    DEFLATE = "deflate"
    INFLATE = "inflate"


@dataclass(frozen=True, eq=False)
class _Family:
    """A family of disjoint end components with the exits that bound them."""

    states: np.ndarray  # int64[k]: local states inside some component
    comp: np.ndarray  # int64[k]: their component
    num: int
    exit_rows: np.ndarray  # int64[e]: exit rows sorted by component
    exit_starts: np.ndarray  # int64[g]: reduceat starts
    exit_comps: np.ndarray  # int64[g]: the component of each group
    out_matrix: (
        sp.csr_matrix | None
    )  # inflation: exit rows restricted to columns outside the component
    p_out: np.ndarray | None  # inflation: probability of leaving the component per exit row

    def deflate(self, y: np.ndarray, x: np.ndarray) -> None:
        """x[T] = min(x[T], max(0, max over exits of y)) (in place)."""
        best = np.zeros(self.num)
        if self.exit_rows.size:
            best[self.exit_comps] = np.maximum.reduceat(y[self.exit_rows], self.exit_starts)
        np.maximum(best, 0.0, out=best)
        x[self.states] = np.minimum(x[self.states], best[self.comp])

    def inflate(self, offset: np.ndarray, x: np.ndarray) -> None:
        """x[T] = max(x[T], min over exits of the value conditioned on leaving) (in place)."""
        if self.exit_rows.size == 0 or self.out_matrix is None or self.p_out is None:
            return
        with np.errstate(divide="ignore", invalid="ignore"):
            cond = (offset[self.exit_rows] + self.out_matrix @ x) / self.p_out
        cond = np.where(self.p_out > 0, cond, np.inf)
        worst = np.full(self.num, np.inf)
        worst[self.exit_comps] = np.minimum.reduceat(cond, self.exit_starts)
        lift = worst[self.comp]
        ok = np.isfinite(lift)
        idx = self.states[ok]
        x[idx] = np.maximum(x[idx], lift[ok])


def _family(sys: System, allowed: np.ndarray, mode: EndComponents) -> _Family | None:
    """The maximal end components of the ``allowed`` rows (those must stay and have offset 0),
    with the exits of the maximiser (DEFLATE) or the minimiser (INFLATE)."""
    allowed = allowed & sys.stays & (sys.offset == 0)
    if not allowed.any():
        return None
    mec_of, num, internal = end_components(sys.matrix, sys.row_state, allowed)
    if num == 0:
        return None
    states = np.flatnonzero(mec_of >= 0)
    rs = sys.row_state
    in_comp = mec_of[rs] >= 0
    side = sys.row_maximize if mode is EndComponents.DEFLATE else ~sys.row_maximize
    exits = np.flatnonzero(in_comp & side & ~internal)
    comp_of_exit = mec_of[rs[exits]]
    order = np.argsort(comp_of_exit, kind="stable")
    exits = exits[order]
    comp_of_exit = comp_of_exit[order]
    if exits.size:
        starts = np.flatnonzero(np.concatenate(([True], comp_of_exit[1:] != comp_of_exit[:-1])))
        groups = comp_of_exit[starts]
    else:
        starts = np.zeros(0, dtype=np.int64)
        groups = np.zeros(0, dtype=np.int64)
    out_matrix = None
    p_out = None
    if mode is EndComponents.INFLATE and exits.size:
        sub = sys.matrix[exits].tocsr()
        er = row_of_entries(sub)
        same = mec_of[sub.indices] == comp_of_exit[er]
        p_in = np.bincount(er[same], weights=sub.data[same], minlength=exits.size)
        p_out = np.maximum(1.0 - p_in, 0.0)
        data = np.where(same, 0.0, sub.data)
        out_matrix = sp.csr_matrix((data, sub.indices, sub.indptr), shape=sub.shape)
        out_matrix.eliminate_zeros()
    return _Family(
        states=states,
        comp=mec_of[states],
        num=num,
        exit_rows=exits,
        exit_starts=starts,
        exit_comps=groups,
        out_matrix=out_matrix,
        p_out=p_out,
    )


# ---------------------------------------------------------------------------------------------
# the solver
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Bounds:
    """``lower``/``upper``: float64[n] (local order); ``iterations``; ``converged``; ``sound``;
    ``end_components``: the player treated by ``ec`` has end components in the system."""

    lower: np.ndarray
    upper: np.ndarray
    iterations: int
    converged: bool
    sound: bool
    end_components: bool = False  # the treated player has end components (strategies need a fix)


_NOISE = 4 * float(np.finfo(np.float64).eps)
"""Relative rounding noise tolerated when checking ``F(U) <= U``: a few ulps of ``U`` itself.
An absolute tolerance would be unsound: with a slow contraction (a self-loop of probability
1 - 1e-13) the true ``F(U) - U`` is tiny although ``U`` is far below the value (PRISM's
``bugfixes/export-precision/rare.nm``: ``Rmin=? [F rare]`` is 1, and a slack of 1e-13 accepted
an upper bound of 1e-6)."""

_ROUNDING = 1e-10
"""Relative floating-point error of the iterates that the final bounds are widened by
(:func:`widen`). The lower iterate can exceed the exact value by more than :data:`_NOISE` (its
row values are updated incrementally, and every step rounds), so an upper iterate that is exact
(deflated to an exit whose value is representable) may sit a few ulps below it."""


def widen(
    lower: np.ndarray, upper: np.ndarray, *, relative: float = _ROUNDING
) -> tuple[np.ndarray, np.ndarray]:
    """Outward rounding: the iterates carry floating-point error (a few ulps per step, amplified at
    most by the inverse contraction rate), far below any requested precision; widening by a
    relative 1e-10 (``relative``) keeps the reported bounds on the right side of the exact
    value."""
    slack_lo = relative * np.abs(lower)
    slack_hi = np.where(np.isfinite(upper), relative * np.abs(upper), 0.0)
    return (
        np.maximum(lower - slack_lo, 0.0) if np.all(lower >= 0) else lower - slack_lo
    ), upper + slack_hi


def gap_ok(lower: np.ndarray, upper: np.ndarray, precision: float, relative: bool) -> bool:
    """The interval meets the precision (its half-width, as :class:`SolverOptions` defines it); an
    infinite bound never does (``inf <= inf`` would pass the relative test)."""
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        return False
    gap = upper - lower
    if relative:
        return bool(np.all(gap <= precision * (np.abs(upper) + np.abs(lower))))
    return bool(np.max(gap, initial=0.0) <= 2.0 * precision)


def max_change(new: np.ndarray, old: np.ndarray, relative: bool) -> float:
    d = np.abs(new - old)
    if relative:
        scale = np.abs(new)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where(scale > 0, d / scale, d)
    return float(np.max(d, initial=0.0))


@dataclass(eq=False)
class _LooksConverged:
    """The stopping test of the lower phases (:func:`_lower_phase`, :func:`_lower_phase_blocks`):
    after each step of change ``d``, whether ``d <= tau`` and the geometric-tail estimate
    ``d * q / (1 - q)`` is at most ``tau`` too, q the larger of the last two contraction ratios
    (each capped at 0.999). Mutable on purpose: it follows one phase's steps."""

    tau: float
    ratios: tuple[float, float] = (0.0, 0.0)
    previous: float = np.inf

    def after(self, d: float) -> bool:
        """Record a step that changed the vector by ``d``; True if the phase may stop."""
        self.ratios = (self.ratios[1], min(d / self.previous, 0.999) if self.previous > 0 else 0.0)
        self.previous = d
        q = max(self.ratios)
        return d <= self.tau and d * q / (1.0 - q) <= self.tau


def _late(deadline: float | None, iters: int) -> bool:
    """Whether the caller's deadline has passed (looked at every 64 iterations; 0: now)."""
    return deadline is not None and iters % 64 == 0 and time.perf_counter() > deadline


def _lower_phase(
    sys: System,
    lower: np.ndarray,
    tau: float,
    rel: bool,
    iters: int,
    max_it: int,
    inflation: _Family | None,
    deadline: float | None = None,
) -> tuple[np.ndarray, int]:
    """Value iteration from ``lower`` until it looks converged to within ``tau``.

    "Looks converged" (a heuristic deciding when to guess an upper bound; soundness never depends
    on it): the last step changed the vector by ``d <= tau`` and the geometric-tail estimate of
    the remaining error, ``d * q / (1 - q)`` with q the recent contraction ratio of the steps
    (capped at 0.999), is at most ``tau`` too. Slowly contracting systems thus keep iterating in
    this cheap one-vector phase instead of failing verification in the two-vector one.

    The row values are updated incrementally, ``y += A (x_new - x_old)``, which saves rewriting
    the offsets every step; they are recomputed from scratch every 64 steps so that rounding does
    not accumulate."""
    n = sys.n
    A = sys.matrix
    y = np.empty(sys.m)
    x = np.ascontiguousarray(lower, dtype=np.float64).copy()
    nxt = np.empty(n)
    delta = np.empty(n)
    multiply_into(sys, x, y)
    fresh = 0
    stopping = _LooksConverged(tau)
    while iters < max_it:
        reduce_into(sys, y, nxt)
        if inflation is not None:
            inflation.inflate(sys.offset, nxt)
        iters += 1
        np.subtract(nxt, x, out=delta)
        if rel:
            d = max_change(nxt, x, rel)
        else:
            d = float(max(delta.max(initial=0.0), -delta.min(initial=0.0)))
        x, nxt = nxt, x
        if stopping.after(d):
            break
        if _late(deadline, iters):
            break
        fresh += 1
        if fresh >= 64 or not HAVE_KERNELS:
            multiply_into(sys, x, y)
            fresh = 0
        else:
            accumulate_rows(A, 0, sys.m, delta, y)
    return x, iters


def _lower_phase_blocks(
    sys: System,
    lower: np.ndarray,
    tau: float,
    rel: bool,
    iters: int,
    max_it: int,
    inner: int = 1,
    deadline: float | None = None,
) -> tuple[np.ndarray, int]:
    """:func:`_lower_phase` by Gauss-Seidel sweeps over the blocks (same stopping rule).

    Block by block in order, the rows of the block are evaluated against the current vector
    (earlier blocks already updated in this sweep) and the block's states take the optimum, or
    keep their value if that is larger. Every value written is ``B`` of a vector below the least
    fixpoint, or a value already below it, so the vector stays a lower bound, as for Jacobi steps;
    values travel from the known states outwards through all the blocks in one sweep instead of
    one layer per step. With ``inner > 1`` a block is updated up to ``inner`` times in a row,
    until its own change is below ``tau / 4`` (a block of small components in topological order
    then converges before the next one reads it; same argument). The sweep's change is the
    largest first update of a block; an iteration counts one sweep."""
    n = sys.n
    A = sys.matrix
    y = np.empty(sys.m)
    x = np.ascontiguousarray(lower, dtype=np.float64).copy()
    tmp = np.empty(n)
    step = np.empty(n)  # scratch for the absolute change (new >= old, so no abs is needed)
    plan = sys.plan
    stopping = _LooksConverged(tau)
    # the same sweep, compiled (posgmc.engines.kernels.blocks), on a system large enough to pay
    fast = scc.compiled_at(n)
    if fast:
        from posgmc.engines.kernels.blocks import sweep_lower

        plan = ()  # the numpy loop below is skipped
    while iters < max_it:
        d = 0.0
        if fast:
            d = float(
                sweep_lower(
                    A.indptr, A.indices, A.data, sys.offset, *sys.sweep_tables, x, tmp, inner,
                    0.25 * tau, rel,
                )
            )
        for r0, r1, ml, a, nl, b, ents in plan:
            yb = y[r0:r1]
            for k in range(inner):
                yb[:] = sys.offset[r0:r1]
                accumulate_rows(A, r0, r1, x, yb)
                reduce_entries(ents, y, tmp)
                dk = 0.0
                for lo, cnt in ((ml, a), (nl, b)):
                    if not cnt:
                        continue
                    new, old = tmp[lo : lo + cnt], x[lo : lo + cnt]
                    np.maximum(new, old, out=new)
                    if rel:
                        dk = max(dk, max_change(new, old, rel))
                    else:
                        change = np.subtract(new, old, out=step[lo : lo + cnt])
                        dk = max(dk, float(change.max()))
                    old[:] = new
                if k == 0:
                    d = max(d, dk)
                if dk <= 0.25 * tau:
                    break
        iters += 1
        if stopping.after(d):
            break
        if _late(deadline, iters):
            break
    return x, iters


def _sweep_pair(sys: System, X: np.ndarray, Xn: np.ndarray, Y: np.ndarray, T: np.ndarray) -> None:
    """One Gauss-Seidel sweep of both columns of ``X`` [n, 2] into ``Xn`` (``Y`` [m, 2] and
    ``T`` [n, 2] are scratch). For the upper column: if ``Xn <= X`` then ``Xn`` is a
    pre-fixpoint, since ``B(Xn)(s) <= B(mix)(s) = Xn(s)`` for the mixed vector ``mix >= Xn`` that
    state s was evaluated on; so the verification test is the same as for a Jacobi step."""
    A = sys.matrix
    if scc.compiled_at(sys.n):  # compiled, the same sweep
        from posgmc.engines.kernels.blocks import sweep_pair

        upper = sys.offset if sys.offset_upper is None else sys.offset_upper
        sweep_pair(A.indptr, A.indices, A.data, sys.offset, upper, *sys.sweep_tables, X, Xn, T)
        return
    Xn[:] = X
    for r0, r1, ml, a, nl, b, ents in sys.plan:
        Yb = Y[r0:r1]
        Yb[:] = sys.offset[r0:r1, None]
        if sys.offset_upper is not None:
            Yb[:, 1] = sys.offset_upper[r0:r1]
        accumulate_rows(A, r0, r1, Xn, Yb)
        reduce_entries(ents, Y, T)
        Xn[ml : ml + a] = T[ml : ml + a]
        Xn[nl : nl + b] = T[nl : nl + b]


def solve(
    sys: System,
    options: SolverOptions,
    *,
    cap: float,
    ec: EndComponents = EndComponents.NONE,
    inner: int = 1,
    spread: float = 0.0,
) -> Bounds:
    """Bounds on the least fixpoint of the system's Bellman operator (see the module docstring).

    Args:
        sys: the system.
        options: precision, relative/absolute, iteration cap; ``Method.VALUE`` gives plain value
            iteration (lower = upper, unsound); every other method gets interval bounds.
        cap: an a-priori upper bound on every value (1 for probabilities, inf if none is known).
        ec: the end-component treatment.
        inner: repeated updates of a Gauss-Seidel block before the next (see
            :func:`_lower_phase_blocks`; the topological solver's bands use more than one).
        spread: part of the precision that is inherited (a band whose upper constants exceed
            its lower ones, :mod:`posgmc.engines.topological`): the guessed upper bound adds
            ``spread`` to the usual ``precision`` (absolute, or relative like the precision), and
            the lower iteration goes on to ``(precision - spread) / 64``: a band's guess only
            verifies once its lower bound is close to the fixpoint of the internal rows, and a
            verification step (two columns, Jacobi with deflation) costs far more than a
            Gauss-Seidel sweep of the lower bound (the 476k-state rover: 239 instead of 989 steps).

    Returns:
        :class:`Bounds` in local order.
    """
    if sys.n == 0:
        empty = np.zeros(0)
        return Bounds(empty, empty.copy(), 0, True, options.method is not Method.VALUE)
    treatment = _Treatment.start(sys, ec)
    if options.method is Method.VALUE:
        return _value_iteration(sys, options, treatment)
    return _interval_iteration(sys, options, treatment, cap=cap, inner=inner, spread=spread)


# --- the end-component treatment ------------------------------------------------------------------


@dataclass(eq=False)
class _Treatment:
    """The end-component treatment of one solve, as it evolves (see the module docstring).

    ``family`` is fixed for one-player systems; in a game the maximiser's components depend on the
    minimiser's optimal choices, so ``refresh`` says the family is recomputed from the current
    bounds, and (DEFLATE) only once ``needed``: the costly decomposition waits until a guess fails
    to verify without it."""

    ec: EndComponents
    family: _Family | None = None
    refresh: bool = False
    deflating: bool = False
    inflating: bool = False
    needed: bool = False

    @classmethod
    def start(cls, sys: System, ec: EndComponents) -> _Treatment:
        mixed = 0 < sys.num_max < sys.n
        t = cls(ec, needed=ec is EndComponents.INFLATE)
        if ec is EndComponents.DEFLATE and sys.num_max > 0:
            if mixed:
                t.refresh = t.deflating = True
            else:
                t.family = _family(sys, np.ones(sys.m, dtype=bool), ec)
                t.deflating = t.family is not None
        elif ec is EndComponents.INFLATE and sys.num_max < sys.n:
            # the lower bound needs the minimiser's components from the first step on
            t.family = _family(sys, np.ones(sys.m, dtype=bool), ec)
            t.inflating = t.family is not None
            t.refresh = t.inflating and mixed
        return t

    @property
    def found(self) -> bool:
        """The treated player has (or, in a game, may have) end components."""
        return self.family is not None or self.refresh

    def recompute(self, sys: System, lo: np.ndarray, hi: np.ndarray) -> None:
        """The family for the bounds ``lo``/``hi`` (finite), the opponent restricted to its optimal
        choices: the minimiser's for the lower bound (DEFLATE), the maximiser's for the upper
        bound (INFLATE)."""
        y = choice_values(sys, np.ascontiguousarray(np.stack([lo, hi], axis=1)))
        opt = np.empty((sys.n, 2))
        reduce_into(sys, y, opt)
        rs = sys.row_state
        if self.ec is EndComponents.DEFLATE:
            tol = 1e-12 * (1.0 + np.abs(opt[rs, 0]))
            keep = sys.row_maximize | (y[:, 0] <= opt[rs, 0] + tol)
        else:
            tol = 1e-12 * (1.0 + np.abs(opt[rs, 1]))
            keep = ~sys.row_maximize | (y[:, 1] >= opt[rs, 1] - tol)
        self.family = _family(sys, keep, self.ec)


# --- plain value iteration ------------------------------------------------------------------------


def _value_iteration(sys: System, options: SolverOptions, treatment: _Treatment) -> Bounds:
    """``Method.VALUE``: iteration from 0 until a step changes the vector by at most the precision
    (lower = upper, not sound)."""
    lower = np.zeros(sys.n)
    scratch = np.empty(sys.n)
    y = np.empty(sys.m)
    family = treatment.family if treatment.inflating else None
    iters = 0
    converged = False
    while iters < options.max_iterations:
        multiply_into(sys, lower, y)
        reduce_into(sys, y, scratch)
        if family is not None:
            family.inflate(sys.offset, scratch)
        iters += 1
        d = max_change(scratch, lower, options.relative)
        lower, scratch = scratch, lower
        if d <= options.precision:
            converged = True
            break
        if _late(options.deadline, iters):
            break
    return Bounds(lower, lower.copy(), iters, converged, False, treatment.found)


# --- optimistic interval iteration ----------------------------------------------------------------


@dataclass(eq=False)
class _Run:
    """The state of one optimistic interval iteration: the pair ``X`` [n, 2] (lower and upper
    column), its successor ``Xn`` and scratch ``Y`` [m, 2], ``T`` [n, 2]; the best upper bound
    proven so far; and where the iteration stands."""

    X: np.ndarray
    Xn: np.ndarray
    Y: np.ndarray
    T: np.ndarray
    proven_upper: np.ndarray
    iters: int = 0
    verified: bool = False
    converged: bool = False
    stalled: bool = False

    def swap(self) -> None:
        self.X, self.Xn = self.Xn, self.X


def _interval_iteration(
    sys: System,
    options: SolverOptions,
    treatment: _Treatment,
    *,
    cap: float,
    inner: int,
    spread: float,
) -> Bounds:
    """Rounds of: the lower bound by value iteration until it stalls, a guessed upper bound, its
    verification (:func:`_verify`); a failed guess shrinks the lower iteration's threshold."""
    n = sys.n
    prec = options.precision
    rel = options.relative
    max_it = options.max_iterations
    lower = np.zeros(n)
    run = _Run(
        X=np.empty((n, 2)),
        Xn=np.empty((n, 2)),
        Y=np.empty((sys.m, 2)),
        T=np.empty((n, 2)),
        proven_upper=np.full(n, cap, dtype=np.float64),
    )
    tau = max(prec - spread, 0.25 * prec) * (1 / 64 if spread else 1.0)
    if treatment.inflating:
        _raised_upper(sys, options, run, cap)
    run.X[:, 0] = lower
    run.X[:, 1] = run.proven_upper
    deadline = options.deadline
    while (
        run.iters < max_it
        and not run.converged
        and not run.stalled
        and not _late(deadline, 0)
    ):
        phase_start = run.iters
        if sys.num_blocks > 1 and not treatment.inflating and HAVE_KERNELS:
            lower, run.iters = _lower_phase_blocks(
                sys, lower, tau, rel, run.iters, max_it, inner, deadline
            )
        else:
            family = treatment.family if treatment.inflating else None
            lower, run.iters = _lower_phase(
                sys, lower, tau, rel, run.iters, max_it, family, deadline
            )
        if rel:
            guess = lower + (prec + spread) * np.abs(lower)
            guess[lower == 0] += prec + spread
        else:
            guess = lower + prec + spread
        run.X[:, 0] = lower
        run.X[:, 1] = run.proven_upper if run.verified else np.minimum(guess, run.proven_upper)
        if treatment.refresh and treatment.needed:
            treatment.recompute(sys, run.X[:, 0].copy(), _finite(run.X[:, 1]))
        _verify(sys, options, treatment, run, budget=max(16, run.iters - phase_start))
        lower = np.ascontiguousarray(run.X[:, 0])
        if not run.verified:
            tau = max(tau / 4.0, 1e-15)
    return _final_bounds(run, lower, cap, treatment)


def _finite(x: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(x), x, 0.0)


def _raised_upper(sys: System, options: SolverOptions, run: _Run, cap: float) -> None:
    """The first proven upper bound under inflation. Park induction does not reach the value here
    (the least fixpoint undercounts), so the upper bound starts from the problem with every zero
    constant raised to eps > 0: its value is larger, it has no zero-reward end components (unique
    fixpoint, so optimistic iteration proves it), and B^k of an upper bound stays an upper
    bound."""
    positive = sys.offset[sys.offset > 0]
    eps = float(positive.min()) if positive.size else 1.0
    raised = replace(
        sys,
        offset=np.maximum(sys.offset, eps),
        offset_upper=None if sys.offset_upper is None else np.maximum(sys.offset_upper, eps),
    )
    first = solve(raised, replace(options, want_strategy=False), cap=cap, ec=EndComponents.NONE)
    run.iters += first.iterations
    run.proven_upper = first.upper.copy()
    run.verified = bool(np.all(np.isfinite(run.proven_upper)))


def _verify(
    sys: System, options: SolverOptions, treatment: _Treatment, run: _Run, *, budget: int
) -> None:
    """Both bounds stepped together from the guess in ``run.X``: until the upper column is proven
    a pre-fixpoint (``F(U) <= U``; then every further iterate stays above the value), the guess
    falls below the lower bound or ``budget`` steps pass without a proof (a failed guess); after
    a proof, until the gap meets the precision or stops shrinking. The end-component family is
    refreshed on the way in a game (see :class:`_Treatment`)."""
    prec = options.precision
    steps = 0
    since_refresh = 0
    last_gap = np.inf
    while run.iters < options.max_iterations:
        X, Xn = run.X, run.Xn
        family = treatment.family
        if family is None and sys.num_blocks > 1 and HAVE_KERNELS:
            _sweep_pair(sys, X, Xn, run.Y, run.T)
        else:
            multiply_into(sys, X, run.Y)
            reduce_into(sys, run.Y, Xn)
        if family is not None:
            if treatment.deflating:
                family.deflate(run.Y[:, 1], Xn[:, 1])
            if treatment.inflating:
                family.inflate(sys.offset, Xn[:, 0])
        run.iters += 1
        steps += 1
        since_refresh += 1
        # the lower bound only grows; keep the best
        np.maximum(Xn[:, 0], X[:, 0], out=Xn[:, 0])
        if not run.verified:
            # F(U) <= U up to rounding noise (a few ulps; the final widening covers it)
            slack = _NOISE * np.abs(X[:, 1])
            if bool(np.all(Xn[:, 1] <= X[:, 1] + slack)):
                run.verified = True
                np.minimum(run.proven_upper, np.maximum(Xn[:, 1], X[:, 1]), out=run.proven_upper)
            elif np.any(Xn[:, 1] < Xn[:, 0] - _ROUNDING * np.abs(Xn[:, 0])):
                # the guess is below the value somewhere: it cannot verify. Only a crossing
                # beyond the rounding of the lower iterate says so; within it, an upper iterate
                # already at the value (a deflated end component whose best exit is exact)
                # would fail every guess forever and the upper bound would never be proven.
                run.swap()
                return
        else:
            # the iterates of F from a pre-fixpoint stay above the value
            np.minimum(run.proven_upper, Xn[:, 1], out=run.proven_upper)
            Xn[:, 1] = run.proven_upper
        run.swap()
        X = run.X
        if run.verified and gap_ok(X[:, 0], X[:, 1], prec, options.relative):
            run.converged = True
            return
        if not run.verified and steps >= budget:
            return
        if (
            not run.verified
            and treatment.refresh
            and not treatment.needed
            and steps >= max(8, budget // 2)
        ):
            # the guess does not verify by itself: the maximiser's end components matter
            treatment.needed = True
            treatment.recompute(sys, X[:, 0].copy(), _finite(X[:, 1]))
            since_refresh = 0
        if run.verified and treatment.refresh and treatment.needed and since_refresh >= 32:
            treatment.recompute(sys, X[:, 0].copy(), X[:, 1].copy())
            since_refresh = 0
        if _late(options.deadline, run.iters):
            return  # out of time: the bounds so far stay proven (converged = False)
        if run.verified and steps % 1000 == 0:
            # give up when the gap no longer shrinks (bounds stay proven; converged = False)
            gap = float(np.max(X[:, 1] - X[:, 0]))
            if gap >= last_gap * (1.0 - 1e-9):
                run.stalled = True
                return
            last_gap = gap


def _final_bounds(run: _Run, lower: np.ndarray, cap: float, treatment: _Treatment) -> Bounds:
    """The proven bounds, widened outwards for rounding (:func:`widen`) and capped."""
    upper = run.proven_upper if not run.converged else np.minimum(run.proven_upper, run.X[:, 1])
    lower, upper = widen(np.minimum(lower, upper), upper)
    upper = np.minimum(upper, cap)
    return Bounds(
        np.ascontiguousarray(lower),
        np.ascontiguousarray(upper),
        run.iters,
        run.converged,
        True,
        treatment.found,
    )


def solve_discounted(sys: System, options: SolverOptions) -> tuple[Bounds, np.ndarray]:
    """Bounds on the unique fixpoint of a contracting system (its matrix already scaled by the
    discount factor ``d``, which the caller passes as ``sys`` with every row leaking ``1 - d``).

    Value iteration from 0; after a step that changed the vector by ``delta`` (sup norm) the
    fixpoint is within ``d / (1 - d) * delta`` of the iterate (Banach), which gives the bounds and
    the stopping rule. Rewards of any sign are fine.

    Returns:
        ``(bounds, best_rows)``: :class:`Bounds` in local order and the greedy row per state.
    """
    n, m = sys.n, sys.m
    row_sums = np.asarray(sys.matrix.sum(axis=1)).ravel() if m else np.zeros(0)
    discount = float(row_sums.max(initial=0.0))
    factor = discount / (1.0 - discount) if discount < 1.0 else np.inf
    cur = np.zeros(n)
    nxt = np.empty(n)
    y = np.empty(m)
    iters = 0
    bound = np.inf if n else 0.0
    converged = n == 0
    while n and iters < options.max_iterations:
        multiply_into(sys, cur, y)
        reduce_into(sys, y, nxt)
        iters += 1
        d = float(np.max(np.abs(nxt - cur), initial=0.0))
        cur, nxt = nxt, cur
        bound = factor * d if discount > 0 else 0.0
        scale = float(np.max(np.abs(cur), initial=0.0)) if options.relative else 1.0
        if bound <= options.precision * max(scale, 1e-300):
            converged = True
            break
    multiply_into(sys, cur, y)
    best = argopt_rows(sys, y) if n else np.zeros(0, dtype=np.int64)
    if options.method is Method.VALUE:
        return Bounds(cur, cur.copy(), iters, converged, False), best
    lo, hi = widen(cur - bound, cur + bound)
    return Bounds(lo, hi, iters, converged, True), best
