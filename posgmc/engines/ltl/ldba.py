"""Limit-deterministic Büchi automata (LDBA) for general LTL, by the Master Theorem.

Co-safe formulas have a DFA (:mod:`posgmc.engines.ltl.dfa`); every other LTL formula ``phi``
(``G F a``, ``F G a``, ``G (a => F b)``, ...) gets an LDBA here, built from the same hash-consed
NNF algebra and progression (:mod:`posgmc.engines.ltl.cosafe`), over the letters of the model only.

**The theorem** (Esparza, Křetínský, Sickert, "One Theorem to Rule Them All", LICS 2018; the
LDBA form of Sickert, Esparza, Jaax, Křetínský, CAV 2016). Write ``mu(psi)`` for the unbounded
``U`` sub-formulas of ``psi`` (``F``, ``U`` and strong release) and ``nu(psi)`` for the unbounded
``R`` ones (``G``, ``R``, ``W``); ``af(phi, u)`` is the progression of ``phi`` by the finite word
``u``. For sets ``X`` of mu- and ``Y`` of nu-formulas:

* ``psi[X]_nu`` replaces each mu-formula ``a U b`` by ``a' W b'`` if it is in ``X`` and by
  ``false`` otherwise (operands substituted recursively), giving a formula without unbounded U:
  a *safety* formula;
* ``psi[Y]_mu`` replaces each nu-formula ``a R b`` by ``true`` if it is in ``Y`` and by the strong
  release ``b' U (a' & b')`` otherwise, giving a *co-safe* formula.

Then ``w |= phi`` iff for some position ``i`` and some ``X <= mu(psi)``, ``Y <= nu(psi)`` with
``psi = af(phi, w_0..w_i)``: the suffix after ``i`` satisfies ``psi[X]_nu`` and ``G (y[X]_nu)``
for every ``y`` in ``Y`` (safety), and ``G F (x[Y]_mu)`` for every ``x`` in ``X`` (soundness for
every ``i``; completeness for every large enough ``i``, with ``X``/``Y`` the mu/nu-formulas that
hold infinitely often / almost always).

**The automaton**, reading the letter of the current model state as the DFA does:

* the *initial component* is the progression automaton: its states are residual formulas
  ``psi``, deterministic, never accepting;
* from each residual ``psi`` an epsilon *jump* per guess ``(X, Y)`` leads into the *accepting
  component*, whose states are ``(safe, z_1..z_k, chi_1..chi_k, j, wrapped)``: ``safe`` is the
  progression of the safety part (the run dies when it becomes ``false``), ``chi_m = x_m[Y]_mu``
  and ``z_m`` the progression of the disjunction of all instances of ``chi_m`` started since its
  last success (``z' = progress(z | chi, letter)``; ``z' = true`` is a success and resets it to
  ``false``), so ``G F chi_m`` holds iff monitor m succeeds infinitely often; ``j`` is the
  monitor awaited by the round-robin degeneralisation and ``wrapped`` marks the states entered
  when every monitor has succeeded in turn (all states when ``k = 0``). The accepting component
  is deterministic, so the automaton is good for MDPs: the maximal probability of ``phi`` is the
  maximal probability of reaching an accepting end component of the product with the jumps as
  extra choices (:mod:`posgmc.engines.ltl.omega`).

Safety progression never reaches ``false`` exactly on the words that satisfy a safety formula,
and a co-safe formula's progression reaches ``true`` exactly on those that satisfy it (finitely
many canonical DNF formulas, so both automata are finite). Unbounded operators with a lower step
bound are rewritten first: ``a U[l,oo) b = a U[l,l] (a U b)``, ``a R[l,oo) b = a R[l,l] (a R b)``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from posgmc.engines.ltl.cosafe import BoundEvaluator, FormulaTable, Kind, translate
from posgmc.engines.ltl.dfa import letter_columns
from posgmc.errors import LimitError
from posgmc.syntax.ast import Expr

__all__ = ["MAX_GUESS_FORMULAS", "Ldba", "to_ldba"]

MAX_GUESS_FORMULAS = 12
"""At most this many unbounded U/R sub-formulas in one residual (2**n guesses are tried)."""

DEFAULT_MAX_STATES = 200_000


@dataclass(frozen=True, eq=False)
class Ldba:
    """A limit-deterministic Büchi automaton over the letters ``alphabet``.

    ``num_states``: Q. ``initial``: the initial state (the formula itself).
    ``delta``: int32[Q, K]; ``delta[q, k]`` is the successor of q on letter ``alphabet[k]``.
    ``accepting``: bool[Q] (Büchi, on states; only accepting-component states).
    ``jump_ptr``: int64[Q + 1]; ``jump_to``: int64[J]: the epsilon jumps of state q are
    ``jump_to[jump_ptr[q]:jump_ptr[q+1]]`` (only initial-component states have any).
    ``initial_component``: bool[Q]. ``sink``: the rejecting sink (absorbing, no jumps).
    ``atoms``; ``alphabet``: int64[K], sorted; ``state_formulas``: for reports only.
    """

    num_states: int
    initial: int
    delta: np.ndarray
    accepting: np.ndarray
    jump_ptr: np.ndarray
    jump_to: np.ndarray
    initial_component: np.ndarray
    sink: int
    atoms: tuple[Expr, ...]
    alphabet: np.ndarray
    state_formulas: tuple[str, ...] = ()

    @property
    def num_atoms(self) -> int:
        return len(self.atoms)

    def columns(self, letters: np.ndarray) -> np.ndarray:
        """int64: the column of ``delta`` for each letter (all must be in ``alphabet``)."""
        return letter_columns(self.alphabet, letters)


class _Substitution:
    """``psi[X]_nu`` and ``psi[Y]_mu`` on one formula table (memoised per guess)."""

    def __init__(self, table: FormulaTable) -> None:
        self.tab = table
        self._nu: dict[tuple[int, frozenset[int]], int] = {}
        self._mu: dict[tuple[int, frozenset[int]], int] = {}

    def nu(self, f: int, xs: frozenset[int]) -> int:
        key = (f, xs)
        found = self._nu.get(key)
        if found is None:
            found = self._rebuild(f, lambda g: self.nu(g, xs), self._nu_temporal(xs))
            self._nu[key] = found
        return found

    def mu(self, f: int, ys: frozenset[int]) -> int:
        key = (f, ys)
        found = self._mu.get(key)
        if found is None:
            found = self._rebuild(f, lambda g: self.mu(g, ys), self._mu_temporal(ys))
            self._mu[key] = found
        return found

    def _nu_temporal(self, xs: frozenset[int]):  # type: ignore[no-untyped-def]
        tab = self.tab

        def sub(f: int, kind: Kind, a: int, b: int, lo: int, hi: int | None) -> int:
            if kind is Kind.UNTIL and hi is None:  # lo == 0 after normalisation
                if f not in xs:
                    return tab.FALSE
                a2, b2 = self.nu(a, xs), self.nu(b, xs)
                return tab.release(b2, tab.or_([a2, b2]), 0, None)  # a W b = b R (a | b)
            a2, b2 = self.nu(a, xs), self.nu(b, xs)
            return (tab.until if kind is Kind.UNTIL else tab.release)(a2, b2, lo, hi)

        return sub

    def _mu_temporal(self, ys: frozenset[int]):  # type: ignore[no-untyped-def]
        tab = self.tab

        def sub(f: int, kind: Kind, a: int, b: int, lo: int, hi: int | None) -> int:
            if kind is Kind.RELEASE and hi is None:
                if f in ys:
                    return tab.TRUE
                a2, b2 = self.mu(a, ys), self.mu(b, ys)
                return tab.until(b2, tab.and_([a2, b2]), 0, None)  # a M b = b U (a & b)
            a2, b2 = self.mu(a, ys), self.mu(b, ys)
            return (tab.until if kind is Kind.UNTIL else tab.release)(a2, b2, lo, hi)

        return sub

    def _rebuild(self, f: int, recurse, temporal) -> int:  # type: ignore[no-untyped-def]
        tab = self.tab
        node = tab.node(f)
        kind = node[0]
        if kind in (Kind.TRUE, Kind.FALSE, Kind.LIT):
            return f
        if kind is Kind.AND:
            return tab.and_([recurse(c) for c in node[1]])
        if kind is Kind.OR:
            return tab.or_([recurse(c) for c in node[1]])
        if kind is Kind.NEXT:
            if f == tab.letter():
                return f
            return tab.next_(recurse(node[1]))
        _, a, b, lo, hi = node
        return temporal(f, kind, a, b, lo, hi)  # type: ignore[no-any-return]


def normalise(tab: FormulaTable, f: int, memo: dict[int, int] | None = None) -> int:
    """Rewrite unbounded operators with a lower step bound into a bounded one around an
    unbounded one without (module docstring), so every unbounded U/R starts at step 0."""
    memo = {} if memo is None else memo
    found = memo.get(f)
    if found is not None:
        return found
    node = tab.node(f)
    kind = node[0]
    if kind in (Kind.TRUE, Kind.FALSE, Kind.LIT):
        out = f
    elif kind is Kind.AND:
        out = tab.and_([normalise(tab, c, memo) for c in node[1]])
    elif kind is Kind.OR:
        out = tab.or_([normalise(tab, c, memo) for c in node[1]])
    elif kind is Kind.NEXT:
        out = f if f == tab.letter() else tab.next_(normalise(tab, node[1], memo))
    else:
        _, a, b, lo, hi = node
        a, b = normalise(tab, a, memo), normalise(tab, b, memo)
        make = tab.until if kind is Kind.UNTIL else tab.release
        if hi is None and lo > 0:
            out = make(a, make(a, b, 0, None), lo, lo)
        else:
            out = make(a, b, lo, hi)
    memo[f] = out
    return out


class _Monitored(NamedTuple):
    """An accepting-component state (module docstring)."""

    safe: int
    pending: tuple[int, ...]
    chis: tuple[int, ...]
    awaiting: int
    wrapped: bool


_Key = tuple[str, int] | _Monitored
"""("sink", 0), ("init", residual formula) or an accepting-component state."""


class _Builder:
    """Explores the LDBA over the letters ``alphabet`` (breadth-first, on demand)."""

    def __init__(self, tab: FormulaTable, alphabet: np.ndarray, max_states: int, path: Expr):
        self.tab = tab
        self.alphabet = alphabet
        self.max_states = max_states
        self.path = path
        self.sub = _Substitution(tab)
        self.index: dict[_Key, int] = {}
        self.keys: list[_Key] = []
        self.sink = self.state(("sink", 0))

    def state(self, key: _Key) -> int:
        found = self.index.get(key)
        if found is None:
            found = len(self.keys)
            self.index[key] = found
            self.keys.append(key)
            if found >= self.max_states:
                raise LimitError(
                    f"the automaton of this LTL formula is too large: more than {self.max_states} "
                    "states",
                    self.path.span,
                    hint="split the formula into several properties or use fewer atoms",
                )
        return found

    # -- the initial component ----------------------------------------------------------------

    def initial_row(self, f: int) -> np.ndarray:
        tab = self.tab
        distinct, inverse = np.unique(self.alphabet & tab.current_mask(f), return_inverse=True)
        succ = np.empty(distinct.size, dtype=np.int64)
        for k, letter in enumerate(distinct.tolist()):
            g = tab.progress(f, letter)
            succ[k] = self.sink if g == tab.FALSE else self.state(("init", g))
        out: np.ndarray = succ[inverse.reshape(-1)]
        return out

    def jumps(self, f: int) -> list[int]:
        tab = self.tab
        if f == tab.FALSE:
            return []
        mus, nus = tab.unbounded(f)
        if len(mus) + len(nus) > MAX_GUESS_FORMULAS:
            raise LimitError(
                f"this LTL formula has {len(mus) + len(nus)} unbounded temporal sub-formulas in "
                f"one residual; at most {MAX_GUESS_FORMULAS} are supported",
                self.path.span,
                hint="split the formula into several properties",
            )
        targets: list[int] = []
        for nx in range(len(mus) + 1):
            for x_set in itertools.combinations(mus, nx):
                xs = frozenset(x_set)
                for ny in range(len(nus) + 1):
                    for y_set in itertools.combinations(nus, ny):
                        ys = frozenset(y_set)
                        target = self._jump(f, xs, ys)
                        if target is not None:
                            targets.append(target)
        return sorted(set(targets))

    def _jump(self, f: int, xs: frozenset[int], ys: frozenset[int]) -> int | None:
        tab, sub = self.tab, self.sub
        parts = [sub.nu(f, xs)]
        parts += [tab.release(tab.FALSE, sub.nu(y, xs), 0, None) for y in sorted(ys)]
        safe = tab.and_(parts)
        if safe == tab.FALSE:
            return None
        chis = []
        for x in sorted(xs):
            chi = sub.mu(x, ys)
            if chi == tab.FALSE:
                return None  # G F false
            if chi != tab.TRUE:  # G F true holds: no monitor needed
                chis.append(chi)
        chis_t = tuple(sorted(set(chis)))
        return self.state(_Monitored(safe, (tab.FALSE,) * len(chis_t), chis_t, 0, False))

    # -- the accepting component --------------------------------------------------------------

    def accepting_row(self, key: _Monitored) -> np.ndarray:
        tab = self.tab
        pending = [tab.or_([z, chi]) for z, chi in zip(key.pending, key.chis)]
        mask = tab.current_mask(key.safe)
        for p in pending:
            mask |= tab.current_mask(p)
        distinct, inverse = np.unique(self.alphabet & mask, return_inverse=True)
        succ = np.empty(distinct.size, dtype=np.int64)
        k = len(key.chis)
        for i, letter in enumerate(distinct.tolist()):
            safe = tab.progress(key.safe, letter)
            if safe == tab.FALSE:
                succ[i] = self.sink
                continue
            progressed = [tab.progress(p, letter) for p in pending]
            success = [z == tab.TRUE for z in progressed]
            renewed = tuple(tab.FALSE if z == tab.TRUE else z for z in progressed)
            if k == 0:
                awaiting, wrapped = 0, True
            elif success[key.awaiting]:
                awaiting = (key.awaiting + 1) % k
                wrapped = awaiting == 0
            else:
                awaiting, wrapped = key.awaiting, False
            succ[i] = self.state(_Monitored(safe, renewed, key.chis, awaiting, wrapped))
        out: np.ndarray = succ[inverse.reshape(-1)]
        return out


def to_ldba(
    path: Expr,
    atoms: tuple[Expr, ...],
    *,
    alphabet: np.ndarray,
    bound_value: BoundEvaluator | None = None,
    max_states: int = DEFAULT_MAX_STATES,
) -> Ldba:
    """The LDBA of an LTL path formula over the letters ``alphabet`` (module docstring).

    Args:
        path: the path formula (any LTL over atoms; co-safe ones are better served by a DFA).
        atoms: the atoms in letter-bit order (:func:`~posgmc.engines.ltl.extract_atoms`).
        alphabet: the letters that can occur (e.g. those of a model's states).
        bound_value: evaluates step bounds.
        max_states: refuse automata with more states.

    Returns:
        The :class:`Ldba`.

    Raises:
        UnsupportedError, SemanticError: as :func:`~posgmc.engines.ltl.cosafe.translate`.
        LimitError: more than ``max_states`` states, or too many guesses in a residual.
    """
    letters = np.unique(np.asarray(alphabet, dtype=np.int64))
    translation = translate(path, atoms, bound_value=bound_value)
    tab = translation.table
    root = normalise(tab, translation.root)
    builder = _Builder(tab, letters, max_states, path)
    initial = builder.sink if root == tab.FALSE else builder.state(("init", root))
    rows: dict[int, np.ndarray] = {builder.sink: np.full(letters.size, builder.sink)}
    jumps: dict[int, list[int]] = {}
    q = 0
    while q < len(builder.keys):
        key = builder.keys[q]
        if isinstance(key, _Monitored):
            rows[q] = builder.accepting_row(key)
        elif key[0] == "init":
            rows[q] = builder.initial_row(key[1])
            jumps[q] = builder.jumps(key[1])
        q += 1
    num = len(builder.keys)
    delta = np.vstack([rows[i] for i in range(num)]).astype(np.int32)
    counts = np.array([len(jumps.get(i, ())) for i in range(num)], dtype=np.int64)
    jump_ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    jump_to = np.array(
        [t for i in range(num) for t in jumps.get(i, ())], dtype=np.int64
    )
    accepting = np.array(
        [isinstance(k, _Monitored) and k.wrapped for k in builder.keys], dtype=bool
    )
    initial_component = np.array(
        [not isinstance(k, _Monitored) and k[0] == "init" for k in builder.keys], dtype=bool
    )
    descriptions = tuple(_describe(tab, k) for k in builder.keys)
    return Ldba(
        num_states=num,
        initial=initial,
        delta=delta,
        accepting=accepting,
        jump_ptr=jump_ptr,
        jump_to=jump_to,
        initial_component=initial_component,
        sink=builder.sink,
        atoms=tuple(atoms),
        alphabet=letters,
        state_formulas=descriptions,
    )


def _describe(tab: FormulaTable, key: _Key) -> str:
    if not isinstance(key, _Monitored):
        return "false" if key[0] == "sink" else tab.render(key[1])
    monitors = ", ".join(
        f"GF({tab.render(c)}) pending {tab.render(z)}" for z, c in zip(key.pending, key.chis)
    )
    mark = " *" if key.wrapped else ""
    return f"safe {tab.render(key.safe)}; [{monitors}] awaiting {key.awaiting}{mark}"
