"""A tiny dict-based explorer of FlatModels, the reference the vectorized builder is compared with.

It follows PRISM/Storm semantics one state at a time (Storm's ``PrismNextStateGenerator``):
non-synchronising commands module by module, then each shared action as the product of one enabled
command per module; zero-probability branches are skipped before their target is numbered; states
are numbered breadth-first in discovery order; a DTMC state's choices are merged with weight
1/(number of choices); states without choices get a self-loop.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction
from typing import Any

from posgmc.compiler import build_model
from posgmc.semantics.flat import FlatModel
from posgmc.syntax import ast as A

# ---------------------------------------------------------------------------------------------
# a scalar evaluator for the generated expressions (PRISM semantics)
# ---------------------------------------------------------------------------------------------


def ev(e: A.Expr, env: dict[str, Any]) -> Any:
    if isinstance(e, (A.IntLit, A.BoolLit, A.DoubleLit)):
        return e.value
    if isinstance(e, A.Ident):
        return env[e.name]
    if isinstance(e, A.Unary):
        v = ev(e.operand, env)
        return (not v) if e.op is A.UnaryOp.NOT else -v
    if isinstance(e, A.Binary):
        op = e.op
        if op is A.BinaryOp.AND:
            return bool(ev(e.left, env)) and bool(ev(e.right, env))
        if op is A.BinaryOp.OR:
            return bool(ev(e.left, env)) or bool(ev(e.right, env))
        a, b = ev(e.left, env), ev(e.right, env)
        return {
            A.BinaryOp.EQ: lambda: a == b,
            A.BinaryOp.NE: lambda: a != b,
            A.BinaryOp.LT: lambda: a < b,
            A.BinaryOp.LE: lambda: a <= b,
            A.BinaryOp.GT: lambda: a > b,
            A.BinaryOp.GE: lambda: a >= b,
            A.BinaryOp.ADD: lambda: a + b,
            A.BinaryOp.SUB: lambda: a - b,
            A.BinaryOp.MUL: lambda: a * b,
            A.BinaryOp.DIV: lambda: Fraction(a) / Fraction(b),
            A.BinaryOp.IMPLIES: lambda: (not a) or b,
            A.BinaryOp.IFF: lambda: bool(a) == bool(b),
        }[op]()
    if isinstance(e, A.Ite):
        return ev(e.then, env) if ev(e.cond, env) else ev(e.otherwise, env)
    if isinstance(e, A.Call):
        args = [ev(a, env) for a in e.args]
        if e.function is A.Function.MIN:
            return min(args)
        if e.function is A.Function.MAX:
            return max(args)
        if e.function is A.Function.MOD:
            return args[0] % args[1]
        if e.function is A.Function.FLOOR:
            return math.floor(args[0])
    raise NotImplementedError(e)


def reference(
    flat: FlatModel,
) -> tuple[list[tuple[int, ...]], list[list[tuple[str, dict[int, float]]]]]:
    """(valuations by state number, per state its choices as (action, {target: probability}))."""
    names = [v.name for v in flat.variables]
    is_bool = [v.type is A.VarType.BOOL for v in flat.variables]

    def env_of(s: tuple[int, ...]) -> dict[str, Any]:
        return {n: (bool(x) if b else x) for n, x, b in zip(names, s, is_bool)}

    if flat.init is None:
        initial = [tuple(v.init for v in flat.variables)]
    else:
        ranges = [range(v.low, v.high + 1) for v in flat.variables]
        initial = [s for s in itertools.product(*ranges) if ev(flat.init, env_of(s))]
    number: dict[tuple[int, ...], int] = {}
    order: list[tuple[int, ...]] = []

    def num(s: tuple[int, ...]) -> int:
        if s not in number:
            number[s] = len(order)
            order.append(s)
        return number[s]

    for s in initial:
        num(s)
    owners: dict[str, list[int]] = {}
    for mi, m in enumerate(flat.modules):
        for a in sorted(m.actions):
            owners.setdefault(a, []).append(mi)
    index = {n: i for i, n in enumerate(names)}

    def apply(s: list[int], update: Any, env: dict[str, Any]) -> None:
        for asg in update.assignments:
            s[index[asg.variable]] = int(ev(asg.value, env))

    result: list[list[tuple[str, dict[int, float]]]] = []
    i = 0
    while i < len(order):
        s = order[i]
        env = env_of(s)
        choices: list[tuple[str, dict[int, float]]] = []
        for m in flat.modules:
            for c in m.commands:
                if c.action is not None and len(owners[c.action]) > 1:
                    continue
                if not ev(c.guard, env):
                    continue
                dist: dict[int, float] = {}
                for u in c.updates:
                    p = ev(u.probability, env)
                    if p == 0:
                        continue
                    t = list(s)
                    apply(t, u, env)
                    k = num(tuple(t))
                    dist[k] = dist.get(k, 0.0) + float(p)
                choices.append((c.action or "", dist))
        for a in flat.actions:
            mods = owners[a]
            if len(mods) <= 1:
                continue
            lists = [
                [c for c in flat.modules[mi].commands if c.action == a and ev(c.guard, env)]
                for mi in mods
            ]
            if not all(lists):
                continue
            for combo in itertools.product(*lists):
                dist = {}
                for ups in itertools.product(*[c.updates for c in combo]):
                    p = Fraction(1)
                    t = list(s)
                    for u in ups:
                        p *= Fraction(ev(u.probability, env))
                        apply(t, u, env)
                    if p == 0:
                        continue
                    k = num(tuple(t))
                    dist[k] = dist.get(k, 0.0) + float(p)
                choices.append((a, dist))
        if not choices:
            choices = [("", {i: 1.0})]
        if flat.model_type is A.ModelType.DTMC and len(choices) > 1:
            merged: dict[int, float] = {}
            for _, d in choices:
                for k, p in d.items():
                    merged[k] = merged.get(k, 0.0) + p / len(choices)
            acts = {a for a, _ in choices}
            choices = [(acts.pop() if len(acts) == 1 else "", merged)]
        result.append(choices)
        i += 1
    return order, result


def compare_with_reference(flat: FlatModel) -> None:
    """The vectorized builder's model of ``flat`` is the reference explorer's, entry by entry."""
    order, choices = reference(flat)
    model = build_model(flat).model
    assert model.num_states == len(order)
    assert [tuple(int(x) for x in row) for row in model.state_values] == [
        tuple(int(x) for x in s) for s in order
    ]
    assert model.num_choices == sum(len(c) for c in choices)
    T = model.transitions
    rg = model.row_groups
    for s, cs in enumerate(choices):
        assert rg[s + 1] - rg[s] == len(cs)
        for k, (action, dist) in enumerate(cs):
            row = int(rg[s]) + k
            assert model.action_names[model.choice_actions[row]] == action
            lo, hi = T.indptr[row], T.indptr[row + 1]
            got = dict(zip(T.indices[lo:hi].tolist(), T.data[lo:hi].tolist()))
            assert got.keys() == dist.keys()
            for t, p in dist.items():
                assert math.isclose(got[t], p, rel_tol=1e-12)
    assert model.num_transitions == sum(len(d) for c in choices for _, d in c)
    model.validate()
