"""Time Storm on one model and one property: the Storm side of posgmc's model-checking benchmark.

As a script it runs in the reference environment (stormpy 2.0.0 + paynt 0.5.0), never in posgmc's:

    $POSGMC_REFERENCE_PYTHON benchmarks/storm_check.py --model MODEL --const N=32 \
        --prop 'Pmax=? [ F "goal" ]' [--sound] [--full-model]

and prints exactly one JSON line on standard output:

    {"states": ..., "choices": ..., "transitions": ..., "build_seconds": ..., "check_seconds": ...,
     "value": ..., "peak_rss_mb": ...}

``build_seconds`` covers parsing the PRISM file and the property, instantiating the constants and
building the sparse model; ``check_seconds`` covers the model-checking call only (both with
``time.perf_counter``). ``value`` is the value at the (first) initial state: a float, a bool for a
threshold property, or ``"inf"``/``"-inf"``. ``peak_rss_mb`` is the peak resident set size of the
process (``getrusage(RUSAGE_SELF).ru_maxrss``, KiB on Linux, divided by 1024). Games (``smg``) are
checked with ``payntbind.synthesis.model_check_smg`` because stormpy 2.0.0's ``model_checking``
returns None on them; POMDPs are checked fully observably. On failure the line is
``{"error": "..."}`` and the exit code is 1.

Storm writes its log (warnings, errors) to standard output; the script moves that to standard error
so that standard output carries only the JSON line.

From posgmc's own Python (which has no stormpy), :func:`run_storm_check` runs this script in the
reference environment and returns the parsed line.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any


def plain(value: Any) -> Any:
    """Turn a Storm value into a JSON-friendly one.

    Args:
        value: A float, bool or number-like value.

    Returns:
        bool stays bool; floats stay floats; infinities become ``"inf"``/``"-inf"``, NaN ``"nan"``.
    """
    if isinstance(value, bool):
        return value
    number = float(value)
    if math.isnan(number):
        return "nan"
    if math.isinf(number):
        return "inf" if number > 0 else "-inf"
    return number


def check(
    model_file: Path, *, constants: str, prop: str, sound: bool, full_model: bool
) -> dict[str, Any]:
    """Build a PRISM model with Storm and check one property at its initial state.

    Args:
        model_file: PRISM-language model (dtmc, mdp, pomdp or smg).
        constants: Storm constant definitions such as ``"N=32"`` ('' for none).
        prop: The property, as Storm reads it (numeric coalitions are 0-based in Storm).
        sound: Use ``stormpy.environments.sound()`` instead of Storm's built-in defaults
            (``stormpy.Environment()``: value iteration, relative precision 1e-6, not sound).
        full_model: Build the whole model; by default Storm (like its command line) makes the
            property's target states absorbing while building, which may drop transitions.

    Returns:
        The record printed by the script (see the module docstring).

    Raises:
        RuntimeError: Storm failed to parse, build or check (Storm's message), or returned
            no result.
    """
    import payntbind
    import stormpy
    import stormpy.environments

    started = time.perf_counter()
    program = stormpy.parse_prism_program(str(model_file))
    if constants:
        program, _ = stormpy.instantiate_constants(program, constants)
    properties = stormpy.parse_properties(prop, program)
    if len(properties) != 1:
        raise RuntimeError(f"expected one property, Storm read {len(properties)}")
    # With one formula Storm derives absorbing "terminal" states from it; with two it does not.
    options = stormpy.BuilderOptions(properties * 2 if full_model else properties)
    # Storm refuses observation valuations when an observable is named like a formula.
    options.set_build_observation_valuations(False)
    model = stormpy.build_model(program, options=options)
    build_seconds = time.perf_counter() - started

    kind = str(model.model_type).rsplit(".", 1)[-1]
    env = stormpy.environments.sound() if sound else stormpy.Environment()
    started = time.perf_counter()
    cpu_started = time.process_time()
    if kind == "SMG":
        formula = properties[0].get_raw_formula()
        result = payntbind.synthesis.model_check_smg(model, formula, False, False, env)
    else:
        partial = kind == "POMDP"
        result = stormpy.model_checking(
            model, properties[0], force_fully_observable=partial, environment=env
        )
    check_seconds = time.perf_counter() - started
    check_cpu_seconds = time.process_time() - cpu_started
    if result is None:
        raise RuntimeError("Storm returned no result (formula unsupported for this model type)")
    initial = model.initial_states[0]
    value = bool(result[initial]) if result.is_qualitative() else plain(result.get_value(initial))
    return {
        "states": model.nr_states,
        "choices": model.nr_choices,
        "transitions": model.nr_transitions,
        "build_seconds": build_seconds,
        "check_seconds": check_seconds,
        "check_cpu_seconds": check_cpu_seconds,
        "value": value,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def run_storm_check(
    model_file: Path,
    *,
    constants: str,
    prop: str,
    sound: bool,
    full_model: bool = False,
    python: Path,
    timeout: float | None = None,
) -> dict[str, Any]:
    """Run this script in the reference environment and return its JSON line (needs no stormpy).

    Args:
        model_file: PRISM-language model.
        constants: Storm constant definitions such as ``"N=32"`` ('' for none).
        prop: The property, as Storm reads it.
        sound: Use Storm's sound environment.
        full_model: Build without Storm's property-based absorbing states.
        python: Interpreter of the reference environment (``$POSGMC_REFERENCE_PYTHON``).
        timeout: Seconds before the run is stopped (None: no limit).

    Returns:
        The parsed record (keys as in the module docstring, or ``"error"``).

    Raises:
        subprocess.TimeoutExpired: The run took longer than ``timeout``.
        RuntimeError: The script printed no JSON line.
    """
    script = str(Path(__file__).resolve())
    command = [str(python), script, "--model", str(model_file), "--prop", prop]
    if constants:
        command += ["--const", constants]
    if sound:
        command.append("--sound")
    if full_model:
        command.append("--full-model")
    finished = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    lines = [line for line in finished.stdout.splitlines() if line.startswith("{")]
    if not lines:
        raise RuntimeError(
            f"storm_check printed nothing (exit code {finished.returncode}): "
            f"{finished.stderr[-500:]}"
        )
    record: dict[str, Any] = json.loads(lines[-1])
    return record


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point.

    Args:
        argv: Arguments (default: sys.argv[1:]).

    Returns:
        Exit code: 0 on success, 1 when Storm failed.
    """
    parser = argparse.ArgumentParser(
        description="Build a model and check one property with Storm; print one JSON line."
    )
    parser.add_argument("--model", type=Path, required=True, help="PRISM-language model file")
    parser.add_argument(
        "--const", action="append", default=[], help="constant definitions, e.g. N=32 (repeatable)"
    )
    parser.add_argument("--prop", required=True, help="the property, as Storm reads it")
    parser.add_argument("--sound", action="store_true", help="use stormpy.environments.sound()")
    parser.add_argument(
        "--full-model", action="store_true", help="no property-based absorbing states when building"
    )
    args = parser.parse_args(argv)

    # Storm's C++ log goes to file descriptor 1; keep it for the JSON line only.
    sys.stdout.flush()
    json_out = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    try:
        record = check(
            args.model,
            constants=",".join(args.const),
            prop=args.prop,
            sound=args.sound,
            full_model=args.full_model,
        )
        code = 0
    except Exception as error:  # Storm raises RuntimeError subclasses; report any failure as JSON
        record = {"error": " ".join(str(error).split()) or type(error).__name__}
        code = 1
    sys.stdout.flush()
    json_out.write(json.dumps(record, allow_nan=False) + "\n")
    json_out.flush()
    return code


if __name__ == "__main__":
    sys.exit(main())
