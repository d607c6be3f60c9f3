"""Multi-objective MDP queries (PRISM's ``multi(...)``): the occupation-measure LP
(:mod:`~posgmc.engines.multi.lp`), the end components where paths settle and the probability
objectives they satisfy (:mod:`~posgmc.engines.multi.settle`), and two-objective Pareto fronts by
weighted sums (:mod:`~posgmc.engines.multi.pareto`). The translation of a query into these terms
(products with automata, step unfolding, directions) is :mod:`posgmc.checking.multi`."""

from posgmc.engines.multi.lp import LP_TOLERANCE, LPPoint, LPStatus, OccupationLP
from posgmc.engines.multi.pareto import ParetoFront, pareto_front
from posgmc.engines.multi.settle import Condition, ConditionKind, settling_options

__all__ = [
    "LP_TOLERANCE",
    "LPPoint",
    "LPStatus",
    "OccupationLP",
    "ParetoFront",
    "pareto_front",
    "Condition",
    "ConditionKind",
    "settling_options",
]
