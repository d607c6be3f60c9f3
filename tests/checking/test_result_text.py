"""posgmc.checking.result_text: the lines of one result, short by default, bounds named by role."""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

from posgmc.checking.decimals import plain
from posgmc.checking.result_text import number_text, point_text, result_lines, role_of
from posgmc.checking.results import Bound, PropertyResult, ResultKind
from posgmc.strategies.fss import FiniteStateStrategy

# the numbers of a minimisation where the issue saw upper_bound (5.517) print below guaranteed
# (13.88): for a minimiser the bound on the best any defence achieves is the lower one
G = Bound(13.8812345, 13.88, 13.8824690)
UB = Bound(5.517, 5.517, 5.517)
FULL = Bound(5.000000001e-07, 0.0, 1e-6)


def _defence() -> FiniteStateStrategy:
    return FiniteStateStrategy.from_arrays(
        player="planner", observables=("x",), observation_values=np.array([[0], [1]]),
        actions=("a", "b"), action=np.array([[[1.0, 0.0], [0.0, 1.0]]] * 2))


def _synthesised(**changes: object) -> PropertyResult:
    r = PropertyResult(
        property='<<planner>> R{"cost"}min=? [ F "done" ]', name=None, kind=ResultKind.REWARD,
        value=G.value, lower=G.lower, upper=G.upper, seconds=3.5,
        method="synthesis (interval)", iterations=0, note="a long note", guaranteed=G,
        vs_fss_adversary=Bound(14.0, 14.0, 14.0), upper_bound=UB,
        memory=(("planner", 2),), full_observation=FULL, maximizing=False,
        synthesis={"partial": False, "phases": {"gradient search": 3.0},
                   "rounds": [{"memory": 1, "value_policy_iteration": 17.5},
                              {"memory": 2, "value_policy_iteration": 13.88}],
                   "timeout": 30.0, "seed": 0, "adversaries_enumerated": 4,
                   "adversaries_ranked": 4, "adversaries_kept": 4, "adversaries_added": 0,
                   "vs_adversaries": 4, "exhaustive": True, "defence": "search",
                   "vs_fss_defence": "search", "adversary_memory": 1},
        strategies=(_defence(),))
    return dataclasses.replace(r, **changes)  # type: ignore[arg-type]


def test_the_default_is_the_headline_and_how_it_was_found() -> None:
    lines = result_lines(_synthesised())
    assert lines[0] == ('<<planner>> R{"cost"}min=? [ F "done" ]: 13.881  [13.88, 13.882469]  '
                        "(synthesis, 3.500 s)")
    assert lines[1] == ("  how: planner's deterministic strategy with 2 memory nodes, found by "
                        "the search, proven by interval iteration")
    assert len(lines) == 3 and lines[2].startswith("  note: the value is 'guaranteed'")
    assert not any(" it.," in line or "composed's" in line for line in lines)


def test_verbose_names_each_bound_by_its_role_for_a_minimiser() -> None:
    text = "\n".join(result_lines(_synthesised(), verbose=True))
    assert "  no defence below: 5.517  [5.517, 5.517]  (upper_bound)" in text
    assert "  no defence below, full observation: 0  [0, 1e-06]  (full_observation)" in text
    assert "ensures at most this against every adversary" in text
    assert "rounds: k=1: 17.5, k=2: 13.88" in text and "effort 1, --timeout 30 s, seed 0" in text
    assert "4 strategies enumerated (all of them)" in text
    assert role_of("upper_bound", maximizing=True) == "no defence above"


def test_a_note_is_shown_once_per_run() -> None:
    seen: set[str] = set()
    first = result_lines(_synthesised(), seen=seen)
    second = result_lines(_synthesised(), seen=seen)
    assert any(line.startswith("  note:") for line in first)
    assert not any(line.startswith("  note:") for line in second)


def test_a_partial_randomised_defence_says_so() -> None:
    mixed = FiniteStateStrategy.from_arrays(
        player="planner", observables=("x",), observation_values=np.array([[0], [1]]),
        actions=("a", "b"), action=np.full((2, 2, 2), 0.5))
    stats = {**(_synthesised().synthesis or {}), "partial": True, "cut": "timeout",
             "defence": "composed"}
    line = result_lines(_synthesised(strategies=(mixed,), synthesis=stats))[1]
    assert "randomised strategy" in line and "composed against the 4 strongest" in line
    assert line.endswith("; PARTIAL: --timeout cut the work budget (the numbers, still proven, "
                         "may depend on the machine)")
    interrupted = {**stats, "cut": "interrupt"}
    line = result_lines(_synthesised(strategies=(mixed,), synthesis=interrupted))[1]
    assert line.endswith("; INTERRUPTED: the best defence verified so far")


def test_a_threshold_shows_guaranteed_and_the_bracket_has_its_place() -> None:
    @dataclasses.dataclass(frozen=True)
    class Bracket:  # the bracket on the optimum, when the result carries one
        lower: float
        upper: float

    r = _synthesised(kind=ResultKind.BOOLEAN, value=True, lower=None, upper=None)
    object.__setattr__(r, "optimum", Bracket(13.5, 13.88))
    lines = result_lines(r)
    assert lines[0].endswith(": true  (synthesis, 3.500 s)")
    assert lines[1] == "  guaranteed: 13.881  [13.88, 13.882469]"
    assert lines[2] == "  optimum: [13.5, 13.88]"
    assert lines[3].startswith("  how:")


def test_an_unproven_number_says_so() -> None:
    r = _synthesised(upper_bound=Bound(5.6, 0.0, 20.0, sound=False))
    line = next(x for x in result_lines(r, verbose=True) if "(upper_bound)" in x)
    assert "NOT PROVEN" in line


def test_an_unsettled_interval_is_printed_without_a_point_inside_it() -> None:
    # the numbers of dodge-6-lines' defence when its check stopped at the iteration cap (the
    # guarantee proven at 0.487385696 since): the shortest decimal inside [0.4873856, 1] is 1,
    # which read as the answer
    wide = Bound(0.7436928, 0.4873856, 1.0, sound=False, converged=False)
    r = _synthesised(guaranteed=wide, value=wide.value, lower=wide.lower, upper=wide.upper,
                     sound=False, converged=False)
    head = result_lines(r, verbose=False)[0]
    assert ': [0.4873856, 1]  (synthesis' in head
    assert "NOT PROVEN" in head
    line = next(x for x in result_lines(r, verbose=True) if x.startswith("  guaranteed"))
    assert line.startswith("  guaranteed: [0.4873856, 1]  NOT PROVEN")


def test_a_settled_interval_keeps_its_shortest_decimal() -> None:
    line = next(x for x in result_lines(_synthesised(), verbose=True)
                if x.startswith("  guaranteed"))
    # 13.88 itself is not inside: the double nearest 13.88 is 13.88000000000000078...
    assert line.startswith("  guaranteed: 13.881  [13.88, 13.882469]")


@given(lower=st.floats(-1e6, 1e6), width=st.floats(1e-9, 1e6), where=st.floats(0, 1),
       settled=st.booleans())
def test_the_text_of_a_value_is_its_point_only_when_settled(
        lower: float, width: float, where: float, settled: bool) -> None:
    upper = lower + width
    assume(lower < upper)
    value = lower + where * (upper - lower)
    text = point_text(value, lower, upper, settled=settled)
    if settled:
        # the shortest decimal inside the proven interval, as every settled number prints
        assert text == number_text(value, lower, upper)
    else:
        assert text == f"[{plain(lower)}, {plain(upper)}]"
