"""The best row of every state by slots instead of ``ufunc.reduceat``.

Value iteration on a game or a family of strategies takes, every sweep, the optimum over each
state's rows. ``np.maximum.reduceat`` over 10^5 row groups costs more than the sparse product
itself (a call per group). Laid out by *slot* — slot 0 holds the first row of every state, in
state order, slot j the (j+1)-th row of the states with more than j rows — the optimum is a
contiguous copy of slot 0 and one elementwise maximum (or minimum) per further slot. A matrix
whose rows are taken in :attr:`RowSlots.order` gives the row values in that layout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RowSlots"]


@dataclass(frozen=True, eq=False)
class RowSlots:
    """``order``: int64[R], the row (an index into the caller's rows) at each slot position;
    ``slots``: per slot j >= 1, int64 the states with more than j rows (ascending);
    ``num_states``: the states (each has at least one row)."""

    order: np.ndarray
    slots: tuple[np.ndarray, ...]
    num_states: int

    @staticmethod
    def of(starts: np.ndarray, counts: np.ndarray) -> RowSlots:
        """The slot layout of row groups ``starts[i] .. starts[i] + counts[i] - 1`` (every
        count at least 1)."""
        slots = tuple(np.flatnonzero(counts > j) for j in range(1, int(counts.max(initial=1))))
        order = np.concatenate([starts, *(starts[st] + j for j, st in enumerate(slots, 1))])
        return RowSlots(order.astype(np.int64, copy=False), slots, int(starts.size))

    def best(self, values: np.ndarray, ufunc: np.ufunc, out: np.ndarray | None = None
             ) -> np.ndarray:
        """float64[num_states]: ``ufunc`` (np.maximum or np.minimum) over each state's rows, from
        the rows' ``values`` in slot order; into ``out`` when given (no allocation)."""
        n = self.num_states
        if out is None:
            out = values[:n].copy()
        else:
            out[:] = values[:n]
        at = n
        for st in self.slots:
            out[st] = ufunc(out[st], values[at:at + st.size])
            at += st.size
        return out

    def first_attaining(self, values: np.ndarray, best: np.ndarray) -> np.ndarray:
        """int64[num_states]: the lowest slot (the state's first row in the caller's order) whose
        value in ``values`` (slot order) equals ``best`` (its state's optimum); 0 where none
        does."""
        pick = np.zeros(self.num_states, dtype=np.int64)
        at = values.size
        for j in range(len(self.slots), 0, -1):  # the lowest attaining slot written last
            st = self.slots[j - 1]
            at -= st.size
            pick[st[values[at:at + st.size] == best[st]]] = j
        pick[values[:self.num_states] == best] = 0
        return pick
