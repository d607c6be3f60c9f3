"""Exact exploration (PRISM's ``-exact``): every guard, probability and update in rational
arithmetic.

The vectorised explorer (:mod:`posgmc.compiler.explore`) computes in IEEE doubles, so a guard such
as ``(s+1)*1/3 = 0.333333333333333333333333`` holds there (both sides round to one double) although
it is false over the rationals, and a probability written ``0.500000000000000000000000000000001``
becomes 0.5. In exact mode the model is explored state by state with the scalar evaluator
(:func:`posgmc.semantics.evaluate.evaluate`) under
:func:`posgmc.semantics.operators.exact_arithmetic`: ints and Fractions only, and a value with no
rational form (a fractional power, a logarithm, a division by zero) is a positioned
:class:`~posgmc.errors.BuildError`, as in PRISM's exact engine.

The semantics is the vectorised explorer's, one state at a time: states numbered in discovery
order, choices in :mod:`posgmc.compiler.program`'s generator order, a synchronised choice per
combination of enabled commands (last module fastest) whose branches are the products of the
modules' updates (first module slowest), zero-probability branches dropped, deadlocks fixed with a
self-loop when allowed. A command's probabilities must sum to exactly 1.

The exploration is handed to :func:`posgmc.compiler.assemble.assemble` (with the probabilities
rounded to the nearest doubles) for rewards, players and observations; :func:`exact_model` then
attaches the exact transition probabilities (``ExplicitModel.exact_probabilities``, aligned with the
CSR matrix) and re-evaluates the labels exactly. A Python loop per state: meant for the small models
exact checking is for.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import replace
from fractions import Fraction
from types import MappingProxyType

import numpy as np

from posgmc.compiler.explore import Exploration, initial_keys
from posgmc.compiler.options import BuildOptions
from posgmc.compiler.program import Command, Generator, GeneratorKind, Program
from posgmc.errors import BuildError, LimitError, PosgmcError, SourceSpan
from posgmc.model.explicit import ExplicitModel
from posgmc.semantics import operators as ops
from posgmc.semantics.evaluate import Value, evaluate
from posgmc.syntax.ast import NO_SPAN, Expr, ModelType, VarType

__all__ = ["exact_model", "explore_exact"]

State = tuple[int, ...]
_Branches = list[tuple[Fraction, State]]


def _span(span: SourceSpan) -> SourceSpan | None:
    return None if span == NO_SPAN else span


class _Evaluator:
    """Evaluates the flat model's expressions exactly at one state, with positioned errors."""

    def __init__(self, program: Program) -> None:
        self.program = program
        self.names = program.variable_names
        self.is_bool = [v.type is VarType.BOOL for v in program.flat.variables]
        self.slots = {name: i for i, name in enumerate(self.names)}
        self.ranges = [(v.low, v.high) for v in program.flat.variables]

    def env(self, state: State) -> dict[str, Value]:
        return {n: (bool(v) if b else v) for n, v, b in zip(self.names, state, self.is_bool)}

    def value(self, expr: Expr, env: dict[str, Value], state: State) -> Value:
        try:
            v = evaluate(expr, env)
        except PosgmcError as err:
            raise BuildError(
                f"{err.message} in state {self.program.describe(list(state))}",
                err.span or _span(expr.span),
            ) from None
        if isinstance(v, float):  # only a non-rational value can be a float in exact mode
            raise BuildError(
                f"the value {v!r} is not exact in state {self.program.describe(list(state))}",
                _span(expr.span),
            )
        return v

    def probability(self, expr: Expr, env: dict[str, Value], state: State) -> Fraction:
        v = self.value(expr, env, state)
        if isinstance(v, bool):
            raise BuildError("a probability must be a number", _span(expr.span))
        p = Fraction(v)
        if p < 0:
            raise BuildError(
                f"negative probability {p} in state {self.program.describe(list(state))}",
                _span(expr.span),
            )
        return p


def _guard(cmd: Command) -> Expr:
    assert cmd.source is not None
    return cmd.source.guard


def _branches(cmd: Command, ev: _Evaluator, env: dict[str, Value], state: State) -> _Branches:
    """The updates of one enabled command: (probability, assignments as a partial state)."""
    source = cmd.source
    assert source is not None
    out: _Branches = []
    total = Fraction(0)
    for up in source.updates:
        p = ev.probability(up.probability, env, state)
        total += p
        target = list(state)
        for a in up.assignments:
            i = ev.slots[a.variable]
            v = ev.value(a.value, env, state)
            value = int(v) if isinstance(v, (bool, int)) else v
            low, high = ev.ranges[i]
            if not isinstance(value, int) or not low <= value <= high:
                raise BuildError(
                    f"the update gives variable '{a.variable}' the value {v}, outside its range "
                    f"[{low}..{high}], in state {ev.program.describe(list(state))}",
                    _span(a.span),
                )
            target[i] = value
        out.append((p, tuple(target)))
    if total != 1:
        raise BuildError(
            f"the probabilities of the {cmd.text} sum to {total}, not exactly 1, in state "
            f"{ev.program.describe(list(state))}",
            _span(cmd.span),
            hint="in exact mode the probabilities of a command must sum to exactly 1",
        )
    return out


def _sync(gen: Generator, ev: _Evaluator, env: dict[str, Value], state: State) -> list[_Branches]:
    """The choices of a synchronised action: one per combination of enabled commands."""
    enabled: list[list[tuple[Command, _Branches]]] = []
    for part in gen.parts:
        ok = [(c, _branches(c, ev, env, state)) for c in part if ev.value(_guard(c), env, state)]
        if not ok:
            return []
        enabled.append(ok)
    choices = []
    for combo in itertools.product(*enabled):
        assigned: dict[int, str] = {}
        for cmd, _ in combo:
            for var in cmd.assigned:
                if var in assigned:
                    raise BuildError(
                        f"two synchronising commands assign variable '{ev.names[var]}' in state "
                        f"{ev.program.describe(list(state))}",
                        _span(cmd.span),
                    )
                assigned[var] = ev.names[var]
        branches: _Branches = []
        for parts in itertools.product(*(b for _, b in combo)):
            p = Fraction(1)
            target = list(state)
            for (cmd, _), (q, t) in zip(combo, parts):
                p *= q
                for var in cmd.assigned:
                    target[var] = t[var]
            branches.append((p, tuple(target)))
        choices.append(branches)
    return choices


def explore_exact(
    program: Program, options: BuildOptions
) -> tuple[Exploration, list[Fraction]]:
    """Explore in rational arithmetic; returns the exploration (probabilities rounded to doubles)
    and the exact probability of every branch, in the exploration's branch order.

    Raises:
        BuildError: as the vectorised explorer, plus values without an exact form and command
            probabilities that do not sum to exactly 1.
        LimitError: more than ``options.state_limit`` states.
    """
    ev = _Evaluator(program)
    init = [
        tuple(int(x) for x in row)
        for row in program.encoding.decode_values(initial_keys(program, options))
    ]
    number: dict[State, int] = {s: i for i, s in enumerate(init)}
    states: list[State] = list(init)
    counts: list[int] = []
    gens: list[int] = []
    indptr: list[int] = [0]
    targets: list[int] = []
    exact: list[Fraction] = []
    deadlocks: list[int] = []
    with ops.exact_arithmetic():
        s = 0
        while s < len(states):
            state = states[s]
            env = ev.env(state)
            choices: list[tuple[int, _Branches]] = []
            for gen in program.generators:
                if gen.kind is GeneratorKind.ASYNC:
                    assert gen.command is not None
                    if ev.value(_guard(gen.command), env, state):
                        choices.append((gen.index, _branches(gen.command, ev, env, state)))
                else:
                    choices.extend((gen.index, b) for b in _sync(gen, ev, env, state))
            if not choices:
                if not options.fix_deadlocks:
                    raise BuildError(
                        f"deadlock in state {program.describe(list(state))}",
                        hint="allow deadlocks to be fixed with self-loops",
                    )
                deadlocks.append(s)
                choices.append((program.deadlock_generator.index, [(Fraction(1), state)]))
            counts.append(len(choices))
            for g, branches in choices:
                gens.append(g)
                for p, target in branches:
                    if p == 0:
                        continue
                    t = number.get(target)
                    if t is None:
                        t = number[target] = len(states)
                        states.append(target)
                        if len(states) > options.state_limit:
                            raise LimitError(
                                f"state limit of {options.state_limit:,} reached in exact mode",
                                hint="exact checking is meant for small models",
                            )
                    targets.append(t)
                    exact.append(p)
                indptr.append(len(targets))
            s += 1
    columns = [np.array([st[i] for st in states], dtype=np.int64) for i in range(len(ev.names))]
    keys = (
        program.encoding.encode(columns)
        if columns
        else np.zeros((len(states), program.encoding.num_words), dtype=np.int64)
    )
    exploration = Exploration(
        state_keys=keys,
        initial=np.arange(len(init), dtype=np.int64),
        choice_counts=np.array(counts, dtype=np.int32),
        choice_gen=np.array(gens, dtype=np.int32),
        indptr=np.array(indptr, dtype=np.int64),
        targets=np.array(targets, dtype=np.int64),
        probs=np.array([float(p) for p in exact], dtype=np.float64),
        deadlocks=np.array(deadlocks, dtype=np.int64),
    )
    return exploration, exact


def exact_model(
    model: ExplicitModel,
    program: Program,
    counts: Sequence[int],
    indptr: Sequence[int],
    targets: Sequence[int],
    exact: Sequence[Fraction],
) -> ExplicitModel:
    """``model`` (assembled from the exact exploration) with its exact transition probabilities and
    exactly evaluated labels.

    ``counts``, ``indptr``, ``targets``, ``exact``: the exploration's choices per state, branch
    offsets, targets and exact probabilities. A DTMC's choices are merged per state with weight
    ``1/number of choices``, as the assembler does; duplicates are summed and each row sorted by
    target, which is the CSR layout of ``model.transitions``.
    """
    rows: list[dict[int, Fraction]] = []
    c = 0
    for n in counts:
        if model.model_type is ModelType.DTMC:
            merged: dict[int, Fraction] = {}
            for k in range(c, c + n):
                for b in range(indptr[k], indptr[k + 1]):
                    merged[targets[b]] = merged.get(targets[b], Fraction(0)) + exact[b] / n
            rows.append(merged)
        else:
            for k in range(c, c + n):
                row: dict[int, Fraction] = {}
                for b in range(indptr[k], indptr[k + 1]):
                    row[targets[b]] = row.get(targets[b], Fraction(0)) + exact[b]
                rows.append(row)
        c += n
    data = [p for row in rows for _, p in sorted(row.items())]
    columns = [t for row in rows for t in sorted(row)]
    matrix = model.transitions
    if len(data) != matrix.nnz or not np.array_equal(
        matrix.indices, np.array(columns, dtype=matrix.indices.dtype)
    ):
        raise BuildError(
            "internal: the exact probabilities do not line up with the transition matrix"
        )
    ev = _Evaluator(program)
    labels = dict(model.labels)
    with ops.exact_arithmetic():
        for name, expr in program.flat.labels:
            values = np.empty(model.num_states, dtype=bool)
            for s in range(model.num_states):
                state = tuple(int(v) for v in model.state_values[s])
                values[s] = bool(ev.value(expr, ev.env(state), state))
            labels[name] = values
    exact_data = np.empty(len(data), dtype=object)
    exact_data[:] = data
    return replace(model, labels=MappingProxyType(labels), exact_probabilities=exact_data)
