"""Exact mode (PRISM's ``-exact``, issue #14): built and solved in rational arithmetic.

Before this mode existed, ``--method exact`` solved the floating-point model exactly, so a guard
that holds only in doubles and a probability that a double cannot hold gave wrong values labelled
"exact" (PRISM's ``functionality/verify/exact/exact-eval-4`` and ``exact-literal`` tests, and
``bugfixes/exact-pow``). The models here are our own versions of those situations; every expected
value is derived by hand next to it.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.cli import main
from posgmc.compiler import BuildOptions
from posgmc.errors import BuildError, PosgmcError

# (0+1)/3 = 1/3 is not the decimal 0.3333333333333333333333 over the rationals, but both round to
# the same double: exact mode goes to s=2 (P(F s=1) = 0), floating point to s=1 (P = 1/2)
THIRD = """
dtmc
module m
  s : [0..2] init 0;
  [] s=0 -> 1/2:(s'=((s+1)/3 = 0.3333333333333333333333 ? 1 : 2)) + 1/2:(s'=2);
  [] s>0 -> true;
endmodule
label "one" = s=1;
"""

# a probability no double holds: exact P(F s=1) = 1/10 + 10^-25 > 1/10
LITERAL = """
dtmc
const double p = 0.1000000000000000000000001;
module m
  s : [0..2] init 0;
  [] s=0 -> p:(s'=1) + (1-p):(s'=2);
  [] s>0 -> true;
endmodule
"""

# an mdp: in s=0 action a reaches goal with 1/3 and loops with 1/3; action b reaches it with 1/7
# and fails otherwise. Pmax = max(1/3 / (1 - 1/3), 1/7) = 1/2; Pmin = 1/7 (a: 1/2, b: 1/7).
MDP = """
mdp
module m
  s : [0..2] init 0;
  [a] s=0 -> 1/3:(s'=1) + 1/3:(s'=0) + 1/3:(s'=2);
  [b] s=0 -> 1/7:(s'=1) + 6/7:(s'=2);
  [] s>0 -> true;
endmodule
label "goal" = s=1;
"""


def exact_results(text: str, *props: str, constants: dict[str, object] | None = None):  # type: ignore[no-untyped-def]
    report = api.check(
        api.load(text=text, constants=constants or {}),
        properties=list(props),
        options=CheckOptions(exact=True),
    )
    return [o if not isinstance(o, tuple) else o[1] for o in report.outcomes]


def test_a_guard_that_holds_only_in_doubles_is_false_in_exact_mode() -> None:
    exact_model = api.build(api.load(text=THIRD), options=BuildOptions(exact=True)).model
    float_model = api.build(api.load(text=THIRD)).model
    # sizes first: s=1 is unreachable over the rationals
    assert (exact_model.num_states, float_model.num_states) == (2, 3)
    (value, holds) = exact_results(THIRD, 'P=? [ F "one" ]', "P>0 [ F s=1 ]")
    assert value.exact == 0 and value.method == "exact (rational)"
    assert holds.value is False


def test_a_literal_beyond_double_precision_is_kept_exactly() -> None:
    value, above, equal = exact_results(
        LITERAL, "P=? [ F s=1 ]", "P>1/10 [ F s=1 ]", "P<=1/10 [ F s=1 ]"
    )
    assert value.exact == Fraction(1, 10) + Fraction(1, 10**25)
    assert value.lower <= 0.1 <= value.upper  # the doubles around the fraction
    assert above.value is True and equal.value is False
    # the JSON form carries the fraction as text
    assert value.to_json()["exact"] == f"{value.exact.numerator}/{value.exact.denominator}"


def test_mdp_min_and_max_and_step_bounds_are_exact() -> None:
    pmax, pmin, bounded, nxt = exact_results(
        MDP, 'Pmax=? [ F "goal" ]', 'Pmin=? [ F "goal" ]', 'Pmax=? [ F<=2 "goal" ]',
        'Pmin=? [ X "goal" ]'
    )
    assert (pmax.exact, pmin.exact) == (Fraction(1, 2), Fraction(1, 7))
    # two steps with a: 1/3 + 1/3 * 1/3 = 4/9 > 1/7
    assert bounded.exact == Fraction(4, 9)
    assert nxt.exact == Fraction(1, 7)


def test_ltl_is_exact_through_the_automaton_product() -> None:
    """G F and F G (not co-safe): s=1 and s=2 absorb, so G F "goal" = F "goal" and
    F G s=2 = F s=2: Pmax/Pmin of F "goal" above (1/2, 1/7), of failing 1 - those (6/7, 1/2)."""
    gf_max, gf_min, fg_max, fg_min = exact_results(
        MDP, 'Pmax=? [ G F "goal" ]', 'Pmin=? [ G F "goal" ]', "Pmax=? [ F G s=2 ]",
        "Pmin=? [ F G s=2 ]"
    )
    assert (gf_max.exact, gf_min.exact) == (Fraction(1, 2), Fraction(1, 7))
    assert (fg_max.exact, fg_min.exact) == (Fraction(6, 7), Fraction(1, 2))
    assert gf_max.method == "exact (rational)"
    (literal,) = exact_results(LITERAL, "P=? [ G F s=1 ]")
    assert literal.exact == Fraction(1, 10) + Fraction(1, 10**25)


def test_cumulative_rewards_are_exact() -> None:
    """Reward 1 per step spent in s=0: the first step always pays; a second one only if the
    first step stayed in s=0, which [a] does with 1/3 and [b] never: Rmax = 4/3, Rmin = 1."""
    text = MDP + "rewards s=0 : 1; endrewards\n"
    rmax, rmin, above = exact_results(
        text, "Rmax=? [ C<=2 ]", "Rmin=? [ C<=2 ]", "R>=4/3 [ C<=2 ]"
    )
    assert (rmax.exact, rmin.exact) == (Fraction(4, 3), Fraction(1))
    assert above.value is False  # R>=4/3 on an mdp: for all schedulers (the minimum is 1)


def test_a_fractional_power_is_a_positioned_error_even_when_the_root_is_rational() -> None:
    text = (
        "dtmc\nmodule m\n  s : [0..2] init 0;\n"
        "  [] s=0 -> pow(1/4,1/2):(s'=1) + 1-pow(1/4,1/2):(s'=2);\nendmodule\n"
    )
    with pytest.raises(BuildError) as info:
        api.build(api.load(text=text), options=BuildOptions(exact=True))
    assert "fractional exponent 1/2" in info.value.message
    assert (info.value.span.line, info.value.span.column) == (4, 13)
    # the same model is fine in floating point (pow(1/4, 1/2) = 0.5)
    assert api.build(api.load(text=text)).model.num_states == 3


def test_division_by_zero_has_no_exact_value() -> None:
    text = (
        "dtmc\nmodule m\n  s : [0..1] init 0;\n"
        "  [] s=0 -> 1/(s*2):(s'=1) + 1-1/(s*2):(s'=0);\nendmodule\n"
    )
    with pytest.raises(BuildError) as info:
        api.build(api.load(text=text), options=BuildOptions(exact=True))
    assert "division by zero" in info.value.message and "(s=0)" in info.value.message


def test_probabilities_must_sum_to_exactly_one() -> None:
    text = (
        "dtmc\nmodule m\n  s : [0..1] init 0;\n"
        "  [] s=0 -> 0.3333333333333333:(s'=1) + 2/3:(s'=0);\nendmodule\n"
    )
    with pytest.raises(BuildError) as info:
        api.build(api.load(text=text), options=BuildOptions(exact=True))
    assert "not exactly 1" in info.value.message


def test_what_exact_mode_cannot_answer_is_refused_not_approximated() -> None:
    # (R[F] is answered exactly since tests/engines/test_rational_rewards.py, C<=k since
    # test_cumulative_rewards_are_exact; I=k is not)
    (reward,) = exact_results(MDP + 'rewards true : 1; endrewards\n', 'Rmax=? [ I=2 ]')
    assert isinstance(reward, PosgmcError) and "exact mode answers" in reward.message


def test_the_exact_probabilities_line_up_with_the_matrix_and_are_validated() -> None:
    model = api.build(api.load(text=MDP), options=BuildOptions(exact=True)).model
    assert model.exact_probabilities is not None
    assert np.allclose(model.transitions.data, [float(p) for p in model.exact_probabilities])
    model.validate()


@st.composite
def chains(draw):  # type: ignore[no-untyped-def]
    """A random dtmc over s in [0..n-1] whose rows have random rational probabilities."""
    n = draw(st.integers(2, 5))
    lines = []
    for s in range(n):
        k = draw(st.integers(1, 3))
        targets = draw(st.lists(st.integers(0, n - 1), min_size=k, max_size=k))
        weights = draw(st.lists(st.integers(1, 7), min_size=k, max_size=k))
        total = sum(weights)
        updates = " + ".join(f"{w}/{total}:(s'={t})" for w, t in zip(weights, targets))
        lines.append(f"  [] s={s} -> {updates};")
    body = "\n".join(lines)
    return f"dtmc\nmodule m\n  s : [0..{n - 1}] init 0;\n{body}\nendmodule\n", n


@settings(max_examples=40, deadline=None)
@given(chains())
def test_exact_values_lie_within_the_interval_engines_bounds(case) -> None:  # type: ignore[no-untyped-def]
    text, n = case
    prop = f"P=? [ F s={n - 1} ]"
    (exact,) = exact_results(text, prop)
    interval = api.check(api.load(text=text), properties=[prop]).results[0]
    assert interval.lower - 1e-12 <= exact.exact <= interval.upper + 1e-12


def test_cli_prints_the_fraction_and_json_carries_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "m.prism"
    path.write_text(MDP)
    out = CliRunner().invoke(main, ["check", str(path), "--exact", "--prop", 'Pmin=? [ F "goal" ]'])
    assert out.exit_code == 0, out.output
    assert 'Pmin=? [ F "goal" ]: 1/7' in out.output
    out = CliRunner().invoke(
        main, ["check", str(path), "--exact", "--json", "--prop", 'Pmax=? [ F "goal" ]']
    )
    assert json.loads(out.output)["results"][0]["exact"] == "1/2"


def test_posgmc_test_compares_fractions_exactly(tmp_path) -> None:  # type: ignore[no-untyped-def]
    model = tmp_path / "m.prism"
    model.write_text(LITERAL)
    props = tmp_path / "m.props"
    props.write_text(
        "// RESULT: 1000000000000000000000001/10000000000000000000000000\nP=? [ F s=1 ]\n"
        "// RESULT: 1/10\nP=? [ F s=1 ]\n"
    )
    out = CliRunner().invoke(main, ["test", str(model), str(props), "--exact"])
    # the second line is within any float tolerance of the value but not equal to it
    assert "1 passed, 1 failed" in out.output, out.output
