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
* at most two ``=?`` arguments (posgmc's Pareto fronts are two-dimensional).

Path formulas are checked when the query is answered (co-safe LTL, ``G F a``, ``F G a``), as for
single queries.
"""

from __future__ import annotations

from posgmc.errors import PosgmcError, SemanticError, UnsupportedError
from posgmc.semantics.evaluate import iter_nodes
from posgmc.syntax.ast import Expr, ModelType, MultiQuery, ProbQuery, RewardKind, RewardQuery

__all__ = ["check_multi", "MULTI_REWARD_KINDS", "MULTI_MODEL_TYPES"]

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
    if model_type not in MULTI_MODEL_TYPES:
        errors.append(
            UnsupportedError(
                f"multi-objective queries are answered on mdps (and dtmcs), not on "
                f"{model_type.value} models",
                top.span,
                hint="see docs/tradeoffs.md for what each model type supports (posg: "
                "posgmc pareto --sweep)",
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
    if queries > 2:
        errors.append(
            UnsupportedError(
                f"a Pareto query has at most two objectives (=?) here, found {queries}",
                top.span,
                hint="turn all but two into constraints (P>=p, R<=r)",
            )
        )
