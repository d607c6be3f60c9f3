"""Numerical engines on explicit models: graph precomputation, value/interval iteration, products.

* :mod:`posgmc.engines.objectives` -- the public entry points (reachability, rewards, strategies),
  re-exported from one module per objective family: :mod:`~posgmc.engines.reach`,
  :mod:`~posgmc.engines.step_bounds`, :mod:`~posgmc.engines.rewards` (with
  :mod:`~posgmc.engines.signed` for mixed-sign rewards), :mod:`~posgmc.engines.total`,
  :mod:`~posgmc.engines.zero_reward`, :mod:`~posgmc.engines.stepped`,
  :mod:`~posgmc.engines.discounted`, :mod:`~posgmc.engines.strategy`; shared plumbing in
  :mod:`~posgmc.engines.solving`;
* :mod:`posgmc.engines.options` / :mod:`posgmc.engines.result` -- configuration and result records;
* :mod:`posgmc.engines.graph` -- attractors, qualitative reachability, end components;
* :mod:`posgmc.engines.system` -- the fixpoint problem on the unknown states (:class:`System`) and
  the Bellman kernels every solver imports from there;
* :mod:`posgmc.engines.iteration` -- the sound iterative solver (optimistic interval iteration with
  end-component deflation/inflation) on a :class:`System`;
* :mod:`posgmc.engines.policy_iteration` -- direct solves and policy iteration;
* :mod:`posgmc.engines.rational` -- exact rational reachability for small models (test reference);
* :mod:`posgmc.engines.ltl` -- co-safe LTL to DFA and products (its own owner).
"""
