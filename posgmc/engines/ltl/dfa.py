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

**The model's letters.** A product only ever reads the letters that occur in the model, in the
orders the model's transitions allow. Given a :class:`LetterGraph` (the distinct letters of the
model's states, those of the start states, and which letter can follow which), steps 2-4 run
over those letters only: the table has one column per occurring letter, and exploration follows
only letter sequences the graph allows (a DFA state entered by letter ``a`` is progressed only on
the letters that can follow ``a``); for each state only the distinct values of ``letter &
(atoms it reads)`` are progressed. Table entries no allowed sequence reaches point to the
``false`` state: the product never reads them (so minimisation and the rejecting sink stay
correct for every word the model produces). A conjunction of 13 ``F`` atoms, whose automaton over
all 2**13 letters has 2**13 states and a 2**26-entry table, then costs the states the model can
drive it through (169 on a 13-state ring). Without ``alphabet`` the
table is over all ``2**n`` letters (at most :data:`DEFAULT_MAX_ATOMS` atoms); with it, letters
are int64 bit sets of at most :data:`MAX_ALPHABET_ATOMS` atoms. Either way exploration stops with
a :class:`~posgmc.errors.LimitError` stating the measured size beyond ``max_states`` automaton
states or :data:`DEFAULT_MAX_TABLE` table entries.

After minimisation there is at most one accepting state and at most one rejecting sink (a state
from which no accepting state is reachable), since each is a language-equivalence class.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from posgmc.engines.ltl.cosafe import (
    BoundEvaluator,
    FormulaTable,
    cosafe_error,
    extract_atoms,
    translate,
)
from posgmc.errors import LimitError, UnsupportedError
from posgmc.syntax.ast import Expr

__all__ = ["Dfa", "LetterGraph", "check_atoms", "letter_columns", "minimise", "to_dfa"]

DEFAULT_MAX_ATOMS = 16
MAX_ALPHABET_ATOMS = 62
DEFAULT_MAX_STATES = 100_000
DEFAULT_MAX_TABLE = 20_000_000
"""Successor-table entries (states x letters) allowed before minimisation: 80 MB of int32."""


@dataclass(frozen=True, eq=False)
class LetterGraph:
    """The letters a model can produce and their possible orders.

    ``alphabet``: int64[K], sorted distinct letters of the model's states.
    ``starts``: bool[K], the letters of the states paths start in.
    ``follow``: bool CSR [K, K], ``follow[a, b]`` when a state with letter ``alphabet[b]`` is a
    successor of one with letter ``alphabet[a]``.
    """

    alphabet: np.ndarray
    starts: np.ndarray
    follow: sp.csr_matrix


@dataclass(frozen=True, eq=False)
class Dfa:
    """A complete DFA over the letters ``[0, 2**len(atoms))``.

    ``num_states``: Q. ``initial``: the initial state, in [0, Q).
    ``accepting``: bool[Q]; accepting states are absorbing (a good prefix has been read).
    ``delta``: int32[Q, 2**n]; ``delta[q, sigma]`` is the successor of q on letter sigma, where bit
    i of sigma says whether ``atoms[i]`` holds.
    ``atoms``: the atoms the letters are made of.
    ``rejecting_sink``: the state from which no accepting state is reachable, or None.
    ``alphabet``: None when ``delta`` has a column for every letter; otherwise int64[K], sorted,
    the only letters it reads (the model's), ``delta[:, k]`` being the column of
    ``alphabet[k]`` (see :meth:`columns`).
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
    alphabet: np.ndarray | None = None

    @property
    def num_atoms(self) -> int:
        return len(self.atoms)

    @property
    def num_letters(self) -> int:
        return int(self.delta.shape[1])

    def columns(self, letters: np.ndarray) -> np.ndarray:
        """int64: the column of ``delta`` for each letter.

        Raises:
            ValueError: a letter outside ``alphabet`` (a caller bug: the alphabet is the model's).
        """
        if self.alphabet is None:
            return np.asarray(letters, dtype=np.int64)
        return letter_columns(self.alphabet, letters)

    def run(self, word: Iterable[int]) -> int:
        """The state reached from ``initial`` after reading ``word`` (a sequence of letters)."""
        q = self.initial
        for letter in word:
            q = int(self.delta[q, int(self.columns(np.array([letter]))[0])])
        return q

    def accepts(self, word: Iterable[int]) -> bool:
        """Whether ``word`` has a good prefix (equivalently, is one: acceptance is absorbing)."""
        return bool(self.accepting[self.run(word)])


def letter_columns(alphabet: np.ndarray, letters: np.ndarray) -> np.ndarray:
    """int64: the index of each letter in the sorted ``alphabet``.

    Raises:
        ValueError: a letter outside ``alphabet`` (a caller bug: the alphabet is the model's).
    """
    letters = np.asarray(letters, dtype=np.int64)
    cols = np.searchsorted(alphabet, letters)
    if letters.size and (cols.max() >= alphabet.size or np.any(alphabet[cols] != letters)):
        raise ValueError("a letter outside the automaton's alphabet")
    return cols.astype(np.int64)


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
    table: FormulaTable,
    root: int,
    alphabet: np.ndarray,
    *,
    max_states: int,
    max_table: int,
    path: Expr,
) -> tuple[np.ndarray, list[int]]:
    """Breadth-first progression from ``root`` over the letters ``alphabet``:
    (delta int32[Q, len(alphabet)], formula of each state)."""
    index = {root: 0}
    formulas = [root]
    rows: list[np.ndarray] = []
    i = 0
    while i < len(formulas):
        f = formulas[i]
        # only the atoms progression reads at f matter; letters agreeing on them share the result
        distinct, inverse = np.unique(alphabet & table.current_mask(f), return_inverse=True)
        successors = np.empty(distinct.size, dtype=np.int32)
        for k, letter in enumerate(distinct.tolist()):
            g = table.progress(f, letter)
            j = index.get(g)
            if j is None:
                j = len(formulas)
                index[g] = j
                formulas.append(g)
            successors[k] = j
        rows.append(successors[inverse.reshape(-1)])
        i += 1
        error = _too_large(len(formulas), i, alphabet.size, max_states, max_table, path)
        if error is not None:
            raise error
    return np.vstack(rows), formulas


def check_atoms(path: Expr, atoms: tuple[Expr, ...], max_atoms: int = MAX_ALPHABET_ATOMS) -> None:
    """Raises UnsupportedError when ``path`` has more atoms than letters can hold."""
    max_atoms = min(max_atoms, MAX_ALPHABET_ATOMS)
    if len(atoms) > max_atoms:
        raise UnsupportedError(
            f"the formula has {len(atoms)} distinct atoms; at most {max_atoms} are supported",
            path.span,
            hint="combine state predicates into fewer labels",
        )


def _too_large(
    num_states: int, explored: int, num_letters: int, max_states: int, max_table: int, path: Expr
) -> LimitError | None:
    if num_states <= max_states and num_states * num_letters <= max_table:
        return None
    return LimitError(
        f"the automaton of this formula is too large: {num_states} states found so far "
        f"({explored} explored) over {num_letters} letters; the limits are {max_states} states "
        f"and {max_table} table entries (states x letters)",
        path.span,
        hint="split the formula into several properties, use fewer distinct atoms or smaller "
        "step bounds",
    )


def _explore_model_letters(
    table: FormulaTable,
    root: int,
    graph: LetterGraph,
    *,
    max_states: int,
    max_table: int,
    path: Expr,
) -> tuple[np.ndarray, list[int]]:
    """Progression from ``root`` along the letter sequences ``graph`` allows (module docstring):
    (delta int32[Q, K], formula of each state); unreached entries point to ``false``."""
    alphabet = graph.alphabet
    K = alphabet.size
    index = {root: 0}
    formulas = [root]
    rows = [np.full(K, -1, dtype=np.int64)]
    entered = [np.zeros(K, dtype=bool)]  # letters by which each state has been entered
    pending: dict[int, np.ndarray] = {}
    work: list[tuple[int, np.ndarray]] = [(0, np.asarray(graph.starts, dtype=bool))]
    explored = 0

    def state(g: int) -> int:
        j = index.get(g)
        if j is None:
            j = len(formulas)
            index[g] = j
            formulas.append(g)
            rows.append(np.full(K, -1, dtype=np.int64))
            entered.append(np.zeros(K, dtype=bool))
        return j

    while work:
        q, nexts = work.pop()
        explored += 1
        row, f = rows[q], formulas[q]
        need = np.flatnonzero(nexts & (row < 0))
        if need.size:
            distinct, inverse = np.unique(
                alphabet[need] & table.current_mask(f), return_inverse=True
            )
            successors = np.array([state(table.progress(f, int(r))) for r in distinct])
            row[need] = successors[inverse.reshape(-1)]
            error = _too_large(len(formulas), explored, K, max_states, max_table, path)
            if error is not None:
                raise error
        cols = np.flatnonzero(nexts)
        targets = row[cols]
        for j in np.unique(targets).tolist():
            new = cols[(targets == j) & ~entered[j][cols]]
            if new.size:
                entered[j][new] = True
                pending[j] = np.union1d(pending.get(j, new), new)
        while pending and not work:
            j, letters = pending.popitem()
            follow_mask = np.zeros(K, dtype=bool)
            follow_mask[graph.follow[letters].indices] = True
            work.append((j, follow_mask))
    false_state = state(FormulaTable.FALSE)
    delta = np.vstack(rows)
    delta[delta < 0] = false_state
    delta[false_state] = false_state
    return delta.astype(np.int32), formulas


def to_dfa(
    path: Expr,
    atoms: tuple[Expr, ...] | None = None,
    *,
    bound_value: BoundEvaluator | None = None,
    max_atoms: int | None = None,
    max_states: int = DEFAULT_MAX_STATES,
    max_table: int = DEFAULT_MAX_TABLE,
    exact_good_prefixes: bool = False,
    minimal: bool = True,
    alphabet: np.ndarray | LetterGraph | None = None,
) -> Dfa:
    """The DFA of the good prefixes of a co-safe LTL path formula (see the module docstring).

    Args:
        path: the path formula (``Temporal``, ``!``, ``&``, ``|``, ``=>``, ``<=>`` over atoms).
        atoms: the atoms, in letter-bit order; :func:`extract_atoms` of ``path`` when None.
        bound_value: evaluates step bounds; by default integer literal arithmetic only.
        max_atoms: refuse formulas with more atoms (default :data:`DEFAULT_MAX_ATOMS` for the
            full alphabet of ``2**n`` letters, :data:`MAX_ALPHABET_ATOMS` with ``alphabet``).
        max_states: refuse automata with more states before minimisation.
        max_table: refuse automata whose successor table (states x letters) grows beyond this.
        alphabet: the letters that can occur (e.g. those of a model's states), or a
            :class:`LetterGraph` that also says in which orders; the automaton is built over
            them only (see the module docstring). None: every letter.
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
        LimitError: the automaton exceeds ``max_states`` or ``max_table`` (the message gives the
            size measured so far).
    """
    atoms = extract_atoms(path) if atoms is None else tuple(atoms)
    if max_atoms is None:
        max_atoms = DEFAULT_MAX_ATOMS if alphabet is None else MAX_ALPHABET_ATOMS
    check_atoms(path, atoms, max_atoms)
    translation = translate(path, atoms, bound_value=bound_value)
    table = translation.table
    if table.unbounded_releases(translation.root):
        raise cosafe_error(path, translation.non_cosafe_origin())
    if isinstance(alphabet, LetterGraph):
        letters = alphabet.alphabet
        delta, formulas = _explore_model_letters(
            table, translation.root, alphabet, max_states=max_states, max_table=max_table, path=path
        )
    else:
        letters = (
            np.arange(1 << len(atoms), dtype=np.int64)
            if alphabet is None
            else np.unique(np.asarray(alphabet, dtype=np.int64))
        )
        delta, formulas = _explore(
            table, translation.root, letters, max_states=max_states, max_table=max_table, path=path
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
        alphabet=None if alphabet is None else letters,
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
