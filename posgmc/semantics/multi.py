"""Which ``multi(...)`` queries are well formed, and which of them posgmc answers.

PRISM's multi-objective queries (``prism/MultiObjModelChecker``, manual "Multi-objective
Properties"): ``multi(q1, ..., qn)`` where every ``qi`` is a ``P`` or ``R`` query on an MDP, either
with a threshold (a constraint: "some strategy achieves it") or ``=?`` with a direction (an
objective). No ``=?``: achievability (Boolean); one: numerical (the optimum subject to the
constraints); two: Pareto (the front of the two objectives subject to the constraints).

Checked here, each error at the offending argument:

* the query is a whole property (not nested in arithmetic or inside another query);
* the model is an mdp or a dtmc (smg, pomdp and posg are answered elsewhere or refused);
* each argument is a ``P``/``R`` query without a coalition; ``=?`` has ``min`` or ``max``;
* reward objectives are total ``[C]`` or cumulative ``[C<=k]`` (PRISM's fragment);
* at most :data:`MAX_PARETO_OBJECTIVES` ``=?`` arguments (a front of three or more is found in
  that many dimensions, :mod:`posgmc.engines.multi.pareto_nd`);
* PRISM-games' ``<<C>> (q1 & q2)`` on smgs: one or two objectives the coalition maximises
  (``P>=p``/``Pmax=?`` of co-safe formulas, ``R>=r``/``Rmax=?`` of total rewards ``[C]``).

Path formulas are checked when the query is answered (co-safe LTL, ``G F a``, ``F G a``), as for
single queries.
"""

from __future__ import annotations

from posgmc.errors import PosgmcError, SemanticError, UnsupportedError
from posgmc.syntax.ast import (
    ComparisonOp,
    Direction,
    Expr,
    ModelType,
    MultiQuery,
    ProbQuery,
    RewardKind,
    RewardQuery,
)
from posgmc.syntax.traversal import iter_nodes

__all__ = ["check_multi", "MULTI_REWARD_KINDS", "MULTI_MODEL_TYPES"]

MAX_PARETO_OBJECTIVES = 5
"""The most ``=?`` objectives of a Pareto query (the facets of the front grow fast with the
dimension)."""

MULTI_REWARD_KINDS = (RewardKind.TOTAL, RewardKind.CUMULATIVE)
"""The reward objectives a ``multi(...)`` query may hold."""

MULTI_MODEL_TYPES = (ModelType.MDP, ModelType.DTMC)
"""The model types on which ``multi(...)`` is answered."""


def check_multi(expr: Expr, *, model_type: ModelType, errors: list[PosgmcError]) -> None:
    """Append an error for every misuse of ``multi(...)`` in the property ``expr``."""
    top = expr if isinstance(expr, MultiQuery) else None
    for node in iter_nodes(expr):
        if isinstance(node, MultiQuery) and node is not top:
            errors.append(
                SemanticError(
                    "multi(...) must be a whole property, not part of an expression",
                    node.span,
                    hint="write it on a line of its own",
                )
            )
    if top is None:
        return
    if top.coalition is not None:
        _check_game_form(top, model_type=model_type, errors=errors)
        return
    if model_type not in MULTI_MODEL_TYPES:
        hint = ("on an smg write PRISM-games' coalition form <<C>> (q1 & q2) (docs/tradeoffs.md)"
                if model_type is ModelType.SMG else
                "see docs/tradeoffs.md for what each model type supports (posg: posgmc pareto "
                "--sweep)")
        errors.append(
            UnsupportedError(
                f"multi-objective queries are answered on mdps (and dtmcs), not on "
                f"{model_type.value} models",
                top.span,
                hint=hint,
            )
        )
    queries = 0
    for arg in top.objectives:
        if not isinstance(arg, (ProbQuery, RewardQuery)):
            errors.append(
                SemanticError(
                    "each argument of multi(...) must be a P or R query",
                    arg.span,
                    hint='e.g. multi(Pmax=? [ F "goal" ], R{"cost"}<=20 [ C ])',
                )
            )
            continue
        if arg.coalition is not None:
            errors.append(
                UnsupportedError("a multi(...) objective takes no coalition", arg.coalition.span)
            )
        if arg.threshold is None:
            queries += 1
            if arg.direction is None:
                kind = "P" if isinstance(arg, ProbQuery) else "R"
                errors.append(
                    SemanticError(
                        f"{kind}=? in multi(...) needs a direction",
                        arg.span,
                        hint=f"write {kind}max=? or {kind}min=?",
                    )
                )
        elif arg.direction is not None:  # pragma: no cover - the grammar has no such form
            errors.append(SemanticError("an objective has a direction and a bound", arg.span))
        if isinstance(arg, RewardQuery) and arg.objective.kind not in MULTI_REWARD_KINDS:
            errors.append(
                UnsupportedError(
                    f'multi(...) supports total [C] and cumulative [C<=k] rewards, not '
                    f'"{arg.objective.kind.value}"',
                    arg.objective.span if arg.objective.span.line else arg.span,
                    hint="express a reward until a target with a reward structure that is zero "
                    "from the target on, and [C]",
                )
            )
    if queries > MAX_PARETO_OBJECTIVES:
        errors.append(
            UnsupportedError(
                f"a Pareto query has at most {MAX_PARETO_OBJECTIVES} objectives (=?) here, found "
                f"{queries}",
                top.span,
                hint="turn some into constraints (P>=p, R<=r)",
            )
        )


def _check_game_form(top: MultiQuery, *, model_type: ModelType, errors: list[PosgmcError]) -> None:
    """PRISM-games' ``<<C>> (q1 & q2)`` on an smg: posgmc's fragment (docs/tradeoffs.md) is one
    or two objectives, each a probability ``P>=p`` / ``Pmax=?`` of a co-safe formula or an
    expected total reward ``R>=r [C]`` / ``Rmax=? [C]`` (the coalition maximises them all)."""
    if model_type is not ModelType.SMG:
        errors.append(
            UnsupportedError(
                f"a coalition over several objectives, <<C>> (q1 & q2), is answered on smgs, not "
                f"on "
                f"{model_type.value} models",
                top.span,
                hint="on an mdp write multi(q1, q2)"
                if model_type is ModelType.MDP
                else "see docs/tradeoffs.md",
            )
        )
        return
    if len(top.objectives) > 2:
        errors.append(
            UnsupportedError(
                f"a multi-objective game query has at most two objectives here, found "
                f"{len(top.objectives)}",
                top.span,
            )
        )
    for arg in top.objectives:
        if not isinstance(arg, (ProbQuery, RewardQuery)):
            errors.append(SemanticError(
                "each conjunct of <<C>> (...) must be a P or R query", arg.span,
                hint='e.g. <<p1>> (P>=0.9 [ F "goal" ] & R{"value"}>=2 [ C ])'))
            continue
        if arg.coalition is not None:
            errors.append(
                UnsupportedError(
                    "an objective inside <<C>> (...) takes no coalition of its own",
                    arg.coalition.span,
                )
            )
        upward = (
            arg.threshold is not None and arg.threshold.op in (ComparisonOp.GE, ComparisonOp.GT)
        ) or (arg.threshold is None and arg.direction is Direction.MAX)
        if not upward:
            errors.append(UnsupportedError(
                "in games posgmc answers objectives the coalition maximises: P>=p, P>p, Pmax=?, "
                "R>=r, R>r, Rmax=?",
                arg.span,
                hint="write a cost as a reward to be maximised (e.g. a budget left over), or "
                "check it alone",
            ))
        if isinstance(arg, RewardQuery) and arg.objective.kind is not RewardKind.TOTAL:
            errors.append(
                UnsupportedError(
                    f'in games multi-objective rewards are total rewards [C], not '
                    f'"{arg.objective.kind.value}"',
                    arg.objective.span if arg.objective.span.line else arg.span,
                )
            )
