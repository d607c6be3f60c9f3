"""The objectives posgmc computes on fully observable models (dtmc, mdp, turn-based smg): the one
import for callers (``from posgmc.engines import objectives as obj``); the code lives in small
modules, one objective family each, re-exported here.

Every function takes the optimisation direction per state (``maximize``: bool[S], True where the
state's owner maximises the quantity; see :func:`maximize_mask`) and returns an
:class:`~posgmc.engines.result.EngineResult` for every state. The pattern is always the same:

1. graph precomputation settles the states with a qualitative answer exactly (probability 0 or 1,
   reward 0 or infinite; for games the attractor-based versions, see :mod:`posgmc.engines.graph`);
2. the rest becomes a :class:`~posgmc.engines.system.System` solved by sound interval iteration
   (default), plain value iteration, or policy iteration / direct solves;
3. a memoryless strategy is extracted; where the player who wants the target reached has end
   components, its choices are fixed by an attractor towards the target among its (near-)optimal
   choices, so that the strategy really reaches the target.

Step-bounded objectives (``U<=k``, ``X``, ``C<=k``, ``I=k``) are exact up to floating point: k
Bellman steps. Discounted objectives get sound bounds from the contraction factor.

Where each part lives:

* :mod:`posgmc.engines.solving` -- :func:`maximize_mask`, argument checks, the solve dispatch
  (step 2), result assembly and the attractor fix (step 3), shared by all below;
* :mod:`posgmc.engines.reach` -- :func:`reach_probability`, :func:`bounded_reach_probability`,
  :func:`next_probability`;
* :mod:`posgmc.engines.rewards` -- :func:`expected_reach_reward` (``R[F]``, ``R[Fc]``, ``R[F0]``,
  :class:`ReachRewardMode`), including rewards of mixed sign;
* :mod:`posgmc.engines.total` -- :func:`total_reward` (``R[C]``) and the non-negative ``R[Fc]``;
* :mod:`posgmc.engines.zero_reward` -- ``R[F0]``;
* :mod:`posgmc.engines.stepped` -- :func:`cumulative_reward`, :func:`instantaneous_reward`;
* :mod:`posgmc.engines.discounted` -- :func:`discounted_total_reward`,
  :func:`discounted_reach_reward`;
* :mod:`posgmc.engines.strategy` -- :func:`induced_chain`;
* :mod:`posgmc.engines.rational` -- :func:`exact_rational_reach` (exact reference for small models).
"""

from __future__ import annotations

from posgmc.engines.discounted import discounted_reach_reward, discounted_total_reward
from posgmc.engines.rational import exact_rational_reach
from posgmc.engines.reach import bounded_reach_probability, next_probability, reach_probability
from posgmc.engines.rewards import ReachRewardMode, expected_reach_reward
from posgmc.engines.solving import maximize_mask
from posgmc.engines.stepped import cumulative_reward, instantaneous_reward
from posgmc.engines.strategy import induced_chain
from posgmc.engines.total import total_reward

__all__ = [
    "ReachRewardMode",
    "maximize_mask",
    "reach_probability",
    "bounded_reach_probability",
    "next_probability",
    "expected_reach_reward",
    "cumulative_reward",
    "instantaneous_reward",
    "total_reward",
    "discounted_total_reward",
    "discounted_reach_reward",
    "induced_chain",
    "exact_rational_reach",
]
