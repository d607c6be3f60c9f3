"""Storm's belief-space bounds for one POMDP, as JSON on stdout (run by the reference
interpreter, ``$POSGMC_REFERENCE_PYTHON``, from synthesis_bench.py --bracket).

Usage:
    python _storm_belief.py MODEL PROPERTY SECONDS

Prints {"states", "discretisation": [{"resolution", "value", "completed", "seconds"}, ...],
"unfolding": {"value", "completed", "seconds"}}: the Freudenthal discretisation
(``stormpy.pomdp.verify_with_belief_discretization``, an upper bound for max, a lower bound for
min) at resolution 2, then 4, 8, ... while the next one is expected to fit in SECONDS (each takes
longer than the last: it is started only when the time used so far is below half of SECONDS), and
the belief unfolding (``verify_with_belief_unfolding`` with ``max_exploration_time`` SECONDS, whole
seconds, at least 1: a
lower bound for max, exact when completed).
"""

from __future__ import annotations

import json
import sys
import time

MAX_RESOLUTION = 1024
"""The finest resolution tried (posgmc's grid goes as far: belief_grid.RESOLUTIONS)."""


def main() -> None:
    import stormpy
    import stormpy.pomdp

    path, text, seconds = sys.argv[1], sys.argv[2], float(sys.argv[3])
    with open(path) as f:
        drn = any(line.startswith("@type:") for line in f)
    if drn:  # Storm's explicit format (PAYNT's exported sketches)
        props = stormpy.parse_properties(text)
        drn_options = stormpy.io.DirectEncodingParserOptions()
        drn_options.build_choice_labeling = True
        model = stormpy.build_model_from_drn(path, options=drn_options)
    else:
        program = stormpy.parse_prism_program(path)
        props = stormpy.parse_properties(text, program)
        options = stormpy.BuilderOptions([p.get_raw_formula() for p in props] * 2)
        options.set_build_all_labels()
        options.set_build_all_reward_models()
        options.set_build_choice_labels()
        model = stormpy.build_model(program, options=options)
    out: dict[str, object] = {"states": model.nr_states, "discretisation": []}
    used = 0.0
    resolution = 2
    while resolution == 2 or (used < seconds / 2 and resolution <= MAX_RESOLUTION):
        t0 = time.perf_counter()
        r = stormpy.pomdp.verify_with_belief_discretization(model, props[0], resolution)
        dt = time.perf_counter() - t0
        used += dt
        out["discretisation"].append(  # type: ignore[union-attr]
            {"resolution": resolution, "value": r.value, "completed": r.completed_exploration,
             "seconds": dt})
        print(json.dumps(out), flush=True)  # what is known so far, should the caller stop us
        resolution *= 2
    t0 = time.perf_counter()
    r = stormpy.pomdp.verify_with_belief_unfolding(model, props[0],
                                                   max_exploration_time=max(1, int(seconds)))
    out["unfolding"] = {"value": r.value, "completed": r.completed_exploration,
                        "seconds": time.perf_counter() - t0}
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
