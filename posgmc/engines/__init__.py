"""Numerical engines on explicit models: graph precomputation, value/interval iteration, products.

* :mod:`posgmc.engines.objectives` -- the public entry points (reachability, rewards, strategies);
* :mod:`posgmc.engines.options` / :mod:`posgmc.engines.result` -- configuration and result records;
* :mod:`posgmc.engines.graph` -- attractors, qualitative reachability, end components;
* :mod:`posgmc.engines.iteration` -- the sound iterative solver (optimistic interval iteration with
  end-component deflation/inflation) on the unknown states;
* :mod:`posgmc.engines.exact` -- direct solves and policy iteration;
* :mod:`posgmc.engines.rational` -- exact rational reachability for small models (test reference);
* :mod:`posgmc.engines.ltl` -- co-safe LTL to DFA and products (its own owner).
"""
