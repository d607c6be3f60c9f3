"""Deterministic finite automata for co-safe LTL: construction by progression, and minimisation.

The DFA of a co-safe formula ``phi`` over atoms ``a_0 .. a_{n-1}`` reads letters ``sigma`` in
``[0, 2**n)`` (bit i of sigma = atom i holds) and accepts exactly the *good prefixes* of ``phi``:
the finite words all of whose infinite extensions satisfy ``phi``. Accepting states are absorbing,
so a run accepts as soon as it has read a good prefix, and an infinite word satisfies ``phi`` iff
its run visits an accepting state.

Reading convention: the DFA reads the letter of the CURRENT model state before moving. A path
``s0 s1 s2 ...`` of a model gives the run ``q1 = delta[q0, L(s0)]``, ``q2 = delta[q1, L(s1)]``, ...,
so the initial product state is ``(s0, delta[q0, L(s0)])`` (PRISM's convention) and
``(s_i, q_{i+1})`` is accepting iff ``s0 .. s_i`` is a good prefix.

Construction:

1. translate to NNF over a hash-consed formula algebra and check syntactic co-safety
   (:mod:`posgmc.engines.ltl.cosafe`);
2. explore breadth-first from the formula, the successor of state ``f`` on letter ``sigma`` being
   ``progress(f, sigma)``; for each state only the atoms its progression reads are enumerated and
   the successor table is broadcast to all ``2**n`` letters with numpy; ``true`` is accepting;
3. (only with ``exact_good_prefixes``) make accepting every state from which every infinite word
   reaches ``true``. By default acceptance is progression reaching ``true``, which is PRISM's
   rule for where ``R[co-safe]`` stops collecting reward: a state formula (an atom, or the
   constant ``true``) is satisfied only by reading the letter of an existing position, so
   ``R[X true]`` collects exactly one step and ``R[(X X true) U a]`` waits for the second step
   after the first ``a`` (PRISM's ``dtmc_rewards.pm.cosafety.props``). Probabilities do not
   depend on the choice, since every infinite word from such a state reaches ``true``;
4. minimise (Moore's partition refinement, one ``np.unique`` over state signatures per round, on
   the alphabet compressed to classes of letters with identical columns).

After minimisation there is at most one accepting state and at most one rejecting sink (a state
from which no accepting state is reachable), since each is a language-equivalence class.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from posgmc.errors import LimitError, UnsupportedError
from posgmc.syntax.ast import Expr
from posgmc.engines.ltl.cosafe import (
    BoundEvaluator,
    FormulaTable,
    cosafe_error,
    extract_atoms,
    translate,
)

__all__ = ["Dfa", "to_dfa", "minimise"]

DEFAULT_MAX_ATOMS = 16
DEFAULT_MAX_STATES = 100_000


@dataclass(frozen=True, eq=False)
class Dfa:
    """A complete DFA over the letters ``[0, 2**len(atoms))``.

    ``num_states``: Q. ``initial``: the initial state, in [0, Q).
    ``accepting``: bool[Q]; accepting states are absorbing (a good prefix has been read).
    ``delta``: int32[Q, 2**n]; ``delta[q, sigma]`` is the successor of q on letter sigma, where bit
    i of sigma says whether ``atoms[i]`` holds.
    ``atoms``: the atoms the letters are made of.
    ``rejecting_sink``: the state from which no accepting state is reachable, or None.
    ``state_formulas``: for each state, the (progressed, NNF) formula it stands for, with atoms
    written ``a0``, ``a1``, ...: for reports and debugging only.
    """

    num_states: int
    initial: int
    accepting: np.ndarray
    delta: np.ndarray
    atoms: tuple[Expr, ...]
    rejecting_sink: int | None
    state_formulas: tuple[str, ...] = ()

    @property
    def num_atoms(self) -> int:
        return len(self.atoms)

    @property
    def num_letters(self) -> int:
        return int(self.delta.shape[1])

    def run(self, word: Iterable[int]) -> int:
        """The state reached from ``initial`` after reading ``word`` (a sequence of letters)."""
        q = self.initial
        for letter in word:
            q = int(self.delta[q, letter])
        return q

    def accepts(self, word: Iterable[int]) -> bool:
        """Whether ``word`` has a good prefix (equivalently, is one: acceptance is absorbing)."""
        return bool(self.accepting[self.run(word)])


def _reachable(delta: np.ndarray, initial: int) -> np.ndarray:
    """bool[Q]: the states reachable from ``initial``."""
    reach = np.zeros(delta.shape[0], dtype=bool)
    reach[initial] = True
    frontier = np.array([initial])
    while frontier.size:
        succ = np.unique(delta[frontier])
        frontier = succ[~reach[succ]]
        reach[frontier] = True
    return reach


def _can_reach(delta: np.ndarray, target: np.ndarray) -> np.ndarray:
    """bool[Q]: the states from which some word leads into ``target``."""
    can = target.copy()
    while True:
        grown = can | can[delta].any(axis=1)
        if np.array_equal(grown, can):
            return can
        can = grown


def _compress_letters(delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(delta restricted to one letter per class of letters with identical columns, the class of
    each letter): refinement then costs O(Q * classes) instead of O(Q * 2**n)."""
    columns, inverse = np.unique(delta.T, axis=0, return_inverse=True)
    return np.ascontiguousarray(columns.T), inverse.reshape(-1)


def minimise(
    delta: np.ndarray, accepting: np.ndarray, initial: int
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """Minimise a complete DFA: drop unreachable states, then merge language-equivalent ones.

    States are renumbered in order of their first member, so a DFA whose initial state is 0 keeps
    it at 0.

    Args:
        delta: int[Q, K] successor table.
        accepting: bool[Q].
        initial: the initial state.

    Returns:
        ``(delta, accepting, initial, class_of)`` of the minimal DFA; ``class_of`` is int64[Q],
        the new state of each old state (-1 for unreachable ones).
    """
    num_old = delta.shape[0]
    reach = _reachable(delta, initial)
    kept = np.flatnonzero(reach)
    renumber = np.full(num_old, -1, dtype=np.int64)
    renumber[kept] = np.arange(kept.size)
    sub_delta = renumber[delta[kept]]
    sub_acc = accepting[kept]

    columns, _ = _compress_letters(sub_delta)
    cls = sub_acc.astype(np.int64)
    num_classes = int(np.unique(cls).size)
    while True:
        signature = np.column_stack([cls, cls[columns]])
        _, refined = np.unique(signature, axis=0, return_inverse=True)
        refined = refined.reshape(-1).astype(np.int64)
        count = int(refined.max()) + 1
        cls = refined
        if count == num_classes:
            break
        num_classes = count

    # number the classes by their first member, so that the order follows exploration order
    first = np.full(num_classes, kept.size, dtype=np.int64)
    np.minimum.at(first, cls, np.arange(kept.size))
    order = np.argsort(first, kind="stable")
    rank = np.empty(num_classes, dtype=np.int64)
    rank[order] = np.arange(num_classes)
    cls = rank[cls]
    representatives = first[order]
    new_delta = cls[sub_delta[representatives]].astype(np.int32)
    new_acc = sub_acc[representatives]
    class_of = np.full(num_old, -1, dtype=np.int64)
    class_of[kept] = cls
    return new_delta, new_acc, int(class_of[initial]), class_of


def _explore(
    table: FormulaTable, root: int, num_atoms: int, *, max_states: int, path: Expr
) -> tuple[np.ndarray, list[int]]:
    """Breadth-first progression from ``root``: (delta int32[Q, 2**n], formula of each state)."""
    letters = np.arange(1 << num_atoms, dtype=np.int64)
    index = {root: 0}
    formulas = [root]
    rows: list[np.ndarray] = []
    i = 0
    while i < len(formulas):
        f = formulas[i]
        mask = table.current_mask(f)
        bits = [b for b in range(num_atoms) if (mask >> b) & 1]
        # only the atoms progression reads at f are enumerated; other letters share the result
        successors = np.empty(1 << len(bits), dtype=np.int32)
        for sub in range(1 << len(bits)):
            full = 0
            for k, b in enumerate(bits):
                full |= ((sub >> k) & 1) << b
            g = table.progress(f, full)
            j = index.get(g)
            if j is None:
                if len(formulas) >= max_states:
                    raise LimitError(
                        f"the automaton of this formula has more than {max_states} states",
                        path.span,
                        hint="use smaller step bounds or raise the automaton state limit",
                    )
                j = len(formulas)
                index[g] = j
                formulas.append(g)
            successors[sub] = j
        sub_of_letter = np.zeros(letters.size, dtype=np.int64)
        for k, b in enumerate(bits):
            sub_of_letter |= ((letters >> b) & 1) << k
        rows.append(successors[sub_of_letter])
        i += 1
    return np.vstack(rows), formulas


def to_dfa(
    path: Expr,
    atoms: tuple[Expr, ...] | None = None,
    *,
    bound_value: BoundEvaluator | None = None,
    max_atoms: int = DEFAULT_MAX_ATOMS,
    max_states: int = DEFAULT_MAX_STATES,
    exact_good_prefixes: bool = False,
    minimal: bool = True,
) -> Dfa:
    """The DFA of the good prefixes of a co-safe LTL path formula (see the module docstring).

    Args:
        path: the path formula (``Temporal``, ``!``, ``&``, ``|``, ``=>``, ``<=>`` over atoms).
        atoms: the atoms, in letter-bit order; :func:`extract_atoms` of ``path`` when None.
        bound_value: evaluates step bounds; by default integer literal arithmetic only.
        max_atoms: refuse formulas with more atoms (the alphabet has ``2**n`` letters).
        max_states: refuse automata with more states before minimisation.
        exact_good_prefixes: accept at the first good prefix (True), or only when progression
            has reached ``true`` (False, the default: PRISM's rule, which decides where
            ``R[co-safe]`` stops collecting reward; probabilities are the same either way).
        minimal: minimise (True), or keep the progression automaton as explored.

    Returns:
        The :class:`Dfa`.

    Raises:
        UnsupportedError: the formula is not syntactically co-safe (pointing at the operator that
            becomes an unbounded G/R), has too many atoms, or is not an LTL formula over atoms.
        SemanticError: a negative step bound or an empty step interval.
        LimitError: the automaton exceeds ``max_states``.
    """
    atoms = extract_atoms(path) if atoms is None else tuple(atoms)
    if len(atoms) > max_atoms:
        raise UnsupportedError(
            f"the formula has {len(atoms)} distinct atoms; at most {max_atoms} are supported",
            path.span,
            hint="combine state predicates into fewer labels",
        )
    translation = translate(path, atoms, bound_value=bound_value)
    table = translation.table
    if table.unbounded_releases(translation.root):
        raise cosafe_error(path, translation.non_cosafe_origin())
    delta, formulas = _explore(
        table, translation.root, len(atoms), max_states=max_states, path=path
    )
    accepting = np.array([f == FormulaTable.TRUE for f in formulas], dtype=bool)
    if exact_good_prefixes:
        accepting = _good_prefix_closure(delta, accepting)
        # a good prefix stays good: make acceptance absorbing
        delta[accepting] = np.flatnonzero(accepting)[:, None]
    descriptions = [table.render(f) for f in formulas]
    initial = 0
    if minimal:
        delta, accepting, initial, class_of = minimise(delta, accepting, initial)
        members = np.flatnonzero(class_of >= 0)
        first_member = np.full(delta.shape[0], len(formulas), dtype=np.int64)
        np.minimum.at(first_member, class_of[members], members)
        descriptions = [descriptions[int(m)] for m in first_member]
        # merged accepting states print as the good-prefix fact they stand for
        descriptions = ["true" if a else d for a, d in zip(accepting, descriptions)]
    dead = ~_can_reach(delta, accepting)
    dead_states = np.flatnonzero(dead)
    sink = int(dead_states[0]) if dead_states.size else None
    return Dfa(
        num_states=int(delta.shape[0]),
        initial=initial,
        accepting=accepting,
        delta=delta.astype(np.int32),
        atoms=atoms,
        rejecting_sink=sink,
        state_formulas=tuple(descriptions),
    )


def _good_prefix_closure(delta: np.ndarray, accepting: np.ndarray) -> np.ndarray:
    """bool[Q]: the states from which every infinite word visits ``accepting``, i.e. those with no
    infinite run avoiding it (greatest fixpoint of "non-accepting with a non-accepting
    successor")."""
    columns, _ = _compress_letters(delta)
    avoid = ~accepting
    while True:
        shrunk = avoid & avoid[columns].any(axis=1)
        if np.array_equal(shrunk, avoid):
            return ~avoid
        avoid = shrunk
