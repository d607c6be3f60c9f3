"""``A [ path ]`` and ``E [ path ]`` for CTL path formulas: one temporal operator (``X``, ``F``,
``G``, ``U``, ``W``, ``R``, unbounded) over state formulas, reduced to the graph algorithms of
:mod:`posgmc.engines.ctl`:

* ``F b`` is ``true U b``; ``G a`` is ``!(true U !a)`` with the other quantifier;
* ``a W b`` is ``!(!b U (!a & !b))`` and ``a R b`` is ``!(!a U !b)``, with the other quantifier.

What PRISM does not check either (bounded operators, LTL under ``A``/``E``) is refused.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from posgmc.engines import ctl
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import Expr, PathQuantifier, Temporal, TemporalOp
from posgmc.syntax.placement import contains_temporal

__all__ = ["quantified_states"]


def quantified_states(
    model: ExplicitModel, expr: PathQuantifier, states: Callable[[Expr], np.ndarray]
) -> np.ndarray:
    """bool[S]: where ``expr`` holds.

    Args:
        model: the model (its graph).
        expr: the quantified path formula.
        states: evaluates a state formula (bool[S]).

    Raises:
        UnsupportedError: a step bound, or a path formula that is not CTL.
    """
    path, universal = expr.path, expr.universal
    name = "A" if universal else "E"
    if not isinstance(path, Temporal):
        if contains_temporal(path):
            raise _not_ctl(name, expr)
        return states(path)
    if path.bound is not None:
        raise UnsupportedError(
            f"step-bounded temporal operators inside {name}[...] are not supported (nor are they "
            "in PRISM)", path.span, hint="ask P>0 [...] or P>=1 [...] with the bound instead")
    if any(contains_temporal(o) for o in path.operands):
        raise _not_ctl(name, expr)
    ops = [states(o) for o in path.operands]
    every = np.ones(model.num_states, dtype=np.bool_)
    exists_until = ctl.exists_until
    forall_until = ctl.forall_until
    until, dual = (forall_until, exists_until) if universal else (exists_until, forall_until)
    op = path.op
    if op is TemporalOp.NEXT:
        return (ctl.forall_next if universal else ctl.exists_next)(model, ops[0])
    if op is TemporalOp.EVENTUALLY:
        return until(model, every, ops[0])
    if op is TemporalOp.GLOBALLY:
        return ~dual(model, every, ~ops[0])
    if op is TemporalOp.UNTIL:
        return until(model, ops[0], ops[1])
    if op is TemporalOp.WEAK_UNTIL:
        a, b = ops
        return ~dual(model, ~b, ~a & ~b)
    if op is TemporalOp.RELEASE:
        a, b = ops
        return ~dual(model, ~a, ~b)
    raise _not_ctl(name, expr)


def _not_ctl(name: str, expr: PathQuantifier) -> UnsupportedError:
    return UnsupportedError(
        f"{name}[...] is checked for CTL path formulas only: one of X, F, G, U, W, R over state "
        "formulas", expr.span,
        hint="for LTL use P>0 [...] (some path, for a dtmc) or P>=1 [...] (almost all paths)")
