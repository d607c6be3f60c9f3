"""The long fuzz run: mutate the corpus many times and apply the oracle.

``--surface models`` (the default) uses the corpus, mutations and oracle of
``tests/fuzz/mutate.py``: each input is one random file of the corpus (models, or properties
with their model) after 1-3 mutations. ``--surface strategies``, ``options`` and ``api`` use
``tests/fuzz/surface.py``: mutated strategy files checked against their model, command lines with
hostile option values, and library calls with a hostile argument. The default test run does a
bounded number of each. Input ``i`` is drawn from ``random.Random(seed * 1000003 + i)``, so that
any failure can be replayed with ``--replay I`` (with a traceback).

Usage::

    python benchmarks/fuzz.py [--surface models|strategies|options|api] --count 100000 --seed 1
        [--seconds 3600]

Prints progress lines and a summary: inputs tried, lint-clean, built, and every distinct failure
(with the index that reproduces it). Exit 1 when something failed.
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.fuzz import surface  # noqa: E402 - after the path is set
from tests.fuzz.mutate import (  # noqa: E402 - after the path is set
    OracleFailure,
    check_model_text,
    check_properties_text,
    corpus,
    mutate,
    scratch,
)


def one_surface(kind: str, i: int, seed: int, tmp: Path) -> str:
    """Run input ``i`` of the strategy, option or API fuzzing; its outcome class."""
    rng = random.Random(seed * 1_000_003 + i)
    if kind == "strategies":
        model, text = surface.strategy_text(rng)
        return surface.check_strategy_text(model, text, tmp)
    if kind == "options":
        return surface.check_option_arguments(surface.option_arguments(rng), tmp)
    name, arg, value = surface.api_call(rng, tmp)
    return f"{name}: " + surface.check_api_call(name, arg, value, tmp)


def one(i: int, seed: int, models: list[Path], pairs: list[tuple[Path, Path]], tmp: Path) -> str:
    """Run input ``i``; its outcome class ("clean", "built", "refused", "properties")."""
    rng = random.Random(seed * 1_000_003 + i)
    if pairs and rng.random() < 0.3:
        model, props = rng.choice(pairs)
        check_properties_text(
            model, mutate(props.read_text(encoding="utf-8"), rng, rng.randint(1, 3)), tmp
        )
        return "properties"
    path = rng.choice(models)
    outcome = check_model_text(
        mutate(path.read_text(encoding="utf-8"), rng, rng.randint(1, 3)), path.suffix, tmp
    )
    return "built" if outcome.built else ("lint-clean" if outcome.lint_clean else "refused")


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--surface", choices=["models", "strategies", "options", "api"],
                        default="models")
    parser.add_argument("--count", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=float("inf"))
    parser.add_argument(
        "--replay", type=int, default=None, help="run only input I, with a traceback"
    )
    args = parser.parse_args()
    models, pairs = corpus()
    if args.surface == "models":
        print(f"corpus: {len(models)} models, {len(pairs)} properties files", flush=True)

    def run(i: int, tmp: Path) -> str:
        if args.surface == "models":
            return one(i, args.seed, models, pairs, tmp)
        return one_surface(args.surface, i, args.seed, tmp)

    with scratch() as tmp_name:
        tmp = Path(tmp_name)
        if args.replay is not None:
            print(run(args.replay, tmp))
            return 0
        start = time.monotonic()
        counts: Counter[str] = Counter()
        failures: dict[str, int] = {}
        done = 0
        for i in range(args.count):
            if time.monotonic() - start > args.seconds:
                break
            try:
                counts[run(i, tmp)] += 1
            except OracleFailure as failure:
                key = str(failure).splitlines()[0][:160]
                if key not in failures:
                    failures[key] = i
                    print(f"FAIL at input {i}: {key}", flush=True)
                counts["failed"] += 1
            done += 1
            if done % (5000 if args.surface == "models" else 500) == 0:
                rate = done / (time.monotonic() - start)
                print(f"{done} inputs, {rate:.0f}/s, {dict(counts)}", flush=True)
    elapsed = time.monotonic() - start
    print(f"\n{args.surface}, seed {args.seed}: {done} inputs in {elapsed:.0f} s; outcomes "
          f"{dict(counts)}")
    print(f"{len(failures)} distinct failures")
    for key, i in failures.items():
        print(f"  input {i}: {key}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
