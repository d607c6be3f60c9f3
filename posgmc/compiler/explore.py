"""Breadth-first exploration of the reachable states, a batch of states at a time.

States are numbered in discovery order, exactly as Storm's explicit builder numbers them
(``ExplicitModelBuilder`` with breadth-first order): the initial states first, then every state
in the order its number is first asked for while expanding states ``0, 1, 2, ...``; within a state
choices come in :mod:`posgmc.compiler.program`'s generator order and the successors of a choice in
update order (for synchronised choices: the updates of the first module vary slowest). Zero
probability branches are dropped before their target is looked at (Storm does the same), so they
never create states.

Since numbers only depend on that order, the frontier is processed in batches of consecutive
state numbers rather than in whole BFS levels; a batch is expanded command by command with numpy
over all its states, the choices are put back in canonical order with one stable sort, and the new
targets are numbered by first occurrence. No Python code runs per state.

Per batch the explorer keeps, in canonical order: the source of each choice, its generator, its
number of branches, and the target number and probability of each branch (duplicates within a
choice are summed later by the assembler).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from posgmc.compiler.compile_expr import Columns, CompiledExpr, EvaluationError, ExprType
from posgmc.compiler.options import BuildOptions, ProgressMode
from posgmc.compiler.program import Assignment, Command, Generator, GeneratorKind, Program
from posgmc.compiler.state_space import StateIndex, make_index
from posgmc.errors import BuildError, LimitError, SourceSpan
from posgmc.resources import available_bytes, format_bytes, resident_bytes
from posgmc.semantics import operators as ops
from posgmc.syntax.ast import (
    NO_SPAN,
    Binary,
    BinaryOp,
    BoolLit,
    Expr,
    Ident,
    IntLit,
    Unary,
    UnaryOp,
    VarType,
)

__all__ = ["Exploration", "explore"]

_TARGET_BRANCHES = 1 << 21  # aim for this many branches per batch (bounds temporary memory)
_MIN_BATCH = 256
_MAX_BATCH = 1 << 20


@dataclass
class Exploration:
    """The raw result of exploration, in canonical order (see the module docstring).

    ``state_keys``: int64[S, W] packed states by number. ``initial``: int64[k] initial numbers.
    ``choice_counts``: int32[S] number of choices of each state (>= 1).
    ``choice_gen``: int16/int32[C] generator index of each choice
    (``program.deadlock_generator.index`` for deadlock self-loops).
    ``indptr``: int32/int64[C + 1] the branches of choice c are ``indptr[c]:indptr[c+1]``.
    ``targets``: int32/int64[T] target numbers (same dtype as ``indptr``), ``probs``: float64[T],
    in update order within a choice (duplicates not yet summed).
    ``deadlocks``: int64[d] states that got a self-loop.
    """

    state_keys: np.ndarray
    initial: np.ndarray
    choice_counts: np.ndarray
    choice_gen: np.ndarray
    indptr: np.ndarray
    targets: np.ndarray
    probs: np.ndarray
    deadlocks: np.ndarray
    num_batches: int = 0
    stats: dict[str, float] = field(default_factory=dict)

    @property
    def choice_src(self) -> np.ndarray:
        """int64[C]: the source state of each choice (computed on demand)."""
        return np.repeat(np.arange(self.choice_counts.size, dtype=np.int64), self.choice_counts)


# ---------------------------------------------------------------------------------------------
# small growable buffers
# ---------------------------------------------------------------------------------------------


class _Rows:
    """A growable int64[n, W] array (grown in place like :class:`_Buffer`)."""

    def __init__(self, width: int, capacity: int = 1024) -> None:
        self.data = np.empty((capacity, width), dtype=np.int64)
        self.n = 0

    def extend(self, rows: np.ndarray) -> None:
        need = self.n + rows.shape[0]
        if need > self.data.shape[0]:
            cap = max(need, self.data.shape[0] + (self.data.shape[0] >> 1) + 1024)
            self.data.resize((cap, self.data.shape[1]), refcheck=False)
        self.data[self.n : need] = rows
        self.n = need

    def view(self, lo: int, hi: int) -> np.ndarray:
        return self.data[lo:hi]

    def finish(self) -> np.ndarray:
        data = self.data
        self.data = np.empty((0, data.shape[1]), dtype=np.int64)
        data.resize((self.n, data.shape[1]), refcheck=False)
        return data


class _Buffer:
    """A growable 1-d array. Growth goes through ``ndarray.resize`` (``realloc``, i.e. ``mremap``
    for big blocks): the filled part is neither copied nor touched again, which matters because
    first-touching fresh memory is a large share of the cost of a big build."""

    def __init__(self, dtype: type, capacity: int = 1 << 16) -> None:
        self.data: np.ndarray = np.empty(capacity, dtype=dtype)
        self.n = 0

    def extend(self, values: np.ndarray) -> None:
        need = self.n + int(values.size)
        if need > self.data.size:
            self.data.resize(
                max(need, self.data.size + (self.data.size >> 2) + 4096), refcheck=False
            )
        self.data[self.n : need] = values
        self.n = need

    def upgrade(self, dtype: type) -> None:
        """Switch to a wider dtype (e.g. branch offsets beyond 2**31)."""
        self.data = self.data[: max(self.n, 1)].astype(dtype)

    def finish(self) -> np.ndarray:
        data = self.data
        self.data = np.empty(0, dtype=data.dtype)
        data.resize(self.n, refcheck=False)
        return data


# ---------------------------------------------------------------------------------------------
# progress
# ---------------------------------------------------------------------------------------------


class _Progress:
    """States found / explored and the rate, on one updating stderr line."""

    def __init__(self, mode: ProgressMode, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        if mode is ProgressMode.ALWAYS:
            self.on = True
        elif mode is ProgressMode.NEVER:
            self.on = False
        else:
            isatty = getattr(self.stream, "isatty", None)
            self.on = bool(isatty and isatty())
        self.start = time.perf_counter()
        self.last = self.start
        self.shown = False

    def update(self, explored: int, found: int, *, final: bool = False) -> None:
        if not self.on:
            return
        now = time.perf_counter()
        if not final and now - self.last < 0.5:
            return
        self.last = now
        elapsed = max(now - self.start, 1e-9)
        line = (
            f"\rexploring: {found:,} states found, {explored:,} explored, "
            f"frontier {found - explored:,}, {explored / elapsed:,.0f} states/s"
        )
        self.stream.write(line + ("\n" if final else ""))
        self.stream.flush()
        self.shown = True


# ---------------------------------------------------------------------------------------------
# initial states
# ---------------------------------------------------------------------------------------------


def _pinned(expr: Expr, program: Program) -> dict[int, int]:
    """Variables fixed to one value by top-level conjuncts ``x = c``, ``c = x``, ``b``, ``!b``."""
    out: dict[int, int] = {}
    stack = [expr]
    while stack:
        e = stack.pop()
        if isinstance(e, Binary) and e.op is BinaryOp.AND:
            stack.extend((e.left, e.right))
        elif isinstance(e, Binary) and e.op is BinaryOp.EQ:
            for var, val in ((e.left, e.right), (e.right, e.left)):
                if (
                    isinstance(var, Ident)
                    and isinstance(val, (IntLit, BoolLit))
                    and var.name in program.slots
                ):
                    out[program.slots[var.name][0]] = int(val.value)
        elif isinstance(e, Ident) and e.name in program.slots:
            out[program.slots[e.name][0]] = 1
        elif (
            isinstance(e, Unary)
            and e.op is UnaryOp.NOT
            and isinstance(e.operand, Ident)
            and e.operand.name in program.slots
        ):
            out[program.slots[e.operand.name][0]] = 0
    return out


def initial_keys(program: Program, options: BuildOptions) -> np.ndarray:
    """Packed initial states, sorted by key (= lexicographic order of valuations).

    Raises:
        BuildError: a default initial value outside its range, or no state satisfies ``init``.
        LimitError: the ``init`` predicate leaves too many valuations to enumerate.
    """
    flat = program.flat
    enc = program.encoding
    if flat.init is None:
        values = []
        for v in flat.variables:
            if not v.low <= v.init <= v.high:
                raise BuildError(
                    f"the initial value {v.init} of variable '{v.name}' is outside its range "
                    f"[{v.low}..{v.high}]",
                    _span(v.span),
                )
            values.append(np.array([v.init], dtype=np.int64))
        return enc.encode(values) if values else np.zeros((1, enc.num_words), dtype=np.int64)

    pred = program.compile(flat.init)
    pinned = _pinned(flat.init, program)
    ranges = []
    for i, v in enumerate(flat.variables):
        if i in pinned:
            val = pinned[i]
            if not v.low <= val <= v.high:
                return _no_initial(flat.init)
            ranges.append(np.array([val], dtype=np.int64))
        else:
            ranges.append(np.arange(v.low, v.high + 1, dtype=np.int64))
    total = math.prod(int(r.size) for r in ranges)
    if total > options.initial_state_limit:
        raise LimitError(
            f"the init predicate leaves {total:,} candidate valuations to enumerate "
            f"(limit {options.initial_state_limit:,})",
            _span(flat.init.span),
            hint="pin more variables with conjuncts such as x=0, or raise initial_state_limit",
        )
    # enumerate the product in chunks, in lexicographic order (first variable slowest)
    sizes = [int(r.size) for r in ranges]
    found: list[np.ndarray] = []
    chunk = 1 << 22
    for lo in range(0, total, chunk):
        idx = np.arange(lo, min(total, lo + chunk), dtype=np.int64)
        cols: list[np.ndarray] = [np.empty(0)] * len(ranges)
        rem = idx
        for i in reversed(range(len(ranges))):
            digit = rem % sizes[i]
            rem = rem // sizes[i]
            col = ranges[i][digit]
            cols[i] = col.astype(np.bool_) if flat.variables[i].type is VarType.BOOL else col
        columns = Columns(cols, int(idx.size))
        try:
            ok = pred.evaluate(columns)
        except EvaluationError as err:
            raise BuildError(err.message, _span(err.span)) from None
        if ok.any():
            sel = np.flatnonzero(ok)
            found.append(enc.encode([c[sel] for c in cols]))
    if not found or not sum(f.shape[0] for f in found):
        return _no_initial(flat.init)
    keys = np.concatenate(found)
    order = np.lexsort(keys.T[::-1])
    return keys[order]


def _no_initial(init: Expr) -> np.ndarray:
    raise BuildError(
        "no state satisfies the init predicate",
        _span(init.span),
        hint="the init ... endinit predicate must hold in at least one valuation of the variables",
    )


def _span(span: SourceSpan) -> SourceSpan | None:
    return None if span == NO_SPAN else span


# ---------------------------------------------------------------------------------------------
# batch expansion
# ---------------------------------------------------------------------------------------------


def _static_ok(cmd: Command, tol: float) -> bool:
    """False when all probabilities of ``cmd`` are constants that are negative or do not sum
    to 1 (then the command is an error as soon as it is enabled); True otherwise."""
    if cmd.static_sum is None:
        return True
    if any((u.probability.constant or 0) < 0 for u in cmd.updates):
        return False
    return abs(ops.to_float(cmd.static_sum) - 1.0) <= tol


@dataclass
class _Block:
    """Choices of one generator in a batch: rows (local source index), branch counts, and the
    branches choice-major (target keys int64[T, W], probabilities float64[T])."""

    src: np.ndarray
    gen: int
    counts: np.ndarray
    keys: np.ndarray
    probs: np.ndarray


class _Expander:
    """Expands batches of states; holds the compiled program and the error context."""

    def __init__(self, program: Program, options: BuildOptions) -> None:
        self.program = program
        self.enc = program.encoding
        self.tol = options.probability_tolerance
        self.fix_deadlocks = options.fix_deadlocks
        self.keys: np.ndarray = np.zeros((0, self.enc.num_words), dtype=np.int64)
        self.cols: Columns | None = None
        # commands whose constant probabilities fail the sum check (an error once enabled)
        self.bad_static = {
            id(c)
            for g in program.generators
            for c in ([g.command] if g.command is not None else [c for p in g.parts for c in p])
            if not _static_ok(c, self.tol)
        }

    # -- errors -------------------------------------------------------------------------------

    def state_text(self, row: int) -> str:
        values = self.enc.decode_values(self.keys[row : row + 1])[0]
        return self.program.describe([int(x) for x in values])

    def fail(self, message: str, span: SourceSpan, row: int, hint: str | None = None) -> BuildError:
        return BuildError(f"{message} in state {self.state_text(row)}", _span(span), hint=hint)

    def evaluate(self, expr: CompiledExpr, cols: Columns) -> Any:
        try:
            return expr(cols)
        except EvaluationError as err:
            raise self.fail(err.message, err.span, err.row) from None

    def whole(
        self, new: Any, a: Assignment, sub: Columns, prob: np.ndarray | float, cmd: Command
    ) -> Any:
        """The values of an int/int expression (Storm's typing, accepted by the semantic stage)
        assigned to an int variable, as ints; a value that is not whole, where the update can
        happen, is an error (Storm would truncate its double toward zero)."""
        if isinstance(new, np.ndarray):
            with np.errstate(invalid="ignore"):
                ok = np.floor(new) == new
            values: Any = new
        else:
            ok = np.asarray(math.isfinite(new) and new == math.floor(new))
            values = np.full(sub.n, new, dtype=object)
        if not ok.all():
            bad = np.broadcast_to(~ok, (sub.n,)) & (np.asarray(prob) != 0)
            if bad.any():
                r = int(np.flatnonzero(bad)[0])
                value = values[r]
                name = self.program.variable_names[a.variable]
                raise self.fail(
                    f"{cmd.text} assigns {value} to int variable '{name}', which is not a "
                    "whole number,",
                    a.span,
                    sub.root_row(r),
                    hint="Storm would truncate it toward zero; write floor(...), ceil(...) or "
                    "round(...) to say which whole number is meant",
                )
        if isinstance(new, np.ndarray):
            return np.where(ok, new, 0).astype(np.int64)
        return int(new) if ok.all() else 0

    # -- one batch ----------------------------------------------------------------------------

    def expand(self, keys: np.ndarray) -> list[_Block]:
        n = keys.shape[0]
        self.keys = keys
        cols = Columns(self.enc.decode(keys), n)
        self.cols = cols
        blocks: list[_Block] = []
        for gen in self.program.generators:
            if gen.kind is GeneratorKind.ASYNC:
                block = self.expand_async(gen, cols, keys)
            else:
                block = self.expand_sync(gen, cols, keys)
            if block is not None:
                blocks.append(block)
        has_choice = np.zeros(n, dtype=bool)
        for b in blocks:
            has_choice[b.src] = True
        if not has_choice.all():
            dead = np.flatnonzero(~has_choice)
            if not self.fix_deadlocks:
                raise self.fail(
                    "no command is enabled (deadlock)",
                    self.program.flat.modules[0].span if self.program.flat.modules else NO_SPAN,
                    int(dead[0]),
                    hint="add a command for this state, or build with deadlocks fixed (self-loops)",
                )
            blocks.append(
                _Block(
                    src=dead,
                    gen=self.program.deadlock_generator.index,
                    counts=np.ones(dead.size, dtype=np.int64),
                    keys=keys[dead],
                    probs=np.ones(dead.size),
                )
            )
        return blocks

    def guard_rows(self, cmd: Command, cols: Columns) -> np.ndarray | None:
        """Rows where the guard holds (None: all rows)."""
        g = self.evaluate(cmd.guard, cols)
        if cmd.guard.constant is not None:
            return None if g else np.zeros(0, dtype=np.int64)
        return np.flatnonzero(g)

    def check_sums(self, cmd: Command, probs: np.ndarray, sub: Columns) -> None:
        """``probs``: float64[m, U] of the command's updates on the rows of ``sub``."""
        if cmd.static_sum is not None:
            # all probabilities are constants: checked once (exactly when they are exact)
            if id(cmd) not in self.bad_static:
                return
            for up in cmd.updates:
                if ops.to_float(up.probability.constant or 0) < 0:
                    raise self.fail(
                        f"update probability {ops.to_float(up.probability.constant or 0):g} of "
                        f"{cmd.text} is negative",
                        up.span,
                        sub.root_row(0),
                    )
            if abs(ops.to_float(cmd.static_sum) - 1.0) > self.tol:
                raise self._sum_error(cmd, ops.to_float(cmd.static_sum), sub.root_row(0))
            return
        negative = probs < 0
        if negative.any():
            r, u = np.argwhere(negative)[0]
            raise self.fail(
                f"update probability {probs[r, u]:g} of {cmd.text} is negative",
                cmd.updates[u].span,
                sub.root_row(int(r)),
            )
        sums = probs.sum(axis=1)
        bad = ~(np.abs(sums - 1.0) <= self.tol)
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise self._sum_error(cmd, float(sums[r]), sub.root_row(r))

    def _sum_error(self, cmd: Command, total: float, row: int) -> BuildError:
        return self.fail(
            f"the update probabilities of {cmd.text} sum to {total:.12g}, not 1,",
            cmd.span,
            row,
            hint="the probabilities of a command must sum to 1 in every state where its guard "
            "holds",
        )

    def apply(
        self,
        upd_assignments: tuple[Assignment, ...],
        sub: Columns,
        tkeys: np.ndarray,
        prob: np.ndarray | float,
        cmd: Command,
    ) -> None:
        """Add the key deltas of one update's assignments (evaluated on ``sub``) to ``tkeys``."""
        layouts = self.enc.layouts
        for a in upd_assignments:
            new = self.evaluate(a.value, sub)
            old = sub[a.variable]
            lay = layouts[a.variable]
            if lay.is_bool:
                delta = np.asarray(new, dtype=np.int64) - old.astype(np.int64)
            else:
                if a.value.type is ExprType.DOUBLE:
                    new = self.whole(new, a, sub, prob, cmd)
                bad = (new < lay.low) | (new > lay.high)
                if np.any(bad):
                    bad = np.broadcast_to(bad, (sub.n,)) & (np.asarray(prob) != 0)
                    if bad.any():
                        r = int(np.flatnonzero(bad)[0])
                        value = int(new[r]) if isinstance(new, np.ndarray) else int(new)
                        name = self.program.variable_names[a.variable]
                        raise self.fail(
                            f"{cmd.text} assigns {value} to '{name}', outside its range "
                            f"[{lay.low}..{lay.high}],",
                            a.span,
                            sub.root_row(r),
                            hint=f"keep the value of '{name}' within [{lay.low}..{lay.high}] "
                            "(e.g. guard the command)",
                        )
                delta = new - old
            if lay.multiplier != 1:
                delta = delta * lay.multiplier
            if tkeys.shape[1] == 1:
                tkeys[:, 0] += delta
            else:
                tkeys[:, lay.word] += delta

    def expand_async(self, gen: Generator, cols: Columns, keys: np.ndarray) -> _Block | None:
        cmd = gen.command
        assert cmd is not None
        rows = self.guard_rows(cmd, cols)
        if rows is None:
            rows = np.arange(cols.n)
            sub = cols
        elif rows.size == 0:
            return None
        elif rows.size == cols.n:
            sub = cols
        else:
            sub = cols.take(rows)
        m = rows.size
        num_updates = len(cmd.updates)
        src_keys = keys[rows] if sub is not cols else keys
        tkeys = np.empty((m, num_updates, keys.shape[1]), dtype=np.int64)
        probs = np.empty((m, num_updates), dtype=np.float64)
        for u, upd in enumerate(cmd.updates):
            p = self.evaluate(upd.probability, sub)
            probs[:, u] = p
            if upd.assignments:
                tk = src_keys.copy()
                self.apply(upd.assignments, sub, tk, p, cmd)
                tkeys[:, u, :] = tk
            else:
                tkeys[:, u, :] = src_keys
        self.check_sums(cmd, probs, sub)
        return _Block(
            src=rows,
            gen=gen.index,
            counts=np.full(m, num_updates, dtype=np.int64),
            keys=tkeys.reshape(m * num_updates, keys.shape[1]),
            probs=probs.reshape(m * num_updates),
        )

    def expand_sync(self, gen: Generator, cols: Columns, keys: np.ndarray) -> _Block | None:
        n = cols.n
        enabled: list[np.ndarray] = []
        all_parts: np.ndarray | None = None
        for cmds in gen.parts:
            mat = np.zeros((n, len(cmds)), dtype=bool)
            for j, c in enumerate(cmds):
                mat[:, j] = self.evaluate(c.guard, cols)
            some = np.asarray(mat.any(axis=1))
            all_parts = some if all_parts is None else np.asarray(all_parts & some)
            if not all_parts.any():
                return None
            enabled.append(mat)
        assert all_parts is not None
        # one choice per combination of enabled commands, lexicographic (last module fastest)
        rows = np.flatnonzero(all_parts)
        combo: list[np.ndarray] = []
        for mat in enabled:
            r, col = np.nonzero(mat[rows])
            rows = rows[r]
            combo = [x[r] for x in combo] + [col]
        m = rows.size
        for i, ci, j, cj, var in gen.conflicts:
            clash = (combo[i] == ci) & (combo[j] == cj)
            if clash.any():
                k = int(np.flatnonzero(clash)[0])
                c2 = gen.parts[j][cj]
                name = self.program.variable_names[var]
                raise self.fail(
                    f"variable '{name}' is assigned by both module {gen.module_names[i]} and "
                    f"module {gen.module_names[j]} in a synchronised "
                    f"[{self.program.action_names[gen.action]}] choice",
                    c2.span,
                    int(rows[k]),
                    hint="only one of the synchronising commands may update a variable",
                )
        # branches, choice-major: cross join with the updates of each part in turn
        b_choice = np.arange(m)
        b_prob = np.ones(m)
        b_keys = keys[rows]
        for i, cmds in enumerate(gen.parts):
            num_upd = np.array([len(c.updates) for c in cmds], dtype=np.int64)
            offsets = np.concatenate(([0], np.cumsum(num_upd)[:-1]))
            cmd_of_choice = combo[i]
            cnt = num_upd[cmd_of_choice[b_choice]]
            if np.all(cnt == 1):
                rep = None
                upd = np.zeros(b_choice.size, dtype=np.int64)
            else:
                rep = np.repeat(np.arange(b_choice.size), cnt)
                upd = np.arange(rep.size) - np.repeat(np.cumsum(cnt) - cnt, cnt)
                b_choice = b_choice[rep]
                b_prob = b_prob[rep]
                b_keys = b_keys[rep]
            # group the branches by (command, update) with one sort
            code = offsets[cmd_of_choice[b_choice]] + upd
            order = np.argsort(code, kind="stable")
            bounds = np.searchsorted(code[order], np.arange(int(num_upd.sum()) + 1))
            for j, c in enumerate(cmds):
                choices_j = np.flatnonzero(cmd_of_choice == j)
                if choices_j.size == 0:
                    continue
                sub_c = cols.take(rows[choices_j])
                probs_c = np.empty((choices_j.size, len(c.updates)))
                for u, up in enumerate(c.updates):
                    probs_c[:, u] = self.evaluate(up.probability, sub_c)
                self.check_sums(c, probs_c, sub_c)
                for u, up in enumerate(c.updates):
                    g = offsets[j] + u
                    sel = order[bounds[g] : bounds[g + 1]]
                    if sel.size == 0:
                        continue
                    sub = cols.take(rows[b_choice[sel]])
                    p = self.evaluate(up.probability, sub)
                    b_prob[sel] *= p
                    if up.assignments:
                        tk = b_keys[sel]
                        self.apply(up.assignments, sub, tk, p, c)
                        b_keys[sel] = tk
        counts = np.bincount(b_choice, minlength=m).astype(np.int64)
        return _Block(src=rows, gen=gen.index, counts=counts, keys=b_keys, probs=b_prob)


# ---------------------------------------------------------------------------------------------
# the exploration loop
# ---------------------------------------------------------------------------------------------


def _canonical(
    blocks: list[_Block],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Concatenate the blocks and sort choices by (source, generator, position) and drop zero
    probability branches. Returns (src, gen, counts, keys, probs)."""
    src = np.concatenate([b.src for b in blocks])
    gen = np.concatenate([np.full(b.src.size, b.gen, dtype=np.int32) for b in blocks])
    counts = np.concatenate([b.counts for b in blocks])
    keys = np.concatenate([b.keys for b in blocks])
    probs = np.concatenate([b.probs for b in blocks])
    starts = np.cumsum(counts) - counts
    # blocks come in generator order and each is sorted by source: a stable sort by source gives
    # Storm's order (and is cheap: timsort merges the sorted runs)
    perm = np.argsort(src, kind="stable")
    if not np.array_equal(perm, np.arange(perm.size)):
        src = src[perm]
        gen = gen[perm]
        counts = counts[perm]
        st = starts[perm]
        total = int(counts.sum())
        new_starts = np.cumsum(counts) - counts
        bidx = np.repeat(st - new_starts, counts) + np.arange(total)
        keys = keys[bidx]
        probs = probs[bidx]
    nonzero = probs != 0
    if not nonzero.all():
        choice_of_branch = np.repeat(np.arange(counts.size), counts)
        counts = np.bincount(choice_of_branch[nonzero], minlength=counts.size).astype(np.int64)
        keys = keys[nonzero]
        probs = probs[nonzero]
    return src, gen, counts, keys, probs


class _MemoryGuard:
    """Stops exploring before memory runs out (``options.memory_guard``) or at
    ``options.deadline``: after each batch, the memory the build took so far (growth of the
    resident size) must still be available once more, for assembling the model."""

    _MARGIN = 64 << 20
    """Headroom kept beyond that, for the interpreter and the next batch's temporaries."""

    def __init__(self, options: BuildOptions) -> None:
        self.options = options
        self.start = resident_bytes() or 0

    def check(self, explored: int, num_found: int, progress: _Progress) -> None:
        deadline = self.options.deadline
        if deadline is not None and time.perf_counter() > deadline:
            progress.update(explored, num_found, final=True)
            raise LimitError(
                f"the time budget ran out while building the model: {num_found:,} states found, "
                f"{explored:,} explored",
                hint="give a larger --timeout, or choose smaller constants",
            )
        if not self.options.memory_guard:
            return
        available = available_bytes()
        resident = resident_bytes()
        if available is None or resident is None:
            return
        taken = max(0, resident - self.start)
        if available >= taken + self._MARGIN:
            return
        progress.update(explored, num_found, final=True)
        raise LimitError(
            f"the state space does not fit in memory: exploring stopped at {num_found:,} states "
            f"found ({explored:,} explored), having taken {format_bytes(taken)}, with "
            f"{format_bytes(available)} left (the kernel's available memory and the address-space "
            "limit, ulimit -v)",
            hint=f"choose smaller constants, or give --state-limit (e.g. --state-limit "
            f"{2 * num_found}) to explore up to that many states regardless of memory",
        )


def explore(
    program: Program,
    options: BuildOptions,
    on_states: Callable[[int], None] | None = None,
) -> Exploration:
    """Explore all states reachable from the initial states.

    Args:
        program: the compiled model.
        options: limits, deadlock handling, progress reporting, tolerance.
        on_states: called with the number of states found after every batch.

    Returns:
        The states, choices and branches in canonical order.

    Raises:
        BuildError: probabilities not summing to 1, negative probabilities, values out of range,
            conflicting synchronised assignments, failing expressions, deadlocks (when not fixed).
        LimitError: more than ``options.state_limit`` states.
    """
    t0 = time.perf_counter()
    enc = program.encoding
    wide = options.state_limit >= (1 << 31) - 2
    id_dtype = np.int64 if wide else np.int32
    index: StateIndex = make_index(enc, wide=wide)
    init_keys = initial_keys(program, options)
    _, _ = index.number_new(init_keys, 0)
    num_found = init_keys.shape[0]
    if num_found > options.state_limit:
        raise LimitError(
            f"state limit of {options.state_limit:,} reached ({num_found:,} initial states)"
        )
    store = _Rows(enc.num_words, capacity=max(1024, num_found))
    store.extend(init_keys)
    expander = _Expander(program, options)
    progress = _Progress(options.progress)

    gen_dtype = np.int16 if program.deadlock_generator.index < (1 << 15) else np.int32
    counts_buf = _Buffer(np.int32)  # choices per state
    gen_buf = _Buffer(gen_dtype)
    indptr_buf = _Buffer(id_dtype)
    indptr_buf.extend(np.zeros(1, dtype=id_dtype))
    target_buf = _Buffer(id_dtype)
    prob_buf = _Buffer(np.float64)
    dead_chunks: list[np.ndarray] = []
    deadlock_gen = program.deadlock_generator.index
    num_branches = 0

    explored = 0
    batch = 4096
    num_batches = 0
    guard = _MemoryGuard(options)
    while explored < num_found:
        hi = min(num_found, explored + batch)
        n_batch = hi - explored
        keys = store.view(explored, hi).copy()
        blocks = expander.expand(keys)
        src, gen, counts, tkeys, probs = _canonical(blocks)
        del blocks
        numbers = index.lookup(tkeys)
        unknown = np.flatnonzero(numbers < 0)
        if unknown.size:
            new_numbers, firsts = index.number_new(tkeys[unknown], num_found)
            numbers[unknown] = new_numbers
            store.extend(tkeys[unknown[firsts]])
            num_found += int(firsts.size)
        counts_buf.extend(np.bincount(src, minlength=n_batch).astype(np.int32))
        gen_buf.extend(gen.astype(gen_dtype))
        ends = np.cumsum(counts) + num_branches
        num_branches = int(ends[-1])
        if num_branches >= (1 << 31) - 1 and indptr_buf.data.dtype != np.int64:
            indptr_buf.upgrade(np.int64)
            target_buf.upgrade(np.int64)
        indptr_buf.extend(ends)
        target_buf.extend(numbers)
        prob_buf.extend(probs)
        dead = src[gen == deadlock_gen]
        if dead.size:
            dead_chunks.append(dead + explored)
        num_batches += 1
        explored = hi
        if num_found > options.state_limit:
            progress.update(explored, num_found, final=True)
            raise LimitError(
                f"state limit of {options.state_limit:,} reached: {num_found:,} states found, "
                f"{explored:,} explored",
                hint="raise the state limit or choose smaller constants",
            )
        guard.check(explored, num_found, progress)
        progress.update(explored, num_found)
        if on_states is not None:
            on_states(num_found)
        per_state = max(1.0, tkeys.shape[0] / max(1, n_batch))
        batch = int(min(_MAX_BATCH, max(_MIN_BATCH, _TARGET_BRANCHES / per_state)))
        del keys, src, gen, counts, tkeys, probs, numbers, unknown
    progress.update(explored, num_found, final=True)

    t1 = time.perf_counter()
    result = Exploration(
        state_keys=store.finish(),
        initial=np.arange(init_keys.shape[0], dtype=np.int64),
        choice_counts=counts_buf.finish(),
        choice_gen=gen_buf.finish(),
        indptr=indptr_buf.finish(),
        targets=target_buf.finish(),
        probs=prob_buf.finish(),
        deadlocks=(
            np.concatenate(dead_chunks).astype(np.int64)
            if dead_chunks
            else np.zeros(0, dtype=np.int64)
        ),
        num_batches=num_batches,
    )
    result.stats["explore_seconds"] = t1 - t0
    return result
