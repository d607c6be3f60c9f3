"""Steady-state probabilities (``S``) and long-run average rewards (``R[S]``) on dtmcs.

The model (by hand): s=0 moves to the BSCC {1, 2} or the BSCC {3, 4} with 1/2 each. In {1, 2}:
1 -> 2 with 1/2 and 2 -> 1, so pi = (2/3, 1/3). In {3, 4}: 3 -> 4 with 1/4 and 4 -> 3, so
pi = (4/5, 1/5). Rewards: 2 per step in s=1, 4 per step (action reward) in s=3, so the long-run
average is 2 * 2/3 = 4/3 in the first BSCC and 4 * 4/5 = 16/5 in the second; from s=0 it is
(4/3 + 16/5) / 2 = 34/15.
"""

from __future__ import annotations

from fractions import Fraction

import pytest

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.compiler.options import BuildOptions
from posgmc.engines import steady
from posgmc.errors import UnsupportedError

MODEL = """
dtmc
module m
  s : [0..4] init 0;
  [] s=0 -> 0.5:(s'=1) + 0.5:(s'=3);
  [] s=1 -> 0.5:(s'=2) + 0.5:(s'=1);
  [] s=2 -> 1:(s'=1);
  [] s=3 -> 0.25:(s'=4) + 0.75:(s'=3);
  [] s=4 -> 1:(s'=3);
endmodule
rewards "r"
  s=1 : 2;
  [] s=3 : 4;
endrewards
"""

CASES = [
    ("S=? [ s=1 ]", Fraction(1, 3)),
    ("S=? [ s=2 ]", Fraction(1, 6)),
    ("S=? [ s=3 | s=4 ]", Fraction(1, 2)),
    ("S=? [ s=0 ]", Fraction(0)),  # transient
    ('R{"r"}=? [ S ]', Fraction(34, 15)),
    ("filter(state, S=? [ s=4 ], s=3)", Fraction(1, 5)),  # from inside the second BSCC
]


@pytest.mark.parametrize(("prop", "expected"), CASES)
def test_steady_state_values(prop: str, expected: Fraction) -> None:
    session = api.load(text=MODEL)
    assert api.build(session).model.num_states == 5
    (r,) = api.check(session, properties=[prop]).results
    assert r.sound and r.lower <= expected <= r.upper and r.upper - r.lower < 1e-12


@pytest.mark.parametrize(("prop", "expected"), CASES[:5])
def test_steady_state_exact_mode(prop: str, expected: Fraction) -> None:
    session = api.load(text=MODEL)
    built = api.build(session, options=BuildOptions(exact=True))
    (r,) = api.check(session, properties=[prop], built=built,
                     options=CheckOptions(exact=True)).results
    assert r.exact == expected


@pytest.mark.parametrize(("prop", "expected"), [("S>=0.5 [ s=3 | s=4 ]", True),
                                                ("S>0.5 [ s=3 | s=4 ]", False),
                                                ("S<0.2 [ s=2 ]", True)])
def test_thresholds_are_decided_on_the_exact_value(prop: str, expected: bool) -> None:
    (r,) = api.check(api.load(text=MODEL), properties=[prop]).results
    assert r.value is expected


def test_bsccs() -> None:
    model = api.build(api.load(text=MODEL)).model
    s_of = model.state_values[:, 0]  # states are numbered in exploration order
    assert sorted(sorted(s_of[b].tolist()) for b in steady.bsccs(model)) == [[1, 2], [3, 4]]


def test_large_bsccs_use_the_float_path_with_sound_bounds_from_reachability(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(steady, "EXACT_LIMIT", 1)  # force the floating-point path
    model = api.build(api.load(text=MODEL)).model
    r = steady.long_run_average(model, (model.state_values[:, 0] == 1).astype(float))
    assert not r.sound  # BSCCs of 2 states exceed the limit: their pi is a float solve
    assert abs(r.values[0] - 1 / 3) < 1e-9


def test_mdps_are_refused() -> None:
    report = api.check(api.load(text=MODEL.replace("dtmc", "mdp")), properties=["S=? [ s=1 ]"])
    (_, err), = report.errors
    assert isinstance(err, UnsupportedError) and "dtmcs only" in err.message
