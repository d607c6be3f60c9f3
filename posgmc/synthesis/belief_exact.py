"""The exact-arithmetic side of the grid abstraction (:mod:`posgmc.synthesis.belief_grid`): the
exact belief successors of a maximiser's choices, in integers and fractions.

A maximiser's rows cannot dominate the exact ones one by one in a cycle of beliefs
(docs/synthesis.md, "Floating point"): its abstraction carries an enclosure of the exact rows.
This module computes what that enclosure needs exactly: each row's exact continuing vector
(:func:`exact_rows`: the exact model's rows, the vertex beliefs counts/N, an adversary's rule as
the rational rule it stands for, :class:`Source`), the unfolding's exact posteriors
(:func:`exact_posterior`, shared between parts reached by the same choices, :func:`shared_parts`,
:func:`part_posterior`), and the parts near a face of the triangulation triangulated again in
exact rational arithmetic (:func:`resolve_exactly`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sp

from posgmc.synthesis.belief_dynamics import Dynamics
from posgmc.synthesis.belief_rounding import UNIT

__all__ = ["Source", "exact_posterior", "exact_rows", "part_posterior", "resolve_exactly",
           "shared_parts"]


@dataclass(frozen=True, eq=False)
class Source:
    """What a maximiser's choices' successors are made of, for :func:`resolve_exactly`: the
    rows D = B T with ``B`` csr float64[rows, columns], ``choice_of`` the model choice of each
    column. Without ``rule`` B's entries are exact as stored (vertex beliefs counts/N, N a
    power of two). With it (an adversary's rows: ``rule`` and ``mass`` csr in B's layout, B
    = rule · mass entrywise, rounded) the exact row is the rational rule of
    :func:`_rational_rule` (each state's probabilities normalised to sum to 1 exactly) times
    the states' exact masses: a rule the adversary may play, so offering it only restricts the
    minimising adversary; its entries lie within a few units of roundoff of B's (covered by the
    doubled rounding of :func:`~posgmc.synthesis.belief_rounding.entry_rounding`). ``beliefs``:
    on the unfolding, each row's vertex's exact belief (None where only its float is known);
    ``resolve``: bool per row, the rows whose ambiguous grid parts :func:`resolve_exactly` may
    triangulate again (None: all)."""

    B: sp.csr_matrix
    choice_of: np.ndarray
    mass: sp.csr_matrix | None = None
    rule: sp.csr_matrix | None = None
    beliefs: list[tuple[dict[int, int], int] | None] | None = None
    resolve: np.ndarray | None = None
    exact_rules: dict[int, dict[int, Fraction]] | None = None
    """Rows whose rule is given exactly (global choice -> probability): the unfolding's rules
    that land on an explored belief (:mod:`posgmc.synthesis.target_rules`)."""


_SIMPLE_DENOMINATOR = 1000
"""Rule probabilities within a few units of roundoff of a fraction with at most this
denominator are taken as that fraction (a grid rule's are such fractions: its posterior is then
the grid vertex exactly, not a hair off it)."""


def _rational_rule(probs: list[float], states: list[int]) -> list[Fraction]:
    """A randomised rule's stored probabilities (each state's summing to 1 up to a few units of
    roundoff: every rule here is normalised by its float sum) as an exact rule: each
    probability the simple fraction it rounds (:data:`_SIMPLE_DENOMINATOR`) or else its float's
    own value, then divided by its state's sum, so that each state's probabilities sum to 1
    exactly and each lies within (n + 4) u of the float (n the state's choices)."""
    near = [_rational_probability(x) for x in probs]
    total: dict[int, Fraction] = {}
    for s, q in zip(states, near):
        total[s] = total.get(s, Fraction(0)) + q
    return [q / total[s] for s, q in zip(states, near)]


@functools.lru_cache(maxsize=65536)
def _rule_ratios(probs: tuple[float, ...], states: tuple[int, ...]) -> tuple[tuple[int, int], ...]:
    """:func:`_rational_rule` as (numerator, denominator) pairs, cached: the same rules recur at
    every vertex on the same support."""
    return tuple((q.numerator, q.denominator) for q in _rational_rule(list(probs), list(states)))


@functools.lru_cache(maxsize=4096)
def _rational_probability(x: float) -> Fraction:
    """The simple fraction (:data:`_SIMPLE_DENOMINATOR`) within 4 u of ``x``, else ``x``'s own
    value (cached: the same few probabilities recur in every rule)."""
    q = Fraction(x)
    simple = q.limit_denominator(_SIMPLE_DENOMINATOR)
    return simple if abs(simple - q) <= q * 4 * Fraction(UNIT) else q


def _row_entries(cols: list[int], stored: list[float], states: list[int], rule: list[float],
                 deterministic: bool, belief: tuple[dict[int, int], int] | None,
                 has_rule: bool, given: dict[int, Fraction] | None = None,
                 chosen: list[int] | None = None) -> list[tuple[int, int, int]]:
    """One row of B*'s exact entries (:class:`Source`): (column, its exact rational weight as
    numerator and denominator), from the row's columns, stored weights (B's, or with a rule
    the states' masses), the columns' states and the rule's probabilities (with ``has_rule``),
    whether the rule is deterministic, and the row's vertex's exact belief (None: its float);
    ``given``: the rule itself where it is given exactly (:attr:`Source.exact_rules`, by the
    columns' model choices ``chosen``), else it is the rational rule of the probabilities.
    An exact belief's numerator and a rule's are multiplied, not reduced: the row's common
    denominator absorbs any common factor (:func:`exact_rows` scales the row as a whole)."""
    if not has_rule:
        if belief is not None:  # columns are the belief's states
            nums, den = belief
            return [(k, nums[k], den) for k in cols]
        return [(k, *b.as_integer_ratio()) for k, b in zip(cols, stored)]
    if deterministic and given is None:  # every probability 1: the rational rule is 1 too
        if belief is not None:
            nums, den = belief
            return [(k, nums[s], den) for k, s in zip(cols, states)]
        # each entry is its state's mass, exact as stored
        return [(k, *p.as_integer_ratio()) for k, p in zip(cols, stored)]
    ratios = _rule_ratios(tuple(rule), tuple(states)) if given is None or chosen is None else \
        [(given[c].numerator, given[c].denominator) for c in chosen]
    if belief is not None:
        nums, den = belief
        return [(k, nums[s] * qn, den * qd) for k, s, (qn, qd) in zip(cols, states, ratios)]
    return [(k, pn * qn, pd * qd)
            for k, (pn, pd), (qn, qd) in zip(cols, [p.as_integer_ratio() for p in stored],
                                             ratios)]


def exact_rows(source: Source, rows: np.ndarray, dyn: Dynamics) -> dict[int, dict[int, int]]:
    """Each of ``rows``' (distinct) exact continuing vector y*_s = Σ_k B*_rk T*_k(s) on all its
    successor states (the exact model's rows :meth:`Dynamics.integer_row`, B*'s entries
    :func:`_row_entries`), as integer numerators (state -> numerator, zeros left out) over
    one common denominator per row, a positive factor the triangulation ignores (the parts of
    one row share it). The rows' columns, choices, states, stored weights and rule
    probabilities are gathered in one vectorised step, then read row by row as list slices."""
    B = source.B
    lo, hi = B.indptr[rows].astype(np.int64), B.indptr[rows + 1].astype(np.int64)
    n = hi - lo
    ends = np.cumsum(n)
    flat = np.repeat(lo - (ends - n), n) + np.arange(int(ends[-1]) if n.size else 0)
    cols = B.indices[flat]
    choice_arr = source.choice_of[cols]
    choices = choice_arr.tolist()
    has_rule = source.rule is not None and source.mass is not None
    rule_l: list[float] = []
    states_l: list[int] = []
    if source.rule is None or source.mass is None:
        stored = B.data[flat]
        deterministic = np.ones(rows.size, dtype=bool)
    else:
        stored = source.mass.data[flat]
        probs = source.rule.data[flat]
        owner = np.repeat(np.arange(rows.size), n)
        deterministic = np.bincount(owner[probs != 1.0], minlength=rows.size) == 0
        rule_l = probs.tolist()
    beliefs: list[tuple[dict[int, int], int] | None] = [None] * rows.size
    if source.beliefs is not None:
        beliefs = [source.beliefs[r] for r in rows.tolist()]
    if has_rule:
        states_l = dyn.choice_states[choice_arr].tolist()
    weights = stored.tolist()
    cols_l = cols.tolist()
    out: dict[int, dict[int, int]] = {}
    start = 0
    made = dyn.integer_rows  # the exact rows already made
    given = source.exact_rules or {}
    for r, end, det, known in zip(rows.tolist(), ends.tolist(), deterministic.tolist(),
                                  beliefs):
        exactly = given.get(r)
        entries = _row_entries(cols_l[start:end], weights[start:end], states_l[start:end],
                               rule_l[start:end], det, known, has_rule, exactly,
                               None if exactly is None else choices[start:end])
        exact = [made.get(c) or dyn.integer_row(c) for c in choices[start:end]]
        start = end
        dens = [bd * total for (_, _, bd), (_, total) in zip(entries, exact)]
        den = math.lcm(*dens) if dens else 1
        y: dict[int, int] = {}
        get = y.get
        for (_, bn, _), (row, _), d in zip(entries, exact, dens):
            f = bn * (den // d)
            for s, c in row:
                y[s] = get(s, 0) + f * c
        out[r] = y
    return out


_EXACT_BITS = 128
"""The unfolding keeps a posterior exact while its common denominator has at most this many
bits (long paths multiply denominators); beyond, the float posterior with a leak."""


def exact_posterior(y: dict[int, int], states: list[int]) -> tuple[tuple[int, ...], int] | None:
    """A row's exact posterior on ``states`` (one part: the continuing states of one
    observation group; ``y`` the row's exact vector, :func:`exact_rows`) as numerators and a
    common denominator without a common divisor
    (:meth:`~posgmc.synthesis.belief_grid._Grid.exact_belief`), None when it is zero or too long
    to keep (:data:`_EXACT_BITS`). Invariant under scaling ``y``."""
    get = y.get
    ys = [get(s, 0) for s in states]
    total = sum(ys)
    if total <= 0 or min(ys) <= 0:
        return None
    g = math.gcd(*ys)
    den = total // g
    if den.bit_length() > _EXACT_BITS:
        return None
    return tuple([y // g for y in ys]), den


def shared_parts(source: Source, live: np.ndarray, rows: np.ndarray, starts: np.ndarray,
                 sizes: np.ndarray, col: np.ndarray, vertex: np.ndarray, dyn: Dynamics
                 ) -> tuple[list[tuple[int, int, bytes, tuple[tuple[int, int], ...]] | None],
                            np.ndarray]:
    """The unfolding's parts whose exact posterior is computed from the few choices that reach
    them, once per distinct signature, instead of from their row's whole exact vector: an
    adversary's deterministic rule at a vertex with an exact belief b = nums/den puts b(s_c) on
    one choice c per state s_c, so the row's exact vector is, up to a positive factor
    (:func:`exact_rows`' common denominator, which :func:`exact_posterior` ignores),
    Σ_c nums(s_c) T*_c / |T*_c| (|T*_c| the exact row's denominator), and on a part's states
    (all in group z) only the choices whose continuing successors meet z add anything. The
    parts of ``live`` rows (those :func:`exact_rows` would compute, ascending; ``vertex``:
    each row's vertex) with a deterministic rule get the signature (vertex, z, the states'
    bytes, those choices with their states, in the row's order), the others None (their
    posterior comes from their row's exact vector); returns the signatures and the live rows
    whose exact vector is still needed (a randomised rule, or one given exactly)."""
    n = starts.size
    sigs: list[tuple[int, int, bytes, tuple[tuple[int, int], ...]] | None] = [None] * n
    B, rule = source.B, source.rule
    if rule is None or not live.size:
        return sigs, live
    lo, hi = B.indptr[live].astype(np.int64), B.indptr[live + 1].astype(np.int64)
    k = hi - lo
    ends = np.cumsum(k)
    flat = np.repeat(lo - (ends - k), k) + np.arange(int(ends[-1]))
    owner = np.repeat(np.arange(live.size), k)
    deterministic = np.bincount(owner[rule.data[flat] != 1.0], minlength=live.size) == 0
    if source.exact_rules:  # a rule given exactly is its own (:func:`_row_entries`)
        deterministic &= ~np.isin(live, np.fromiter(source.exact_rules, dtype=np.int64))
    choices = source.choice_of[B.indices[flat]]
    choices_l = choices.tolist()
    touch = dyn.touches
    # each entry: (its choice, the choice's state) and the groups the choice reaches
    pairs = list(zip(choices_l, dyn.choice_states[choices].tolist()))
    reach = [touch(c) for c in choices_l]
    row_cols: dict[int, tuple[list[tuple[int, int]], list[frozenset[int]]]] = {}
    at = 0
    for r, end, det in zip(live.tolist(), ends.tolist(), deterministic.tolist()):
        if det:
            row_cols[r] = (pairs[at:end], reach[at:end])
        at = end
    col_b = col.tobytes()
    groups = dyn.group[col[starts]].tolist()
    vertex_l = vertex.tolist()
    for j, (a, m, r, z) in enumerate(zip(starts.tolist(), sizes.tolist(), rows.tolist(), groups)):
        found = row_cols.get(r)
        if found is not None:
            sigs[j] = (vertex_l[r], z, col_b[8 * a:8 * (a + m)],
                       tuple([p for p, t in zip(*found) if z in t]))
    return sigs, live[~deterministic]


def part_posterior(reach: tuple[tuple[int, int], ...], belief: tuple[dict[int, int], int],
                   states: list[int], dyn: Dynamics) -> tuple[tuple[int, ...], int] | None:
    """:func:`exact_posterior` of a part of a deterministic rule's row from the choices that
    reach it (:func:`shared_parts`: (choice, its state) pairs) and the vertex's exact belief:
    Σ_c nums(s_c) (L / |T*_c|) T*_c, L the least common multiple of the |T*_c|."""
    nums = belief[0]
    made = dyn.integer_rows
    exact = [made.get(c) or dyn.integer_row(c) for c, _ in reach]
    big = math.lcm(*[t for _, t in exact]) if exact else 1
    y: dict[int, int] = {}
    get = y.get
    for (_, s), (row, t) in zip(reach, exact):
        f = nums[s] * (big // t)
        for q, x in row:
            y[q] = get(q, 0) + f * x
    return exact_posterior(y, states)


def resolve_exactly(parts: np.ndarray, rows: np.ndarray, cols: np.ndarray, counts: np.ndarray,
                    lam: np.ndarray, eta: np.ndarray, amb: np.ndarray, rel: np.ndarray,
                    source: Source, dyn: Dynamics, N: int) -> None:
    """Ambiguous parts (near a face of the triangulation: the float simplex may not hold the
    exact posterior) triangulated in exact rational arithmetic instead, in place: the exact
    continuing vector y*_s = Σ_k B_k T*_k(s) in integers (:func:`exact_rows`,
    B*'s entries exact: the vertex belief counts/N with N a power of two, times an adversary's
    rule as the rational rule it stands for, :class:`Source`), its Freudenthal simplex and
    weights (the same construction as :func:`~posgmc.synthesis.freudenthal.freudenthal`, ties
    broken alike), so the part's vertices are the exact decomposition's and each weight is the
    float of the exact one."""
    m = cols.shape[1]
    if source.resolve is not None:
        parts = parts[source.resolve[rows[parts]]]
    # per row, its exact vector (rows may have several parts)
    exact = exact_rows(source, np.unique(rows[parts]).astype(np.int64), dyn)
    done: list[int] = []  # the parts resolved, and per part: v, each coordinate's first
    base: list[list[int]] = []  # vertex with its unit added, the exact weights' floats
    step: list[list[int]] = []
    weights: list[list[float]] = []
    for i in parts.tolist():
        y = exact[int(rows[i])]
        ys = [y.get(s, 0) for s in cols[i].tolist()]
        total = sum(ys)
        if total <= 0:
            continue
        # x_j = N Y_j / Y_0 (Y_j the tail sums): floor and remainder in the numerators' ring
        # (integers, or rationals when a row needed scaling), the weights their differences
        tails = [total] * m
        acc = 0
        for j in range(m - 1, 0, -1):
            acc += ys[j]
            tails[j] = acc
        v = [N] + [(N * tails[j]) // total for j in range(1, m)]
        rem = [0] + [N * tails[j] - v[j] * total for j in range(1, m)]
        order = sorted(range(1, m), key=lambda j: -rem[j])
        dd = [rem[j] for j in order]
        # each weight a quotient of integers, rounded once (int / int is correctly rounded)
        nums = [total - dd[0]] + [dd[q - 1] - dd[q] for q in range(1, m - 1)] + [dd[-1]]
        # vertex q adds the unit vectors of the first q coordinates in the order
        first = [0] * m  # the vertex from which each coordinate has its unit added
        for q, j in enumerate(order):
            first[j] = q + 1
        done.append(i)
        base.append(v)
        step.append(first)
        weights.append([x / total for x in nums])
    if not done:
        return
    # the simplices' vertices and the records, written for all resolved parts at once
    at = np.asarray(done, dtype=np.int64)
    F = np.asarray(step, dtype=np.int64)[:, None, :]
    vertex = np.arange(m)[None, :, None]
    Y = np.asarray(base, dtype=np.int64)[:, None, :] + ((F > 0) & (F <= vertex))  # [part, q, j]
    counts[at] = np.concatenate([Y[:, :, :-1] - Y[:, :, 1:], Y[:, :, -1:]], axis=2)
    lam[at] = np.asarray(weights, dtype=np.float64)
    amb[at] = False
    eta[at] = ((rel[at] + (m + 4) * UNIT) * 1.02 + 4.0 * UNIT)[:, None]
