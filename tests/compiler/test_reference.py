"""The vectorized builder against a tiny dict-based explorer (tests/compiler/helpers.py), on random
small models.

The reference explorer follows PRISM/Storm semantics one state at a time (Storm's
``PrismNextStateGenerator``): non-synchronising commands module by module, then each shared action
as the product of one enabled command per module; zero-probability branches are skipped before
their target is numbered; states are numbered breadth-first in discovery order; a DTMC state's
choices are merged with weight 1/(number of choices); states without choices get a self-loop.
Both must agree on everything: numbering, valuations, choice order, actions, probabilities.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posgmc.compiler import build_model
from posgmc.semantics.flat import FlatModel
from posgmc.syntax import ast as A
from tests.compiler.flatlib import boolvar, cmd, ex, flat_model, module, upd, var
from tests.compiler.helpers import compare_with_reference

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


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models())
def test_vectorized_builder_equals_reference_explorer(flat: FlatModel) -> None:
    compare_with_reference(flat)


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
    compare_with_reference(flat)
    np.testing.assert_equal(build_model(flat).model.num_states, 6)
