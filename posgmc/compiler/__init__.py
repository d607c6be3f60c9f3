"""The compiler: vectorized exploration of a FlatModel into an ExplicitModel.

``build_model(flat)`` compiles every expression once into numpy code
(:mod:`~posgmc.compiler.compile_expr`), packs states into integer keys
(:mod:`~posgmc.compiler.state_space`), explores breadth-first a batch of states at a time numbering
states exactly as Storm does (:mod:`~posgmc.compiler.explore`), and freezes the result
(:mod:`~posgmc.compiler.assemble`). State, choice and transition counts equal Storm's.

State numbers, the order of choices within a state and every row equal those of Storm's sparse
builder (checked against stormpy 2.0 in ``tests/compiler/test_storm_order.py``). Where posgmc
deliberately differs from Storm:

* an assignment outside its variable's range is a :class:`~posgmc.errors.BuildError` (PRISM's
  behaviour; Storm without exploration checks writes a wrapped-around value);
* in games, unowned choices next to owned ones are accepted (PRISM-games' rule; Storm rejects any
  enabled unowned choice);
* several initial states (``init ... endinit``) are numbered in lexicographic order of their
  valuations (Storm: in the order its SMT solver enumerates them);
* a merged DTMC choice is labelled with its action only when all merged choices share it.

Cost: array operations per batch of states, so the time is dominated by the number of
transitions; but each batch has a fixed overhead per command, which dominates for models whose
breadth-first frontier stays tiny for very many levels (e.g. a single counter to 10^5).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from posgmc.compiler.assemble import assemble
from posgmc.compiler.exact_explore import exact_model, explore_exact
from posgmc.compiler.explore import explore
from posgmc.compiler.options import BuildOptions, BuildResult, ProgressMode, ValidationMode
from posgmc.compiler.program import compile_program
from posgmc.semantics.flat import FlatModel

__all__ = ["BuildOptions", "BuildResult", "ProgressMode", "ValidationMode", "build_model"]


def build_model(
    flat: FlatModel,
    *,
    options: BuildOptions = BuildOptions(),  # noqa: B008
    on_states: Callable[[int], None] | None = None,
) -> BuildResult:
    """Build the explicit model of an instantiated model.

    Args:
        flat: the checked, instantiated model (``posgmc.semantics.stages.instantiate``).
        options: state limit, deadlock handling, progress, observations, validation.
        on_states: called with the number of states found so far after every batch of the
            exploration (``api.build`` starts loading the engines' compiled kernels once a model
            is large enough to use them).

    Returns:
        The model, the wall-clock seconds the build took, and warnings (fixed deadlocks).

    Raises:
        BuildError: the model is invalid in a way exploration shows: probabilities of a command
            not summing to 1 or negative, an assignment out of its variable's range, two
            synchronising modules assigning one variable, a failing expression (``mod`` by 0,
            ...), a deadlock with ``fix_deadlocks=False``, a game state with choices of two
            players or with several unowned choices, two states with one observation but
            different actions, no initial state.
        LimitError: more states than ``options.state_limit``, or an ``init`` predicate with too
            many candidate valuations.
        UnsupportedError: a double-valued observable.
    """
    start = time.perf_counter()
    # x/0 and the like are IEEE values in PRISM, not warnings
    with np.errstate(all="ignore"):
        program = compile_program(flat)
        if options.exact:
            exploration, exact = explore_exact(program, options)
            layout = (exploration.choice_counts.tolist(), exploration.indptr.tolist(),
                      exploration.targets.tolist())
            model, warnings = assemble(program, exploration, options)
            model = exact_model(model, program, *layout, exact)
        else:
            exploration = explore(program, options, on_states)
            model, warnings = assemble(program, exploration, options)
    return BuildResult(model=model, seconds=time.perf_counter() - start, warnings=tuple(warnings))
