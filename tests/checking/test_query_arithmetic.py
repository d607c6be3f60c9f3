"""Bounds that hold through arithmetic, and thresholds decided only on proof.

Each case guards a way to go wrong: a straddling threshold decided by the midpoint and reported
sound, division by 0 printed as a sound 1.797e308, functions of queries dropping the engine's
interval, and property expressions failing silently where the model compiler reports an error.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from posgmc import api
from posgmc.cli import main

ROOT = Path(__file__).resolve().parents[2]

# x=0 loops with 1/2 and leaves to x=1 or x=2 with 1/4 each: P(F x=1) = 1/2 exactly (by hand),
# reached only in the limit, so interval iteration never separates it from 0.5
HALF = """
dtmc
module m
  x : [0..2] init 0;
  [] x=0 -> 0.25:(x'=1) + 0.25:(x'=2) + 0.5:(x'=0);
  [] x>0 -> true;
endmodule
rewards "steps" x=0 : 1; endrewards
"""


def one(prop: str, text: str = HALF):  # type: ignore[no-untyped-def]
    report = api.check(api.load(text=text), properties=[prop])
    outcome = report.outcomes[0]
    return outcome if not isinstance(outcome, tuple) else outcome[1]


def test_threshold_at_the_exact_value_is_decided_exactly() -> None:
    # refinement cannot separate 0.5 from the interval; the rational solve decides it (1/2 > 1/2)
    r = one("P>0.5 [ F x=1 ]")
    assert r.value is False and r.sound and "rational" in r.method
    assert one("P>=0.5 [ F x=1 ]").value is True


def test_comparison_inside_the_interval_is_unknown_not_guessed() -> None:
    r = one("P=? [ F x=1 ] > 0.5")
    assert r.value is None and r.to_json()["value"] is None
    assert one("P=? [ F x=1 ] > 0.49").value is True


def test_rover_threshold_between_bounds_and_exact_value() -> None:
    # the exact value is 0.9876561794 (F<=10^20 reaches the fixpoint, tests/engines); the
    # midpoint 0.98765635 would wrongly make ">= 0.98765634" true
    session = api.load(ROOT / "models" / "rover.smg")
    for prop in ('<<rover>> Pmax=? [F "goal"] >= 0.98765634', '<<rover>> P>=0.98765634 [F "goal"]'):
        r = api.check(session, properties=[prop]).results[0]
        assert r.value is False


def test_cli_exit_code_for_unknown_and_false() -> None:
    runner = CliRunner()
    model = ROOT / "models" / "rover.smg"
    unknown = runner.invoke(main, ["check", "-", "--prop", "P=? [ F x=1 ] > 0.5"], input=HALF)
    assert unknown.exit_code == 1 and ": unknown" in unknown.output
    false = runner.invoke(main, ["check", str(model), "--prop", '<<rover>> P>=0.99 [F "goal"]'])
    assert false.exit_code == 1 and ": false" in false.output


def test_division_by_zero_is_infinite_and_zero_by_zero_undefined() -> None:
    r = one("P=? [ F x=1 ] / 0")
    assert r.value == math.inf and r.lower == math.inf and r.sound
    r = one("Pmin=? [ F x=2 & x=1 ] / Pmin=? [ F x=2 & x=1 ]",
            HALF.replace("dtmc", "mdp"))
    assert math.isnan(r.value) and not r.sound


def test_division_by_an_interval_around_zero_has_no_finite_bound() -> None:
    r = one("P=? [ F x=1 ] / (P=? [ F x=1 ] - P=? [ F x=1 ])")
    assert not (r.sound and math.isfinite(r.lower) and math.isfinite(r.upper))
    if r.sound:
        assert r.lower <= r.value <= r.upper


def test_functions_keep_the_engine_interval() -> None:
    q = one("P=? [ F x=1 ]")
    assert q.lower < q.upper  # the engine's interval is not a point here
    r = one("min(P=? [ F x=1 ], 1)")
    assert (r.lower, r.upper) == (q.lower, q.upper) and r.lower <= 0.5 <= r.upper
    r = one("P=? [ F x=1 ] >= 0.4 ? P=? [ F x=1 ] : 2")
    assert r.lower <= 0.5 <= r.upper


@pytest.mark.parametrize(
    ("prop", "words"),
    [
        ('floor(R{"steps"}=? [ F x=3 ])', "floor() of a non-finite value in state (x=0)"),
        ("P=? [ F x=1 ] + mod(3, 0)", "mod() by a non-positive divisor in state (x=0)"),
        ("pow(2, x-1)", "negative exponent in pow() of two ints in state (x=0)"),
        ("mod(3, x)", "mod() by a non-positive divisor in state (x=0)"),
        ("floor(1/x)", "floor() of a non-finite value in state (x=0)"),
    ],
)
def test_one_rule_for_failing_operators_with_the_state(prop: str, words: str) -> None:
    e = one(prop)
    assert isinstance(e, Exception) and words in e.message and e.span is not None


def test_short_circuit_keeps_guarded_operands_from_failing() -> None:
    assert one("x > 0 & mod(3, x) = 0").value is False
    assert one("x = 0 ? 1 : floor(1/x)").value == 1.0


def test_huge_double_constant_in_a_guard() -> None:
    # pow(2.0, 2000) is Infinity as a double (PRISM): the guard holds, no internal error
    text = HALF.replace("[] x=0 ->", "[] x < pow(2.0, 2000) & x=0 ->")
    assert one("P=? [ F x=1 ]", text).lower <= 0.5
