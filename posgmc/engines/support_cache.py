"""Memoised graph precomputations, keyed on a transition matrix's *support* (never its values).

Graph searches (attractors, the transposed pattern of a :class:`~posgmc.engines.graph.Structure`)
read only where a matrix has entries, never how large they are. A strategy synthesis evaluates
thousands of products of one game with candidate strategies of the same support (the product is
refilled with new probabilities: :mod:`posgmc.synthesis.product_template`), and the adversary's
best response solves chains induced by the same few policies again and again: the same searches
on the same patterns. This module remembers their answers.

A key is a 128-bit BLAKE2b digest of everything a search reads: the arrays' dtypes, shapes and
bytes (the pattern's ``indptr``/``indices``/``row_groups``, the masks passed to the search) and
which implementation runs (the compiled and the numpy searches agree on sets and layers but may
report different witnesses). The answer for a key is therefore the answer the search would give:
a hit changes no number, only the time. Entries are kept least-recently-used first out within a
byte budget (:data:`BUDGET_BYTES` per cache), so memory stays bounded whatever the model's size.
"""

from __future__ import annotations

import hashlib
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, Generic, TypeVar

import numpy as np

__all__ = ["BUDGET_BYTES", "SupportCache", "clear_all", "digest"]

BUDGET_BYTES = 32 * 1024 * 1024
"""Bytes of cached arrays per cache, at most (five caches: the transposed patterns, the
attractors, policy iteration's two, the candidate chains' reach): an attractor of a product of
10^5 states keeps about 3 MB, so about ten of them stay, while the rover's whole synthesis needs
7 MB; a long session, or a worker of ``--jobs``, cannot grow without bound."""

V = TypeVar("V")


def digest(*parts: np.ndarray | bytes | int | None) -> bytes:
    """A 16-byte digest of arrays (dtype, shape and contents), byte strings, ints and Nones, in
    order: equal digests mean equal inputs (up to BLAKE2b collisions, 2^-64 by the birthday
    bound over 2^32 keys)."""
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        if p is None:
            h.update(b"\x00N")
        elif isinstance(p, bytes):
            h.update(b"\x00B%d:" % len(p))
            h.update(p)
        elif isinstance(p, int):
            h.update(b"\x00I%d" % p)
        else:
            a = np.ascontiguousarray(p)
            h.update(b"\x00A" + a.dtype.str.encode() + repr(a.shape).encode())
            h.update(a.reshape(-1).view(np.uint8).data)
    return h.digest()


class SupportCache(Generic[V]):
    """A thread-safe least-recently-used map from digests to results, within a byte budget.

    ``size_of`` gives a result's size in bytes (what it holds in arrays); a result larger than
    the whole budget is computed and returned but not kept. Every cache is listed for
    :func:`clear_all`."""

    def __init__(self, size_of: Callable[[V], int], budget: int = BUDGET_BYTES) -> None:
        self._size_of = size_of
        self._budget = budget
        self._entries: OrderedDict[bytes, tuple[V, int]] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0
        _ALL.add(self)

    def get(self, key: bytes) -> V | None:
        """The result kept for ``key`` (now the most recently used), or None."""
        with self._lock:
            found = self._entries.get(key)
            if found is None:
                self.misses += 1
                return None
            self._entries.move_to_end(key)
            self.hits += 1
            return found[0]

    def put(self, key: bytes, value: V) -> None:
        """Keep ``value`` for ``key``, dropping the least recently used entries beyond the
        budget."""
        size = self._size_of(value)
        if size > self._budget:
            return
        with self._lock:
            old = self._entries.pop(key, None)
            if old is not None:
                self._bytes -= old[1]
            self._entries[key] = (value, size)
            self._bytes += size
            while self._bytes > self._budget:
                _, (_, dropped) = self._entries.popitem(last=False)
                self._bytes -= dropped

    def clear(self) -> None:
        """Forget every entry (and the hit counts)."""
        with self._lock:
            self._entries.clear()
            self._bytes = 0
            self.hits = 0
            self.misses = 0

    def __len__(self) -> int:
        return len(self._entries)


_ALL: weakref.WeakSet[SupportCache[Any]] = weakref.WeakSet()


def clear_all() -> None:
    """Forget what every cache remembers: a measurement that runs several syntheses in one
    process (a benchmark comparing two options) starts each as a fresh command would."""
    for cache in list(_ALL):
        cache.clear()
