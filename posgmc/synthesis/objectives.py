"""Objectives that synthesis reduces to reachability on a product: co-safe LTL and step bounds.

``<<d>> Pmax=? [ φ ]`` for a co-safe LTL formula φ (``F<=k b`` included: its automaton counts the
steps) and ``<<d>> R{"c"}min=? [ φ ]`` (the reward until φ is satisfied) become ``F "accept"`` on
the product of the game with φ's deterministic automaton (:mod:`posgmc.engines.ltl.product`).

What the players observe on the product — the soundness question:

* the decision maker observes what it observes in the game, **not** the automaton state (nor the
  step counter): its finite-state strategies on the product are exactly its finite-state
  strategies of the game (same rules, same file), and their value on the product is their value
  for φ in the game, because the automaton is deterministic (the product is an unfolding). A
  strategy that needs the automaton state must carry it in its own memory, which is what the
  memory sizes are for. Observing the automaton state would be sound only where the player can
  compute it from its own observations (every atom a function of its observations, and — for a
  step counter — every step one of its own turns, as in a POMDP); posgmc does not assume it, so
  it never reports a strategy that relies on information the player lacks;
* the adversary's enumerated strategies observe what the adversary observes in the game (a
  fully observing adversary: the game's state, not the automaton's), so they are strategies of
  the game too; the omniscient adversary of ``guaranteed`` sees the whole product state;
* the full-information numbers (``full_observation``, ``upper_bound``) let the decision maker
  see the automaton state: full information includes the history.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from posgmc.errors import UnsupportedError
from posgmc.model.explicit import ExplicitModel
from posgmc.syntax.ast import (
    Expr,
    LabelRef,
    ProbQuery,
    RewardKind,
    RewardObjective,
    RewardQuery,
    Temporal,
    TemporalOp,
)
from posgmc.synthesis.parametric import game_views

if TYPE_CHECKING:
    from posgmc.checking.property_checker import PropertyChecker

__all__ = ["needs_product", "lift"]


def _plain(path: Expr) -> bool:
    """``F b`` or ``a U b`` without a step bound, over state formulas."""
    return (isinstance(path, Temporal) and path.bound is None
            and path.op in (TemporalOp.EVENTUALLY, TemporalOp.UNTIL)
            and not any(_temporal(o) for o in path.operands))


def _temporal(expr: Expr) -> bool:
    if isinstance(expr, Temporal):
        return True
    return any(_temporal(v) for v in vars(expr).values() if isinstance(v, Expr)) or any(
        _temporal(x) for v in vars(expr).values() if isinstance(v, tuple) for x in v
        if isinstance(x, Expr))


def needs_product(expr: Expr) -> bool:
    """Whether ``expr`` is a P query of a path other than plain ``F b``/``a U b``, or an R query
    of a co-safe LTL formula."""
    if isinstance(expr, ProbQuery):
        return not _plain(expr.path)
    return isinstance(expr, RewardQuery) and expr.objective.kind is RewardKind.LTL


def lift(
    model: ExplicitModel, expr: ProbQuery | RewardQuery, checker: PropertyChecker
) -> tuple[ExplicitModel, ProbQuery | RewardQuery]:
    """The product of ``model`` with the automaton of ``expr``'s formula, and the reachability
    query that answers ``expr`` on it (see the module docstring for what each player observes).

    Args:
        checker: a :class:`~posgmc.checking.property_checker.PropertyChecker` of ``model`` (it
            evaluates the formula's atoms and builds the automaton product).

    Raises:
        UnsupportedError: the formula is not co-safe LTL.
    """
    from posgmc.engines import ltl

    path = expr.path if isinstance(expr, ProbQuery) else expr.objective.target
    assert path is not None  # noqa: S101 - an LTL objective has its formula
    if not ltl.is_cosafe(path):
        raise UnsupportedError(
            "synthesis takes co-safe LTL (X, F, U, step bounds, bounded G, boolean connectives)",
            path.span,
            hint="for a safety objective G a, synthesise the opposite player's Pmin/Pmax of F !a",
        )
    checker._everywhere = False  # the initial states' values only
    prod, _ = checker._ltl_product(path)
    pm = prod.model
    name = "accept"
    while name in pm.labels:
        name = "_" + name
    labels = dict(pm.labels)
    labels[name] = np.asarray(prod.accepting, dtype=bool)
    # the automaton state is no part of any player's view: the observations are the model's,
    # a fully observing player observes the model state (game_views), and the valuations are
    # the model state's
    lifted = dataclasses.replace(
        game_views(model, pm, prod.state_of),
        labels=labels,
        variable_names=model.variable_names,
        state_values=model.state_values[prod.state_of]
        if model.state_values.shape[0] == model.num_states
        else model.state_values,
    )
    target = Temporal(TemporalOp.EVENTUALLY, (LabelRef(name, span=path.span),), span=path.span)
    if isinstance(expr, ProbQuery):
        return lifted, dataclasses.replace(expr, path=target)
    return lifted, dataclasses.replace(
        expr, objective=RewardObjective(RewardKind.REACH, target=LabelRef(name, span=path.span),
                                        span=expr.objective.span))
