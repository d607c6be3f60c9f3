"""Arithmetic, comparisons and thresholds over queries: proven bounds through every operator.

Expected numbers are hand-derived on the chains below:

* ``HALF`` (dtmc): from x=0, 1/4 to x=1, 1/4 to x=2, 1/2 to x=3, which returns to x=0 with 1/2
  and stays with 1/2. P(F x=1) = (1/4) / (1 - 1/2) = 1/2 exactly (x=3 is left to x=0 surely),
  P(F x=2) = 1/2 likewise. Interval iteration approaches 1/2 from both sides but never reaches it,
  so a threshold at 0.5 is decided only by refinement (the exact solve).
* ``COIN`` (mdp): one choice, 1/2 to x=1 ("goal"), 1/2 to x=2; both absorbing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posgmc import api
from posgmc.checking import dispatch
from posgmc.checking import intervals as iv
from posgmc.checking.results import ResultKind
from posgmc.errors import SemanticError
from posgmc.semantics import operators as ops
from posgmc.syntax.ast import BinaryOp, Function

HALF = """dtmc
module m
  x : [0..3] init 0;
  [] x=0 -> 0.25:(x'=1) + 0.25:(x'=2) + 0.5:(x'=3);
  [] x=3 -> 0.5:(x'=0) + 0.5:(x'=3);
  [] x=1|x=2 -> true;
endmodule
label "goal" = x=1;
rewards "steps" true : 1; endrewards
"""

COIN = """mdp
module m
  x : [0..2] init 0;
  [] x=0 -> 0.5:(x'=1) + 0.5:(x'=2);
  [] x>0 -> true;
endmodule
label "goal" = x=1;
"""


def _check(model: str, prop: str, **kwargs):  # type: ignore[no-untyped-def]
    session = api.load(text=model)
    report = api.check(session, properties=[prop], **kwargs)
    assert report.model.num_states in (3, 4)  # sizes first: HALF has 4 states, COIN 3
    if report.errors:
        raise report.errors[0][1]
    return report.results[0]


# -- thresholds and comparisons are decided on proven bounds only -------------------------------


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ("P=? [ F x=1 ] > 0.5", False),  # exact value 1/2
        ("P>0.5 [ F x=1 ]", False),
        ("P>=0.5 [ F x=1 ]", True),
        ("P=? [ F x=1 ] >= 0.5", True),
        ("P=? [ F x=1 ] = P=? [ F x=2 ]", True),
        ("P=? [ F x=1 ] < 0.5", False),
    ],
)
def test_threshold_at_the_exact_value_is_refined_to_a_proof(prop: str, expected: bool) -> None:
    r = _check(HALF, prop)
    assert r.kind is ResultKind.BOOLEAN
    assert r.value is expected and r.sound


def test_undecided_threshold_is_unknown_without_exact_refinement(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(dispatch, "EXACT_REFINEMENT_STATES", 0)
    r = _check(HALF, "P>0.5 [ F x=1 ]")
    assert r.value is None and r.is_unknown and not r.sound and not r.is_decided
    assert r.to_json()["value"] == "unknown"
    r = _check(HALF, "P=? [ F x=1 ] > 0.5")
    assert r.is_unknown


def test_separated_threshold_needs_no_refinement() -> None:
    r = _check(HALF, "P>0.4 [ F x=1 ]")
    assert r.value is True and r.sound and r.method == "interval"


# -- P=? needs a direction where choices exist --------------------------------------------------


def test_p_query_without_direction_on_an_mdp_is_refused() -> None:
    with pytest.raises(SemanticError) as info:
        _check(COIN, 'P=? [ F "goal" ]')
    assert "needs min or max" in info.value.message and info.value.span is not None
    assert "Pmax=?" in (info.value.hint or "")
    assert _check(COIN, 'Pmax=? [ F "goal" ]').value == pytest.approx(0.5)


# -- arithmetic over queries keeps its bounds ------------------------------------------------------


def test_function_of_a_query_keeps_the_interval() -> None:
    # the engine's bounds straddle 1/2; min(., 1) must keep them (not report lower = upper)
    r = _check(HALF, "min(P=? [ F x=1 ], 1)")
    assert r.lower <= 0.5 <= r.upper and r.lower < r.upper and r.sound


def test_ite_over_queries_keeps_the_interval() -> None:
    r = _check(HALF, "true ? P=? [ F x=1 ] : 0")
    assert r.lower <= 0.5 <= r.upper and r.sound


def test_division_of_a_query_by_zero_is_infinite() -> None:
    # PRISM (Java doubles): 0.5 / 0 = Infinity; never the largest finite double
    r = _check(HALF, "P=? [ F x=1 ] / 0")
    assert r.value == math.inf and r.lower == math.inf and r.upper == math.inf
    assert r.to_json()["value"] == "inf"


def test_zero_over_zero_is_undefined_not_zero() -> None:
    r = _check(COIN, 'Pmin=? [ F x=3 ] / Pmin=? [ F x=3 ]')  # 0/0: x=3 does not exist... as P=0
    assert math.isnan(r.value) and not r.sound
    assert r.to_json()["value"] is None


def test_quotient_value_lies_within_its_bounds() -> None:
    r = _check(HALF, "P=? [ F x=1 ] / (P=? [ F x=1 ] - P=? [ F x=1 ])")
    assert r.lower <= r.value <= r.upper


def test_floor_of_an_infinite_reward_is_an_error() -> None:
    # from x=0 the target x=1 is missed with probability 1/2: R[F] is infinite (PRISM)
    with pytest.raises(SemanticError) as info:
        _check(HALF, 'floor(R{"steps"}=? [ F x=1 ])')
    assert "floor() of inf" in info.value.message and info.value.span is not None


# -- one rule for partial operators in properties and models ---------------------------------------


@pytest.mark.parametrize(
    ("prop", "message"),
    [
        ("pow(2, x-1) > 0", "negative exponent -1 in pow() of two ints"),
        ("mod(3, x)", "mod() by a non-positive divisor (0)"),
        ("floor(1/x)", "floor() of inf is not an integer"),
        ("mod(3, 0) + P=? [ F x=1 ]", "mod() by a non-positive divisor (0)"),
    ],
)
def test_partial_operators_in_properties_fail_with_the_state(prop: str, message: str) -> None:
    with pytest.raises(SemanticError) as info:
        _check(HALF, prop)
    assert message in info.value.message and "(x=0)" in info.value.message
    assert info.value.span is not None


# -- the interval operators themselves ----------------------------------------------------------------


def _b(lo: float, hi: float) -> iv.Bounds:
    a, b = np.array([lo]), np.array([hi])
    return iv.Bounds((a + b) / 2, a, b, np.array([True]))


def test_comparison_straddling_is_undecided() -> None:
    r = iv.binary(BinaryOp.GT, _b(0.4, 0.6), iv.point(np.array([0.5])))
    assert not r.decided[0] and not r.lower[0] and r.upper[0]
    r = iv.binary(BinaryOp.GT, _b(0.51, 0.6), iv.point(np.array([0.5])))
    assert r.decided[0] and r.lower[0]


def test_monotone_and_product_bounds() -> None:
    m = iv.call(Function.MIN, [_b(0.4, 0.6), iv.point(np.array([0.5]))])
    assert (m.lower[0], m.upper[0]) == (0.4, 0.5)
    p = iv.binary(BinaryOp.MUL, _b(-1.0, 2.0), _b(3.0, 4.0))
    assert (p.lower[0], p.upper[0]) == (-4.0, 8.0)
    d = iv.binary(BinaryOp.DIV, _b(1.0, 2.0), _b(-1.0, 1.0))
    assert (d.lower[0], d.upper[0]) == (-math.inf, math.inf) and d.defined[0]


def test_nested_threshold_at_the_exact_value_is_refined() -> None:
    # P>0.5 [F x=1] holds in x=1 only (x=0 and x=3 have exactly 1/2): the outer value is 1/2;
    # with >= it holds in the initial state itself: 1
    r = _check(HALF, "P=? [ F P>0.5 [ F x=1 ] ]")
    assert r.value == pytest.approx(0.5, abs=1e-12) and r.sound and r.method == "exact"
    assert _check(HALF, "P=? [ F P>=0.5 [ F x=1 ] ]").value == 1.0


def test_nested_undecided_threshold_is_not_proven(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(dispatch, "EXACT_REFINEMENT_STATES", 0)
    r = _check(HALF, "P=? [ F P>0.5 [ F x=1 ] ]")
    assert not r.sound  # the target set was guessed where the nested bounds straddle 0.5


# -- invariant: the bounds of a result contain the operator applied to any points inside ------------

_finite = st.floats(-8, 8, allow_nan=False, allow_infinity=False)


@st.composite
def _interval_with_point(draw):  # type: ignore[no-untyped-def]
    lo, pt, hi = sorted(draw(st.lists(_finite, min_size=3, max_size=3)))
    return lo, pt, hi


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(list(BinaryOp)[4:]),  # comparisons and arithmetic (connectives below)
    _interval_with_point(),
    _interval_with_point(),
)
def test_binary_bounds_contain_every_point(op: BinaryOp, a, b) -> None:  # type: ignore[no-untyped-def]
    A = iv.Bounds(*(np.array([x]) for x in (a[1], a[0], a[2])), np.array([True]))
    B = iv.Bounds(*(np.array([x]) for x in (b[1], b[0], b[2])), np.array([True]))
    r = iv.binary(op, A, B)
    with np.errstate(all="ignore"):
        exact = ops.BINARY[op].vector(np.array([a[1]]), np.array([b[1]]))
    if r.defined[0] and not np.isnan(exact[0]):
        assert r.lower[0] <= exact[0] <= r.upper[0], (op, a, b, r.lower, r.upper, exact)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from([Function.MIN, Function.MAX, Function.FLOOR, Function.CEIL, Function.ROUND]),
       _interval_with_point(), _interval_with_point())
def test_function_bounds_contain_every_point(fn: Function, a, b) -> None:  # type: ignore[no-untyped-def]
    A = iv.Bounds(*(np.array([x]) for x in (a[1], a[0], a[2])), np.array([True]))
    B = iv.Bounds(*(np.array([x]) for x in (b[1], b[0], b[2])), np.array([True]))
    args = [A, B] if fn in (Function.MIN, Function.MAX) else [A]
    r = iv.call(fn, args)
    pts = [np.array([a[1]]), np.array([b[1]])][: len(args)]
    exact = {
        Function.MIN: lambda: np.minimum(*pts),
        Function.MAX: lambda: np.maximum(*pts),
        Function.FLOOR: lambda: ops.to_int(pts[0], "floor"),
        Function.CEIL: lambda: ops.to_int(pts[0], "ceil"),
        Function.ROUND: lambda: ops.to_int(pts[0], "round"),
    }[fn]()
    assert r.lower[0] <= exact[0] <= r.upper[0]


def test_reward_threshold_at_the_exact_value_is_refined() -> None:
    # expected steps to x in {1,2}: E0 = 1 + E3/2, E3 = 1 + E0/2 + E3/2, so E0 = 4 exactly
    assert _check(HALF, 'R{"steps"}=? [ F x=1|x=2 ] >= 4').value is True
    r = _check(HALF, 'R{"steps"}<4 [ F x=1|x=2 ]')
    assert r.value is False and r.sound


BOOLVAR = """dtmc
module m
  x : [0..2] init 0;
  b : bool init true;
  [] x=0 -> 0.5:(x'=1) + 0.5:(x'=2);
  [] x>0 -> true;
endmodule
"""


@pytest.mark.parametrize(
    ("prop", "expected"),
    [
        ("b & P>0.4 [ F x=1 ]", True),  # P = 1/2 by hand
        ("!b | P>0.6 [ F x=1 ]", False),
        ("b = P>0.4 [ F x=1 ]", True),
        ("(x=0 ? b : false) & P<0.6 [ F x=1 ]", True),
    ],
)
def test_boolean_variables_combine_with_queries(prop: str, expected: bool) -> None:
    # valuations are stored as ints: a Boolean variable must still act as a Boolean here
    session = api.load(text=BOOLVAR)
    report = api.check(session, properties=[prop])
    assert report.model.num_states == 3 and not report.errors
    assert report.results[0].value is expected and report.results[0].sound


def test_boolean_variable_as_condition_over_a_query() -> None:
    session = api.load(text=BOOLVAR)
    (r,) = api.check(session, properties=["b ? P=? [ F x=1 ] : 0"]).results
    assert r.lower <= 0.5 <= r.upper and r.sound
