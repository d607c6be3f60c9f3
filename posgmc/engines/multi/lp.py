"""The occupation-measure linear program of multi-objective MDP queries.

The LP of Etessami, Kwiatkowska, Vardi and Yannakakis (LMCS 2008) in the form of Forejt,
Kwiatkowska, Norman, Parker and Qu ("Quantitative multi-objective verification for probabilistic
systems", TACAS 2011), which PRISM's LP method solves. Every objective is first written as a
function of where a path **settles**: with probability 1 a path of a finite MDP eventually stays
in an end component and visits all of its states infinitely often (under the strategy the LP
yields, which plays the component's choices uniformly once it settles). So

* ``y[c]`` >= 0, one per choice: the expected number of times choice ``c`` is taken before the
  path settles;
* ``z[k]`` >= 0, one per **settling option** ``k`` (a state ``stop_state[k]`` in an end component
  of the allowed choices, see :mod:`posgmc.engines.multi.settle`): the probability that the path
  settles there, satisfying the probability objectives ``stop_sat[k]``;
* flow: for every state ``s``, ``sum_{c of s} y[c] + sum_{k at s} z[k] - sum_c y[c] P(c, s) =
  [s = s0]`` (rows stochastic, so ``sum_k z[k] = 1``);
* probability objective ``i``: ``sum_k z[k] stop_sat[k, i]``; reward objective: ``sum_c y[c] r(c)``.

Every objective value is linear in ``x = (y, z)``: ``values = coefficients @ x``, all in the
maximising sense (a minimised reward enters negated, a minimised probability as its complement;
the caller converts back). An LP optimum is a floating-point number from HiGHS, exact only up to
its feasibility tolerances: :class:`LPPoint` carries the residual of the returned solution, and
callers report LP numbers as such (not as proven bounds).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import OptimizeResult, linprog

__all__ = ["OccupationLP", "LPPoint", "LPStatus", "LP_TOLERANCE"]

LP_TOLERANCE = 1e-9
"""HiGHS's primal and dual feasibility tolerances as posgmc sets them."""


class LPStatus(enum.Enum):
    OPTIMAL = "optimal"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"
    FAILED = "failed"  # HiGHS gave up (iteration limit, numerical trouble)


@dataclass(frozen=True, eq=False)
class LPPoint:
    """One LP solve. ``values``: float64[n], every objective at the solution (maximising sense;
    ``+inf`` for the optimised one when unbounded); ``x`` the solution; ``residual`` the largest
    violation of the flow equations, bounds and constraints by ``x``; ``extra`` the value of an
    auxiliary variable (the slack of :meth:`OccupationLP.slack`)."""

    status: LPStatus
    values: np.ndarray
    x: np.ndarray | None
    residual: float
    extra: float = float("nan")
    message: str = ""


@dataclass(frozen=True, eq=False)
class OccupationLP:
    """The LP's fixed part.

    ``flow``: csr float64 [S, C + K], the flow equations' matrix; ``initial``: float64[S], their
    right-hand side; ``coefficients``: float64[n, C + K], row i the objective i in the
    maximising sense; ``num_choices`` = C.
    """

    flow: sp.csr_matrix
    initial: np.ndarray
    coefficients: np.ndarray
    num_choices: int

    @staticmethod
    def build(
        transitions: sp.csr_matrix,
        row_groups: np.ndarray,
        initial_state: int,
        stop_state: np.ndarray,
        coefficients: np.ndarray,
    ) -> OccupationLP:
        """The LP of an MDP (``transitions`` csr [C, S] grouped by ``row_groups``) from state
        ``initial_state``, with settling options at ``stop_state`` (int64[K]) and objective rows
        ``coefficients`` (float64[n, C + K])."""
        num_choices, num_states = transitions.shape
        counts = np.diff(row_groups)
        owner = np.repeat(np.arange(num_states), counts)
        out_y = sp.csr_matrix(
            (np.ones(num_choices), (owner, np.arange(num_choices))), shape=(num_states, num_choices)
        )
        out_z = sp.csr_matrix(
            (np.ones(stop_state.size), (stop_state, np.arange(stop_state.size))),
            shape=(num_states, stop_state.size),
        )
        flow = sp.hstack([out_y - transitions.T.tocsr(), out_z], format="csr")
        initial = np.zeros(num_states)
        initial[initial_state] = 1.0
        return OccupationLP(flow, initial, np.asarray(coefficients, dtype=float), num_choices)

    @property
    def num_objectives(self) -> int:
        return int(self.coefficients.shape[0])

    # -- solves ----------------------------------------------------------------------------------

    def maximise(
        self, weights: np.ndarray, *, at_least: dict[int, float] | None = None
    ) -> LPPoint:
        """Maximise ``weights @ values`` subject to ``values[i] >= at_least[i]``."""
        at_least = at_least or {}
        c = -(np.asarray(weights, dtype=float) @ self.coefficients)
        rows = sorted(at_least)
        a_ub = -self.coefficients[rows] if rows else None
        b_ub = -np.array([at_least[i] for i in rows]) if rows else None
        res = self._solve(c, a_ub, b_ub, self.flow, (0, None))
        if res.status == 3:
            values = np.full(self.num_objectives, np.nan)
            values[np.asarray(weights) != 0] = np.inf
            return LPPoint(LPStatus.UNBOUNDED, values, None, 0.0, message=res.message)
        return self._point(res, rows, at_least)

    def slack(self, at_least: dict[int, float], scale: dict[int, float]) -> LPPoint:
        """The largest ``t <= 1`` with ``values[i] - at_least[i] >= t * scale[i]`` for all
        constrained ``i`` (achievability with a margin: ``t`` > 0 means every constraint holds
        with room ``t * scale[i]``); ``extra`` is ``t``."""
        rows = sorted(at_least)
        n = self.flow.shape[1]
        c = np.zeros(n + 1)
        c[-1] = -1.0
        a_ub = np.hstack([-self.coefficients[rows], np.array([[scale[i]] for i in rows])])
        b_ub = -np.array([at_least[i] for i in rows])
        flow = sp.hstack([self.flow, sp.csr_matrix((self.flow.shape[0], 1))], format="csr")
        bounds = [(0, None)] * n + [(None, 1.0)]
        res = self._solve(c, a_ub, b_ub, flow, bounds)
        if res.status != 0 or res.x is None:
            return self._point(res, [], {})
        point = self._point(res, [], {}, x=res.x[:n])
        return LPPoint(point.status, point.values, point.x, point.residual, float(res.x[-1]))

    def _solve(
        self,
        c: np.ndarray,
        a_ub: np.ndarray | None,
        b_ub: np.ndarray | None,
        flow: sp.csr_matrix,
        bounds: tuple[float | None, float | None] | Sequence[tuple[float | None, float | None]],
    ) -> OptimizeResult:
        return linprog(
            c,
            A_ub=a_ub,
            b_ub=b_ub,
            A_eq=flow,
            b_eq=self.initial,
            bounds=bounds,
            method="highs",
            options={
                "primal_feasibility_tolerance": LP_TOLERANCE,
                "dual_feasibility_tolerance": LP_TOLERANCE,
                "presolve": True,
            },
        )

    def _point(
        self,
        res: OptimizeResult,
        rows: Sequence[int],
        at_least: Mapping[int, float],
        *,
        x: np.ndarray | None = None,
    ) -> LPPoint:
        if res.status == 2:
            return LPPoint(LPStatus.INFEASIBLE, np.full(self.num_objectives, np.nan), None,
                           0.0, message=res.message)
        if res.status != 0 or res.x is None:
            return LPPoint(LPStatus.FAILED, np.full(self.num_objectives, np.nan), None, 0.0,
                           message=res.message)
        x = res.x if x is None else x
        values = self.coefficients @ x
        residual = float(np.max(np.abs(self.flow @ x - self.initial), initial=0.0))
        residual = max(residual, float(-np.min(x, initial=0.0)))
        for i in rows:
            residual = max(residual, at_least[i] - float(values[i]))
        return LPPoint(LPStatus.OPTIMAL, values, x, residual)
