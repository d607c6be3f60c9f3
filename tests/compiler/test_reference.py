"""The vectorized builder against a tiny dict-based explorer written here, on random small models.

The reference explorer follows PRISM/Storm semantics one state at a time (Storm's
``PrismNextStateGenerator``): non-synchronising commands module by module, then each shared action
as the product of one enabled command per module; zero-probability branches are skipped before
their target is numbered; states are numbered breadth-first in discovery order; a DTMC state's
choices are merged with weight 1/(number of choices); states without choices get a self-loop.
Both must agree on everything: numbering, valuations, choice order, actions, probabilities.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.compiler import build_model
from posgmc.semantics.flat import FlatModel
from posgmc.syntax import ast as A
from tests.compiler.flatlib import boolvar, cmd, ex, flat_model, module, upd, var

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


# ---------------------------------------------------------------------------------------------
# random models
# ---------------------------------------------------------------------------------------------

SPLITS = [
    [1],
    [Fraction(1, 2), Fraction(1, 2)],
    [Fraction(1, 3), Fraction(2, 3)],
    [Fraction(1, 5), Fraction(3, 10), Fraction(1, 2)],
    [0, 1],
]


@st.composite
def models(draw: st.DrawFn) -> FlatModel:
    model_type = draw(st.sampled_from([A.ModelType.DTMC, A.ModelType.MDP]))
    num_modules = draw(st.integers(1, 3))
    variables = []
    mod_vars: list[list[tuple[str, int, int, bool]]] = []
    use_global = draw(st.booleans())
    if use_global:
        variables.append(boolvar("g"))
    for mi in range(num_modules):
        vs = []
        for vi in range(draw(st.integers(1, 2))):
            name = f"v{mi}{vi}"
            if draw(st.booleans()):
                lo = draw(st.integers(-1, 1))
                hi = lo + draw(st.integers(1, 3))
                init = draw(st.integers(lo, hi))
                variables.append(var(name, lo, hi, init, module=f"m{mi}"))
                vs.append((name, lo, hi, False))
            else:
                variables.append(boolvar(name, draw(st.booleans()), module=f"m{mi}"))
                vs.append((name, 0, 1, True))
        mod_vars.append(vs)
    all_vars = [(v.name, v.low, v.high, v.type is A.VarType.BOOL) for v in variables]

    def atom() -> str:
        name, lo, hi, b = draw(st.sampled_from(all_vars))
        if b:
            return name if draw(st.booleans()) else f"not {name}"
        c = draw(st.integers(lo - 1, hi + 1))
        op = draw(st.sampled_from(["<", "<=", "==", "!=", ">"]))
        return f"{name} {op} {c}"

    def guard() -> str:
        kind = draw(st.integers(0, 4))
        if kind in (0, 4):
            return "true"
        if kind == 1:
            return atom()
        joiner = draw(st.sampled_from([" and ", " or "]))
        return "(" + atom() + joiner + atom() + ")"

    def value(name: str, lo: int, hi: int, b: bool) -> str:
        if b:
            return draw(st.sampled_from([f"not {name}", "true", "false", atom()]))
        size = hi - lo + 1
        c = draw(st.integers(-2, 2))
        return draw(
            st.sampled_from(
                [
                    f"mod({name} - {lo} + {c % size}, {size}) + {lo}",
                    f"min(max({name} + {c}, {lo}), {hi})",
                    str(draw(st.integers(lo, hi))),
                ]
            )
        )

    # half of the models label most commands [a] so that synchronisation is exercised often
    actions = [None, "a", "a", "b"] if draw(st.booleans()) else ["a", "a", "a", None]
    modules = []
    for mi, vs in enumerate(mod_vars):
        cmds = []
        for _ in range(draw(st.integers(1, 3))):
            action = draw(st.sampled_from(actions))
            updates = []
            for p in draw(st.sampled_from(SPLITS)):
                targets = [v for v in vs if draw(st.booleans())]
                if use_global and action is None and draw(st.booleans()):
                    targets.append(("g", 0, 1, True))
                updates.append(upd(p, *[(n, value(n, lo, hi, b)) for n, lo, hi, b in targets]))
            cmds.append(cmd(f"m{mi}", action, guard(), *updates))
        modules.append(module(f"m{mi}", [v[0] for v in vs], cmds))
    init = None
    if draw(st.booleans()):
        name, lo, hi, b = draw(st.sampled_from(all_vars))
        init = ex(f"{name} <= {lo}" if not b else f"not {name}")
    return flat_model(model_type, variables, modules, init=init)


def _compare(flat: FlatModel) -> None:
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


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models())
def test_vectorized_builder_equals_reference_explorer(flat: FlatModel) -> None:
    _compare(flat)


def test_reference_agrees_on_a_synchronising_example() -> None:
    # two modules synchronising on [a] with two enabled commands in one of them: 2 combinations
    flat = flat_model(
        A.ModelType.MDP,
        [var("x", 0, 2, module="m0"), var("y", 0, 1, module="m1")],
        [
            module(
                "m0",
                ["x"],
                [
                    cmd("m0", "a", "x < 2", upd(0.5, ("x", "x+1")), upd(0.5)),
                    cmd("m0", "a", "true", upd(1, ("x", 0))),
                ],
            ),
            module(
                "m1",
                ["y"],
                [cmd("m1", "a", "true", upd(Fraction(1, 3), ("y", "1-y")), upd(Fraction(2, 3)))],
            ),
        ],
    )
    _compare(flat)
    np.testing.assert_equal(build_model(flat).model.num_states, 6)
