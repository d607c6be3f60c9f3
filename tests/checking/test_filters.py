"""PRISM's filters, ``filter(op, prop, states)`` and the old ``P=? [ ... {states}{min} ]`` form
(meaning: ``prism/src/explicit/StateModelChecker.java``, ``checkExpressionFilter``)."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.errors import PosgmcError, SemanticError, UnsupportedError

# s=0 -> s=1 or s=2 (1/2 each); s=1 loops (0.7) or reaches s=3 "a" (0.3); s=2, s=3 absorb.
# By hand, P(F "a") per state: s0 = 1/2, s1 = 1, s2 = 0, s3 = 1.
MODEL = """
dtmc
module m
  s : [0..3] init 0;
  [] s=0 -> 0.5:(s'=1) + 0.5:(s'=2);
  [] s=1 -> 0.3:(s'=3) + 0.7:(s'=1);
  [] s>=2 -> true;
endmodule
label "a" = s=3;
"""

CASES = [
    ('filter(forall, P>0.5 [ F "a" ] <=> (s=1|s=3))', True),
    ('filter(forall, P>0.5 [ F "a" ])', False),  # s0 and s2 fail
    ('filter(&, P>=0.5 [ F "a" ], s!=2)', True),
    ('filter(exists, P<0.1 [ F "a" ])', True),  # s2
    ('filter(|, s=7)', False),
    ('filter(count, P>0 [ F "a" ])', 3),  # s0, s1, s3
    ('filter(count, P>0 [ F "a" ]) = 3', True),
    ('filter(min, P=? [ F "a" ], s<=1)', 0.5),
    ('filter(max, P=? [ F "a" ], s!=1)', 1.0),
    ('filter(sum, P=? [ F "a" ])', 2.5),
    ('filter(+, s)', 6),
    ('filter(avg, P=? [ F "a" ])', 0.625),
    ('filter(first, P=? [ F "a" ], s>0)', 1.0),  # the lowest state satisfying s>0 is s1
    ('filter(state, P=? [ F "a" ], s=2)', 0.0),
    ('filter(print, P=? [ F "a" ])', 0.5),  # values unchanged: the initial state's
    ('filter(printall, P=? [ F "a" ])', 0.5),
    ('filter(argmin, P=? [ F "a" ])', False),  # the minimiser is s2, not the initial s0
    ('filter(count, filter(argmax, P=? [ F "a" ]))', 2),  # s1 and s3
    ('2 * filter(max, P=? [ F "a" ])', 2.0),
    ('P=? [ F "a" {s=1} ]', 1.0),  # old form: the value in the one state s=1
    ('P=? [ F "a" {s<=2}{min} ]', 0.0),
    ('P=? [ F "a" {s<=1}{max} ]', 1.0),
    ('P>=0.5 [ F "a" {s!=2} ]', True),  # old form with a threshold: for all those states
    ('P>=0.5 [ F "a" {s>=0} ]', False),
]


@pytest.mark.parametrize(("prop", "expected"), CASES)
def test_filter_values(prop: str, expected: float | bool) -> None:
    session = api.load(text=MODEL)
    assert api.build(session).model.num_states == 4
    report = api.check(session, properties=[prop])
    assert not report.errors, report.errors[0][1].render()
    r = report.results[0]
    if isinstance(expected, bool):
        assert r.value is expected
    else:
        assert r.lower <= expected + 1e-9 and expected - 1e-9 <= r.upper and r.sound
        assert r.upper - r.lower < 1e-6


@pytest.mark.parametrize(
    ("prop", "error", "words"),
    [
        ('filter(state, P=? [ F "a" ])', SemanticError, "exactly 1 state"),
        ('filter(min, P=? [ F "a" ], s>4)', SemanticError, "satisfies no states"),
        ('filter(count, P=? [ F "a" ])', SemanticError, "needs a Boolean operand"),
        ('filter(min, s=1)', SemanticError, "needs a numeric operand"),
        ('filter(range, P=? [ F "a" ])', UnsupportedError, "range"),
        ('filter(median, s)', PosgmcError, "'median' is not a filter operator"),
    ],
)
def test_filter_errors(prop: str, error: type, words: str) -> None:
    try:
        report = api.check(api.load(text=MODEL), properties=[prop])
    except PosgmcError as e:  # a parse error concerns the whole input
        assert isinstance(e, error) and words in e.message
        return
    (_, err), = report.errors
    assert isinstance(err, error) and words in err.message


def test_filter_is_a_word_only_before_a_parenthesis() -> None:
    # a model may still name a variable `filter`
    text = MODEL.replace("s : [0..3] init 0;", "s : [0..3] init 0;\n  filter : bool init true;")
    report = api.check(api.load(text=text), properties=["filter", "filter(forall, filter)"])
    assert [r.value for r in report.results] == [True, True]
