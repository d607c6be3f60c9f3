"""Every ``// RESULT:`` line of PRISM-games' test files under the vendored benchmarks.

The expected values are PRISM-games' own (its regression tests, copied with the models; see
tests/data/benchmarks/README.md), written above each property: a number, ``19/15``, ``true``,
``Infinity`` or ``Error:co-safe``; ``RESULT (k=3): v`` applies to one constant value only.
This covers what Storm cannot answer (co-safe LTL, ``F0``/``Fc``, ``I=k``, ``C<=k``, ``G<=k``,
``<<*>>``) as well as what it can.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction
from pathlib import Path

import pytest

from posgmc import api
from posgmc.errors import PosgmcError, UnsupportedError
from posgmc.semantics.constants import expand_sweep, parse_const_assignments

# (model, property file, constants as given to PRISM-games in the .args files or the README)
CASES = [
    ("smg/smg_example/smg_example.prism", "smg/smg_example/smg_example.prism.props", "k=0:5"),
    ("smg/smg_example/smg_example.prism", "smg/smg_example/smg_example.prism.cosafe.props", ""),
    ("smg/robot/robot.prism", "smg/robot/robot.prism.cosafe.props", ""),
    ("smg/robot/robot.prism", "smg/robot/robot.prism.rewards.cosafe.props", ""),
    ("smg/coins/coins.prism", "smg/coins/coins.prism.props", ""),
    ("smg/game/game.prism", "smg/game/game.prism.props", ""),
    ("smg/game/game.prism", "smg/game/game.prism.rewards.props", ""),
    ("smg/investor/investor.prism", "smg/investor/investor.prism.props", "vmax=5,vinit=2"),
]

KNOWN_GAPS: set[tuple[str, int]] = set()  # none left: F0 on games landed with the engines

# PRISM-games prints 6 significant digits in some RESULT lines (investor: 2.365893)
TOLERANCE = 1e-6


def _expected_for(prop, constants: dict[str, str]):  # type: ignore[no-untyped-def]
    for exp in prop.expected:
        if all(constants.get(k) == v for k, v in exp.constants):
            return exp.text
    return None


def _matches(text: str, value: float | bool) -> bool:
    t = text.strip()
    if t.lower() in ("true", "false"):
        return value is (t.lower() == "true")
    if t.lower() in ("infinity", "inf"):
        return isinstance(value, float) and math.isinf(value) and value > 0
    expected = float(Fraction(t))
    return abs(float(value) - expected) <= TOLERANCE * max(1.0, abs(expected))


def _cases():  # type: ignore[no-untyped-def]
    for model, props, consts in CASES:
        yield pytest.param(model, props, consts, id=Path(props).name)


@pytest.mark.parametrize(("model", "props", "consts"), list(_cases()))
def test_prism_games_results(benchmarks: Path, model: str, props: str, consts: str) -> None:
    settings = expand_sweep(parse_const_assignments(consts)) if consts else [{}]
    checked = 0
    for setting in settings:
        texts = {n: str(getattr(v, "value", v)) for n, v in setting.items()}
        session = api.load(benchmarks / model, constants=setting)
        built = api.build(session, allow_extra_constants=True)
        for prop, outcome in api.iter_check(
            session, property_files=[benchmarks / props], built=built
        ):
            expected = _expected_for(prop, texts)
            if expected is None:
                continue
            checked += 1
            where = f"{props}:{prop.span.line} {prop.text} ({texts})"
            if expected.startswith("Error"):
                assert isinstance(outcome, PosgmcError), (
                    f"{where}: expected {expected}, got {outcome}"
                )
                if expected == "Error:co-safe":
                    assert isinstance(outcome, UnsupportedError)
                    assert "co-safe" in outcome.message, where
                continue
            if (props, prop.span.line) in KNOWN_GAPS:
                assert isinstance(outcome, UnsupportedError) and "F0" in outcome.message, where
                continue
            assert not isinstance(outcome, PosgmcError), f"{where}: {outcome.render()}"
            assert _matches(expected, outcome.value), (
                f"{where}: expected {expected}, got {outcome.value}"
            )
            if outcome.lower is not None and not math.isinf(outcome.value):
                # the proven bounds enclose PRISM-games' value
                exp = float(Fraction(expected))
                assert outcome.lower - TOLERANCE <= exp <= outcome.upper + TOLERANCE, where
    assert checked > 0


@pytest.mark.parametrize("model,props,consts", CASES)
def test_posgmc_test_passes_prism_games_result_lines(benchmarks: Path, model: str, props: str,
                                                    consts: str) -> None:
    """The same files through ``posgmc test`` (issue #10: the CI command users run on theirs)."""
    from click.testing import CliRunner

    from posgmc.cli import main

    shared = benchmarks
    args = ["test", str(shared / model), str(shared / props)] + (
        ["--const", consts] if consts else []
    )
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    summary = r.output.strip().splitlines()[-1]
    assert summary.endswith(" 0 failed") and not summary.startswith("0 passed"), summary


def test_every_prism_games_result_file_is_checked(benchmarks: Path) -> None:
    """Every upstream property file under smg/ with a ``// RESULT`` line is in CASES (files
    marked DERIVED are ours and hold no upstream expectations)."""
    found = set()
    for props in (benchmarks / "smg").rglob("*.props"):
        text = props.read_text()
        if re.search(r"^\s*//\s*RESULT", text, re.M) and "DERIVED" not in text:
            found.add(str(props.relative_to(benchmarks)))
    assert found == {props for _, props, _ in CASES}
