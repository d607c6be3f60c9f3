"""``A [ path ]`` and ``E [ path ]`` for CTL path formulas: one temporal operator (``X``, ``F``,
``G``, ``U``, ``W``, ``R``, unbounded) over state formulas, reduced to the graph algorithms of
:mod:`posgmc.engines.ctl`:

* ``F b`` is ``true U b``; ``G a`` is ``!(true U !a)`` with the other quantifier;
* ``a W b`` is ``!(!b U (!a & !b))`` and ``a R b`` is ``!(!a U !b)``, with the other quantifier.

Any other path formula is LTL (``E [ G F a ]``, ``A [ a U (b U c) ]``): ``E [ phi ]`` holds where
some path of the graph satisfies ``phi``, found as an accepting cycle of the product with the
formula's limit-deterministic Büchi automaton (:mod:`posgmc.engines.ltl.omega`), and
``A [ phi ] = !E [ !phi ]``: PRISM's ``NonProbModelChecker`` (``checkExistsLTL``) semantics.

What PRISM does not check either (step-bounded operators under ``A``/``E``) is refused.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from posgmc.engines import ctl
from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import Expr, PathQuantifier, Temporal, TemporalOp, Unary, UnaryOp
from posgmc.syntax.placement import contains_temporal
from posgmc.syntax.traversal import any_node

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
    if not isinstance(path, Temporal) and not contains_temporal(path):
        return states(path)
    bounded = any_node(
        path,
        lambda n: isinstance(n, Temporal) and n.bound is not None,
        into=lambda n: contains_temporal(n),
    )
    if bounded:
        raise UnsupportedError(
            f"step-bounded temporal operators inside {name}[...] are not supported (nor are they "
            "in PRISM)", path.span, hint="ask P>0 [...] or P>=1 [...] with the bound instead")
    if not isinstance(path, Temporal) or any(contains_temporal(o) for o in path.operands):
        if universal:  # A [ phi ] = ! E [ !phi ]
            return ~_exists_ltl(model, Unary(UnaryOp.NOT, path, span=path.span), states)
        return _exists_ltl(model, path, states)
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


def _exists_ltl(
    model: ExplicitModel, path: Expr, states: Callable[[Expr], np.ndarray]
) -> np.ndarray:
    """bool[S]: where some path satisfies the LTL formula ``path`` (an accepting lasso of the
    product with its LDBA, probabilities ignored)."""
    from posgmc.engines import ltl

    atoms = ltl.extract_atoms(path)
    ltl.check_atoms(path, atoms)
    S = model.num_states
    values = (np.stack([states(a) for a in atoms]) if atoms
              else np.zeros((0, S), dtype=np.bool_))
    ldba = ltl.to_ldba(path, atoms, alphabet=np.unique(ltl.pack_letters(values)))
    prod = ltl.omega_product(model, ldba, values, starts=np.arange(S))
    at_start: np.ndarray = ltl.accepting_cycles(prod)[prod.initial_map]
    return at_start


def _not_ctl(name: str, expr: PathQuantifier) -> UnsupportedError:
    return UnsupportedError(
        f"{name}[...] is checked for CTL path formulas and LTL over state formulas", expr.span,
        hint="temporal operators may be combined with !, &, |, => and <=> only")
