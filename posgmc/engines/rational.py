"""Exact rational reachability values for small models (a reference for tests and cross-checks).

Probabilities are read as fractions (``Fraction(p).limit_denominator(d)`` recovers the decimal the
model was written with), the qualitative states come from the same graph precomputation as the
floating-point engine (exact by nature), and the rest is solved by nested policy iteration in exact
arithmetic: the maximiser's strategy is improved by strict switches against the minimiser's exact
best response, itself computed by policy iteration after the minimiser's value-0 states are settled
by graph search. Dense Gaussian elimination over ``Fraction``: meant for models with at most a few
hundred states.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from posgmc.engines.graph import almost_sure_reach, positive_reach, structure_of
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel
from posgmc.model.types import ModelType

__all__ = ["exact_bounded_reach", "exact_cumulative_reward", "exact_rational_reach", "solve_dense"]

_Row = tuple[Fraction, dict[int, Fraction]]  # (mass into value-1 states, mass into unknowns)


def solve_dense(matrix: list[list[Fraction]], rhs: list[Fraction]) -> list[Fraction]:
    """Gauss-Jordan elimination for a nonsingular system."""
    n = len(rhs)
    a = [row[:] + [rhs[i]] for i, row in enumerate(matrix)]
    for col in range(n):
        pivot = next((r for r in range(col, n) if a[r][col] != 0), None)
        if pivot is None:
            raise PosgmcError("singular system in the exact solver")
        a[col], a[pivot] = a[pivot], a[col]
        inv = 1 / a[col][col]
        a[col] = [v * inv for v in a[col]]
        for r in range(n):
            if r != col and a[r][col] != 0:
                f = a[r][col]
                a[r] = [v - f * w for v, w in zip(a[r], a[col])]
    return [a[i][n] for i in range(n)]


def _evaluate(states: list[int], rows: dict[int, _Row]) -> dict[int, Fraction]:
    """Reach probability of the chain that uses ``rows[s]`` in every unknown state s."""
    # states that can reach a row with mass into value-1 states; the others have value 0
    reaches = {s for s in states if rows[s][0] > 0}
    changed = True
    while changed:
        changed = False
        for s in states:
            if s not in reaches and any(t in reaches for t in rows[s][1]):
                reaches.add(s)
                changed = True
    live = [s for s in states if s in reaches]
    index = {s: i for i, s in enumerate(live)}
    n = len(live)
    matrix = [[Fraction(0)] * n for _ in range(n)]
    rhs = [Fraction(0)] * n
    for s in live:
        i = index[s]
        matrix[i][i] += 1
        rhs[i] = rows[s][0]
        for t, p in rows[s][1].items():
            if t in index:
                matrix[i][index[t]] -= p
    sol = solve_dense(matrix, rhs) if n else []
    out = {s: Fraction(0) for s in states}
    for s in live:
        out[s] = sol[index[s]]
    return out


def _value(row: _Row, x: dict[int, Fraction]) -> Fraction:
    return row[0] + sum((p * x[t] for t, p in row[1].items()), Fraction(0))


def _min_idle(
    states: list[int], options: dict[int, list[_Row]], is_max: dict[int, bool]
) -> set[int]:
    """States where the minimiser can keep the probability 0 (positive attractor complement)."""
    positive: set[int] = set()
    changed = True
    while changed:
        changed = False
        for s in states:
            if s in positive:
                continue
            hits = [r[0] > 0 or any(t in positive for t in r[1]) for r in options[s]]
            if any(hits) if is_max[s] else all(hits):
                positive.add(s)
                changed = True
    return {s for s in states if s not in positive}


def _best_response(
    states: list[int],
    options: dict[int, list[_Row]],
    is_max: dict[int, bool],
    choice: dict[int, int],
) -> tuple[dict[int, int], dict[int, Fraction]]:
    """The minimiser's optimal reply (policy iteration; the maximiser's rows are fixed)."""
    fixed_opts = {s: (options[s] if not is_max[s] else [options[s][choice[s]]]) for s in states}
    idle = _min_idle(states, fixed_opts, is_max)
    ch = dict(choice)
    for s in states:
        if not is_max[s] and s in idle:
            # a row keeping out of the positive region
            positive = set(states) - idle
            ch[s] = next(
                i
                for i, r in enumerate(options[s])
                if r[0] == 0 and not any(t in positive for t in r[1])
            )
    while True:
        x = _evaluate(states, {s: options[s][ch[s]] for s in states})
        improved = False
        for s in states:
            if is_max[s] or s in idle:
                continue
            vals = [_value(r, x) for r in options[s]]
            best = min(vals)
            if best < vals[ch[s]]:
                ch[s] = vals.index(best)
                improved = True
        if not improved:
            return ch, x


def exact_rational_reach(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    maximize: np.ndarray,
    limit_denominator: int | None = 10**6,
) -> list[Fraction]:
    """The exact value of ``P[remain U target]`` per state, as fractions.

    Args:
        model: a small dtmc, mdp or smg.
        target, remain: bool[S] (remain None: everywhere).
        maximize: bool[S], True where the owner maximises.
        limit_denominator: read each probability as ``Fraction(p).limit_denominator(d)``; None reads
            the exact binary value of the float. A model built in exact mode
            (``model.exact_probabilities``) is read exactly and this is ignored.

    Returns:
        One :class:`Fraction` per state.
    """
    S = model.num_states
    tgt = np.asarray(target, dtype=bool)
    rem = np.ones(S, dtype=bool) if remain is None else np.asarray(remain, dtype=bool)
    mx = (
        np.ones(S, dtype=bool)
        if model.model_type is ModelType.DTMC
        else np.asarray(maximize, dtype=bool)
    )
    g = structure_of(model)
    pos = positive_reach(g, tgt, rem, existential=mx)
    one, _ = almost_sure_reach(g, tgt, rem, existential=mx)
    unknown = pos & ~one
    T = model.transitions
    exact = model.exact_probabilities
    states = [int(s) for s in np.flatnonzero(unknown)]
    options: dict[int, list[_Row]] = {}
    for s in states:
        rows: list[_Row] = []
        for c in range(int(model.row_groups[s]), int(model.row_groups[s + 1])):
            lo, hi = T.indptr[c], T.indptr[c + 1]
            mass = Fraction(0)
            succ: dict[int, Fraction] = {}
            for k, (t, p) in enumerate(zip(T.indices[lo:hi], T.data[lo:hi])):
                if exact is not None:
                    f = exact[lo + k]
                else:
                    f = Fraction(float(p))
                    if limit_denominator is not None:
                        short = f.limit_denominator(limit_denominator)
                        # the decimal the model was written with, if it is the one the double holds
                        f = short if float(short) == float(p) else f
                if one[t]:
                    mass += f
                elif unknown[t]:
                    succ[int(t)] = succ.get(int(t), Fraction(0)) + f
            rows.append((mass, succ))
        options[s] = rows
    is_max = {s: bool(mx[s]) for s in states}
    choice = {s: 0 for s in states}
    x: dict[int, Fraction] = {}
    while states:
        choice, x = _best_response(states, options, is_max, choice)
        improved = False
        for s in states:
            if not is_max[s]:
                continue
            vals = [_value(r, x) for r in options[s]]
            best = max(vals)
            if best > vals[choice[s]]:
                choice[s] = vals.index(best)
                improved = True
        if not improved:
            break
    out = [Fraction(1) if one[s] else Fraction(0) for s in range(S)]
    for s in states:
        out[s] = x[s]
    return out


def exact_bounded_reach(
    model: ExplicitModel,
    target: np.ndarray,
    *,
    remain: np.ndarray | None = None,
    steps: int,
    maximize: np.ndarray,
    next_only: bool = False,
) -> list[Fraction]:
    """The exact value of ``P[remain U<=steps target]`` (or of ``P[X target]`` with ``next_only``)
    per state, by ``steps`` rounds of backward induction in rational arithmetic on a model built
    in exact mode (``model.exact_probabilities``). Each round optimises per state: the owner's
    best choice (``maximize``) against the others' worst."""
    exact = model.exact_probabilities
    if exact is None:
        raise PosgmcError("exact bounded reachability needs a model built in exact mode")
    S = model.num_states
    tgt = [bool(v) for v in np.asarray(target, dtype=bool)]
    rem = [True] * S if remain is None else [bool(v) for v in np.asarray(remain, dtype=bool)]
    mx = [True] * S if model.model_type is ModelType.DTMC else [bool(v) for v in maximize]
    T = model.transitions
    indptr, indices, groups = T.indptr, T.indices, model.row_groups

    def step(x: list[Fraction]) -> list[Fraction]:
        out = []
        for s in range(S):
            vals = [
                sum(
                    (exact[k] * x[indices[k]] for k in range(indptr[c], indptr[c + 1])), Fraction(0)
                )
                for c in range(int(groups[s]), int(groups[s + 1]))
            ]
            out.append(max(vals) if mx[s] else min(vals))
        return out

    if next_only:
        return step([Fraction(int(t)) for t in tgt])
    x = [Fraction(int(t)) for t in tgt]
    for _ in range(steps):
        y = step(x)
        x = [Fraction(1) if tgt[s] else (y[s] if rem[s] else Fraction(0)) for s in range(S)]
    return x


def exact_cumulative_reward(
    model: ExplicitModel,
    choice_rewards: list[Fraction],
    *,
    steps: int,
    maximize: np.ndarray,
) -> list[Fraction]:
    """The exact expected reward collected in the first ``steps`` steps (``R[ C<=steps ]``) per
    state, by backward induction in rational arithmetic on a model built in exact mode:
    ``x_0 = 0``, ``x_{i+1}(s) = opt_c ( r(c) + sum_t P(c, t) x_i(t) )``, each state's owner
    maximising (``maximize``) or minimising.

    Args:
        model: a dtmc, mdp or smg with ``exact_probabilities``.
        choice_rewards: one Fraction per choice (state reward plus action reward).
        steps: the step bound k >= 0.
        maximize: bool[S].

    Raises:
        PosgmcError: the model was not built in exact mode.
    """
    exact = model.exact_probabilities
    if exact is None:
        raise PosgmcError("exact cumulative rewards need a model built in exact mode")
    S = model.num_states
    mx = [True] * S if model.model_type is ModelType.DTMC else [bool(v) for v in maximize]
    T = model.transitions
    indptr, indices, groups = T.indptr, T.indices, model.row_groups
    x = [Fraction(0)] * S
    for _ in range(steps):
        y = []
        for s in range(S):
            vals = [
                choice_rewards[c]
                + sum((exact[k] * x[indices[k]] for k in range(indptr[c], indptr[c + 1])),
                      Fraction(0))
                for c in range(int(groups[s]), int(groups[s + 1]))
            ]
            y.append(max(vals) if mx[s] else min(vals))
        x = y
    return x
