"""Grade posgmc's multi(...) answers against PRISM's own regression RESULT lines.

Usage::

    python benchmarks/prism_multi.py CHECKOUT [--verbose]

``CHECKOUT`` is a checkout of PRISM (github.com/prismmodelchecker/prism), or its ``prism-tests``
folder. Every properties file under ``prism-tests`` that holds ``multi(`` is read; each
``multi(...)`` property with a ``// RESULT:`` line above it is checked on the model beside it
(``foo.nm`` for ``foo.nm.props``) and graded as ``posgmc test`` grades (numbers within 1e-5
relative, Pareto fronts vertex by vertex). Only the multi lines are taken from each file (some
files also hold properties of other features), each with its RESULT line. The files are read
from the checkout, never copied into this repository.

Prints one line per failure (all lines with ``--verbose``) and a summary:
``N multi(...) lines: P passed, F failed, E errors; T s``, then how many numerical answers carry
a proven bound from the LP's strategy re-checked by the sound engines, and how many ``true``
achievability verdicts are proven that way.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path


def multi_lines(props: Path) -> list[tuple[str, str, int]]:
    """``(RESULT text, property text, line number)`` of each multi(...) property with a RESULT."""
    out = []
    result: str | None = None
    for number, line in enumerate(props.read_text().splitlines(), start=1):
        stripped = line.strip()
        m = re.match(r"//\s*RESULT\s*:\s*(.*)$", stripped)
        if m:
            result = m.group(1).strip()
            continue
        if not stripped or stripped.startswith("//"):
            continue
        if re.match(r"multi\s*\(", stripped) and result is not None:
            out.append((result, stripped, number))
        result = None
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout", type=Path)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args(argv)

    from posgmc import api
    from posgmc.checking.expected import grade
    from posgmc.errors import PosgmcError
    from posgmc.syntax.ast import ExpectedResult

    root = args.checkout
    tests = root / "prism-tests" if (root / "prism-tests").is_dir() else root
    files = sorted(p for p in tests.rglob("*.props") if re.search(r"multi\s*\(", p.read_text()))
    passed = failed = errors = 0
    numerical = certified = close = achievable = proven = 0
    start = time.perf_counter()
    for props in files:
        model = props.with_suffix("")
        lines = multi_lines(props)
        if not lines or not model.exists():
            continue
        session = api.load(str(model))
        built = api.build(session)
        for result, text, number in lines:
            where = f"{props.relative_to(tests)}:{number}"
            with tempfile.NamedTemporaryFile("w", suffix=".props", delete=False) as tmp:
                tmp.write(text + "\n")
            try:
                ((_, outcome),) = list(
                    api.iter_check(session, property_files=[tmp.name], built=built)
                )
            except PosgmcError as e:
                outcome = e
            finally:
                Path(tmp.name).unlink()
            verdict = grade(ExpectedResult(result), outcome)
            multi = getattr(outcome, "multi", None)
            if multi is not None and multi.kind.value == "numerical" and multi.value == multi.value:
                numerical += 1
                if multi.certified == multi.certified:
                    certified += 1
                    close += abs(multi.certified - multi.value) <= 1e-5 * max(1.0, abs(multi.value))
                elif args.verbose:
                    print(f"      not certified: {where}")
            if multi is not None and multi.kind.value == "achievability" and multi.achievable:
                achievable += 1
                proven += bool(multi.proven)
            if isinstance(outcome, PosgmcError) and not result.lower().startswith("error"):
                errors += 1
                print(f"ERROR {where}: {text}\n      {outcome.message}")
            elif verdict.passed:
                passed += 1
                if args.verbose:
                    print(f"PASS  {where}: {text} = {verdict.actual}")
            else:
                failed += 1
                print(
                    f"FAIL  {where}: {text}\n      expected {verdict.expected}, got "
                    f"{verdict.actual}"
                )
    total = passed + failed + errors
    seconds = time.perf_counter() - start
    print(
        f"{total} multi(...) lines: {passed} passed, {failed} failed, {errors} errors; "
        f"{seconds:.1f} s"
    )
    print(f"numerical answers with a proven bound from the LP's re-checked strategy: {certified} "
          f"of {numerical} ({close} within 1e-5 relative of the LP value); achievable verdicts "
          f"proven: {proven} of {achievable}")
    return 0 if passed == total else 1


if __name__ == "__main__":
    sys.exit(main())
