"""Packing of states into integer keys, and the vectorized index from keys to state numbers.

A state (one value per variable) is packed in mixed radix over ``value - low``: with the variables
in :class:`~posgmc.semantics.flat.FlatModel` order, the first variable is the most significant
digit, so key order is the lexicographic order of valuations. When the product of all ranges does
not fit in 63 bits the variables are split into several words (each a mixed-radix number below
2**63) and a key is a row of ``W`` int64 words; everything below handles both shapes, keys always
being an int64 array of shape ``(m, W)``.

An update only changes the variables it assigns, so the key of a successor is the key of its source
plus ``(new - old) * multiplier`` for each assigned variable (no re-packing of whole states).

Two indexes map keys to state numbers, both array-at-a-time:

* :class:`DirectIndex` when the whole key space is small (one word, at most ``2**26`` keys): a
  table of ``number + 1`` per key, zero-initialised so that untouched pages cost no memory.
* :class:`HashIndex` otherwise: open addressing with linear probing; each probing round is one
  vectorized gather over the keys still unresolved.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DirectIndex",
    "HashIndex",
    "StateEncoding",
    "StateIndex",
    "VariableLayout",
    "make_index",
]

_WORD_LIMIT = 1 << 63
DIRECT_LIMIT = 1 << 26
"""Largest key space (number of keys) served by :class:`DirectIndex`."""


@dataclass(frozen=True)
class VariableLayout:
    """Where one variable sits in a key: its ``word`` and digit ``multiplier``;
    ``size = high - low + 1``."""

    low: int
    high: int
    is_bool: bool
    word: int
    multiplier: int

    @property
    def size(self) -> int:
        return self.high - self.low + 1


class StateEncoding:
    """Mixed-radix packing of the variables into ``num_words`` int64 words."""

    def __init__(self, ranges: Sequence[tuple[int, int, bool]]) -> None:
        """Args:
        ranges: ``(low, high, is_bool)`` of each variable, in model order.
        """
        # group variables into words from the last one (least significant) backwards so that the
        # first variable is the most significant digit of the first word
        sizes = [hi - lo + 1 for lo, hi, _ in ranges]
        words_rev: list[list[int]] = [[]]
        capacity = 1
        for i in reversed(range(len(ranges))):
            if capacity * sizes[i] >= _WORD_LIMIT and words_rev[-1]:
                words_rev.append([])
                capacity = 1
            words_rev[-1].append(i)
            capacity *= sizes[i]
        words = [list(reversed(w)) for w in reversed(words_rev)]
        layouts: list[VariableLayout | None] = [None] * len(ranges)
        self.word_sizes: list[int] = []
        for w, members in enumerate(words):
            mult = 1
            for i in reversed(members):
                lo, hi, is_bool = ranges[i]
                layouts[i] = VariableLayout(lo, hi, is_bool, w, mult)
                mult *= sizes[i]
            self.word_sizes.append(mult)
        self.layouts: tuple[VariableLayout, ...] = tuple(lay for lay in layouts if lay is not None)
        self.num_words = len(words)

    @property
    def key_space(self) -> int:
        """Number of distinct keys (product of all ranges)."""
        out = 1
        for s in self.word_sizes:
            out *= s
        return out

    def encode(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        """Keys ``int64[m, W]`` of states given as one value array per variable."""
        m = int(columns[0].shape[0]) if columns else 1
        keys = np.zeros((m, self.num_words), dtype=np.int64)
        for layout, col in zip(self.layouts, columns):
            digit = np.asarray(col, dtype=np.int64) - layout.low
            keys[:, layout.word] += digit * layout.multiplier
        return keys

    def decode_column(self, keys: np.ndarray, i: int) -> np.ndarray:
        """The values of variable ``i`` (int64, or bool for Booleans) in ``keys``."""
        layout = self.layouts[i]
        word = keys[:, layout.word]
        digit = word // layout.multiplier if layout.multiplier != 1 else word
        if layout.multiplier * layout.size < self.word_sizes[layout.word]:
            digit = digit % layout.size
        if layout.is_bool:
            return digit.astype(np.bool_)
        return digit + layout.low if layout.low else digit.copy() if digit is word else digit

    def decode(self, keys: np.ndarray) -> list[np.ndarray]:
        return [self.decode_column(keys, i) for i in range(len(self.layouts))]

    def decode_values(self, keys: np.ndarray) -> np.ndarray:
        """``int64[m, V]`` valuations (Booleans as 0/1)."""
        out = np.empty((keys.shape[0], len(self.layouts)), dtype=np.int64)
        for i in range(len(self.layouts)):
            out[:, i] = self.decode_column(keys, i)
        return out


# ---------------------------------------------------------------------------------------------
# indexes
# ---------------------------------------------------------------------------------------------


class StateIndex:
    """Maps keys to state numbers; numbers are handed out by the caller in discovery order."""

    size: int

    def lookup(self, keys: np.ndarray) -> np.ndarray:
        """State numbers of ``keys`` (``int64[m]``), -1 where unknown."""
        raise NotImplementedError

    def insert(self, keys: np.ndarray, numbers: np.ndarray) -> None:
        """Record distinct, unknown ``keys`` with their ``numbers``."""
        raise NotImplementedError

    def number_new(self, keys: np.ndarray, first_number: int) -> tuple[np.ndarray, np.ndarray]:
        """Number the distinct unknown ``keys`` by first occurrence, starting at ``first_number``.

        Args:
            keys: ``int64[m, W]`` keys that are all unknown, possibly repeated, in discovery order.
            first_number: the number of the first new state.

        Returns:
            ``(numbers, firsts)``: the number of every row, and the rows where each new key occurs
            first (ascending, so ``keys[firsts]`` are the new states in number order).
        """
        m = keys.shape[0]
        if m == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        if keys.shape[1] == 1:
            order = np.argsort(keys[:, 0], kind="stable")
            sk = keys[order, 0]
            starts = np.flatnonzero(np.concatenate(([True], sk[1:] != sk[:-1])))
        else:
            order = np.lexsort(keys.T[::-1])
            sk = keys[order]
            diff = np.any(sk[1:] != sk[:-1], axis=1)
            starts = np.flatnonzero(np.concatenate(([True], diff)))
        mark = np.zeros(m, dtype=np.int64)
        mark[starts] = 1
        group = np.cumsum(mark) - 1  # group of each sorted row
        first_rows = order[starts]  # stable sort: smallest row of each key
        rank_order = np.argsort(first_rows)
        group_number = np.empty(starts.size, dtype=np.int64)
        group_number[rank_order] = np.arange(first_number, first_number + starts.size)
        numbers = np.empty(m, dtype=np.int64)
        numbers[order] = group_number[group]
        firsts = np.sort(first_rows)
        self.insert(keys[firsts], numbers[firsts])
        return numbers, firsts


class DirectIndex(StateIndex):
    """A table over the whole (single-word) key space holding ``number + 1`` (0: unknown)."""

    def __init__(self, key_space: int, *, wide: bool) -> None:
        # np.zeros maps fresh zero pages lazily: only pages of reached keys take memory
        self.table = np.zeros(key_space, dtype=np.int64 if wide else np.int32)
        self.size = 0

    def lookup(self, keys: np.ndarray) -> np.ndarray:
        out: np.ndarray = self.table[keys[:, 0]].astype(np.int64) - 1
        return out

    def insert(self, keys: np.ndarray, numbers: np.ndarray) -> None:
        self.table[keys[:, 0]] = numbers + 1
        self.size += int(keys.shape[0])

    def number_new(self, keys: np.ndarray, first_number: int) -> tuple[np.ndarray, np.ndarray]:
        m = keys.shape[0]
        if m == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        k = keys[:, 0]
        # smallest row of each key without sorting: a minimum scatter of (row - m) < 0 into the
        # table, whose entries for unknown keys are 0
        pos = np.arange(m, dtype=np.int64)
        if self.table.dtype == np.int32 and m >= (1 << 31):
            raise OverflowError("batch too large for a 32-bit index")
        np.minimum.at(self.table, k, (pos - m).astype(self.table.dtype))
        first = self.table[k].astype(np.int64) + m
        firsts = np.flatnonzero(first == pos)
        self.table[k[firsts]] = np.arange(first_number + 1, first_number + 1 + firsts.size)
        numbers = self.table[k].astype(np.int64) - 1
        self.size += int(firsts.size)
        return numbers, firsts


_HASH_MUL = np.uint64(0x9E3779B97F4A7C15)
_HASH_MIX = np.uint64(0xBF58476D1CE4E5B9)


class HashIndex(StateIndex):
    """Open addressing with linear probing, load factor at most 1/2, ``W``-word keys.

    ``keys[slot]`` holds the key (all words -1 in a free slot: real keys are never negative),
    ``numbers[slot]`` its state number. A probing round is one gather of the keys still
    unresolved; a hit costs one more gather of its number.
    """

    def __init__(self, num_words: int, *, wide: bool = False, initial_bits: int = 16) -> None:
        self.num_words = num_words
        self.number_dtype = np.int64 if wide else np.int32
        self.size = 0
        self._alloc(initial_bits)

    def _alloc(self, bits: int) -> None:
        self.bits = bits
        cap = 1 << bits
        self.mask = cap - 1
        self.keys = np.full((cap, self.num_words), -1, dtype=np.int64)
        self.numbers = np.zeros(cap, dtype=self.number_dtype)

    def _slots(self, keys: np.ndarray) -> np.ndarray:
        h = keys[:, 0].view(np.uint64) * _HASH_MUL
        for w in range(1, keys.shape[1]):
            h = (h ^ keys[:, w].view(np.uint64)) * _HASH_MIX
        h ^= h >> np.uint64(31)
        h = h * _HASH_MUL
        return (h >> np.uint64(64 - self.bits)).astype(np.int64)

    def lookup(self, keys: np.ndarray) -> np.ndarray:
        m = keys.shape[0]
        out = np.full(m, -1, dtype=np.int64)
        rows = np.arange(m)
        slots = self._slots(keys)
        if self.num_words == 1:
            table = self.keys[:, 0]
            want = keys[:, 0]
            while rows.size:
                found = table[slots]
                hit = found == want
                if hit.any():
                    out[rows[hit]] = self.numbers[slots[hit]]
                go_on = (found >= 0) & ~hit  # occupied by another key: probe the next slot
                rows, want, slots = rows[go_on], want[go_on], (slots[go_on] + 1) & self.mask
            return out
        want2 = keys
        while rows.size:
            found2 = self.keys[slots]
            hit = np.all(found2 == want2, axis=1)
            if hit.any():
                out[rows[hit]] = self.numbers[slots[hit]]
            go_on = (found2[:, 0] >= 0) & ~hit
            rows, want2, slots = rows[go_on], want2[go_on], (slots[go_on] + 1) & self.mask
        return out

    def insert(self, keys: np.ndarray, numbers: np.ndarray) -> None:
        m = keys.shape[0]
        if m == 0:
            return
        if 2 * (self.size + m) > (1 << self.bits):
            bits = self.bits
            while 2 * (self.size + m) > (1 << bits):
                bits += 1
            old_keys, old_numbers = self.keys, self.numbers
            live = old_keys[:, 0] >= 0
            self._alloc(bits)
            self.size = 0
            self._place(old_keys[live], old_numbers[live])
        self._place(keys, numbers)

    def _place(self, keys: np.ndarray, numbers: np.ndarray) -> None:
        pending = np.arange(keys.shape[0])
        slots = self._slots(keys)
        while pending.size:
            cand = np.flatnonzero(self.keys[slots, 0] < 0)
            # several pending keys may want the same free slot: write them all, read back who
            # stayed (one write per slot survives), and let the others probe on
            target = slots[cand]
            self.keys[target] = keys[pending[cand]]
            if self.num_words == 1:
                won = self.keys[target, 0] == keys[pending[cand], 0]
            else:
                won = np.all(self.keys[target] == keys[pending[cand]], axis=1)
            winners = cand[won]
            self.numbers[slots[winners]] = numbers[pending[winners]]
            self.size += int(winners.size)
            lost = np.ones(pending.size, dtype=bool)
            lost[winners] = False
            pending = pending[lost]
            slots = (slots[lost] + 1) & self.mask


def make_index(encoding: StateEncoding, *, wide: bool) -> StateIndex:
    """A :class:`DirectIndex` for small single-word key spaces, else a :class:`HashIndex`.

    Args:
        encoding: the packing of states.
        wide: state numbers may exceed 2**31 - 2 (the direct table then holds int64).
    """
    if encoding.num_words == 1 and encoding.key_space <= DIRECT_LIMIT:
        return DirectIndex(encoding.key_space, wide=wide)
    return HashIndex(encoding.num_words, wide=wide)
