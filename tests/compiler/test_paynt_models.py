"""PAYNT's public models build to Storm's counts: every vendored file that Storm 2.0 builds, posgmc
builds with the same numbers of states, choices, transitions (and observations of a POMDP).

The files are PAYNT's (``randriu/synthesis``, ``models/`` tree; provenance in tests/data/README.md),
the reference counts Storm's, recorded by ``benchmarks/paynt_counts.py`` in
tests/data/paynt/storm_counts.json. Among them the ones PAYNT and Storm accepted and posgmc refused
before: an observable named like a label (maze-10, drone-2-8-1), int/int assigned to an int
variable (lanes-100-combined-new) or initialising one (geo-2-8), unlabelled DRN choices (hallway).
Models of more than a second's build run with ``-m slow``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from posgmc import api
from posgmc.errors import BuildError, DialectWarning, MultipleErrors, ParseError, SemanticError

DATA = Path(__file__).resolve().parents[1] / "data" / "paynt"
MODELS = DATA / "models"
STORM = json.loads((DATA / "storm_counts.json").read_text())["models"]

SLOW = {
    "pomdp/large/maze-10/sketch.templ",
    "pomdp/large/drone-2-8-1/sketch.templ",
    "pomdp/large/network-5-10-8/sketch.templ",
    "pomdp/large/rocks-4-20/sketch.templ",
    "posmg/pomdps/multi-dodge4/sketch.templ",
    "archive/voihp/network-prio-3-8-20/sketch.templ",
    "archive/indefinite-horizon-pomdps/models/crypt/crypt6.prism",
}
# Storm builds these only without its range checks (state valuations off: 1340 states of garbled
# valuations); with them it refuses, as posgmc does, an assignment x2' = max(x2-1, 0) below x2's
# range [1..6]
OUT_OF_RANGE = {
    "posmg/prism-models/dodge6-lines.prism",
    "posmg/prism-models/dodge6-lines-position.prism",
}


def _cases(slow: bool) -> list[object]:
    keys = sorted(k for k in STORM if (k in SLOW) == slow)
    marks = [pytest.mark.slow] if slow else []
    return [pytest.param(k, id=k, marks=marks) for k in keys]


def _counts(key: str) -> dict[str, int]:
    built = api.build(api.load(MODELS / key))
    m = built.model
    out = {"states": m.num_states, "choices": m.num_choices, "transitions": m.num_transitions}
    observations = m.statistics().get("observations")
    if "observations" in STORM[key] and observations:
        out["observations"] = observations["agent"]
    return out


def test_the_vendored_files_and_the_reference_agree() -> None:
    files = {
        p.relative_to(MODELS).as_posix()
        for p in MODELS.rglob("*")
        if p.is_file() and "sketches" not in p.parts
    }
    assert files == set(STORM)
    # Storm refuses exactly the two models whose assignment leaves the range
    assert {k for k, v in STORM.items() if "error" in v} == OUT_OF_RANGE
    assert SLOW <= set(STORM)


@pytest.mark.parametrize("key", _cases(slow=False))
def test_storms_counts(key: str) -> None:
    _check(key)


@pytest.mark.parametrize("key", _cases(slow=True))
def test_storms_counts_of_large_models(key: str) -> None:
    _check(key)


def _check(key: str) -> None:
    storm = STORM[key]
    if "error" in storm:
        assert "out of range" in storm["error"]
        with pytest.raises(BuildError) as info:
            api.build(api.load(MODELS / key))
        assert "outside its range [1..6]" in info.value.message
        return
    want = {k: storm[k] for k in ("states", "choices", "transitions", "observations") if k in storm}
    assert _counts(key) == want


@pytest.mark.parametrize(
    ("key", "lines"),
    [
        ("archive/cav23-saynt/lanes-100-combined-new/sketch.templ", [82, 82]),  # y'=SIZE/2+1
        # o1x, o1y, then o2x, o2y of the renamed module obs2, whose text is obs1's
        ("pomdp/large/geo-2-8/sketch.templ", [53, 53, 54, 54]),  # init gMAX/2
    ],
)
def test_storms_reading_is_a_warning_and_strict_refuses(key: str, lines: list[int]) -> None:
    built = api.build(api.load(MODELS / key))
    assert built.flat is not None
    assert all(isinstance(w, DialectWarning) for w in built.flat.warnings)
    assert [w.span.line for w in built.flat.warnings if w.span] == lines
    assert all("PRISM's rule" in str(w) for w in built.warnings)
    with pytest.raises(MultipleErrors) as info:
        api.build(api.load(MODELS / key, strict=True))
    assert [e.span.line for e in info.value.errors if e.span] == lines
    assert all(isinstance(e, SemanticError) and "divides ints" in e.message
               for e in info.value.errors)


def test_a_label_and_an_observable_of_one_name() -> None:
    # drone-2-8-1 has the same clash (label "goal", observable "goal") and runs with -m slow
    key = "pomdp/large/maze-10/sketch.templ"
    flat = api.instantiate(api.load(MODELS / key))
    ((w),) = flat.warnings
    assert w.span is not None and w.span.line == 39
    assert w.message.startswith('observable "goal" has the name of label "goal" (line 32)')
    with pytest.raises(SemanticError):
        api.instantiate(api.load(MODELS / key, strict=True))


def test_unlabelled_drn_choices_are_named_by_index() -> None:
    model = api.build(api.load(MODELS / "archive/cav23-saynt/hallway/sketch.templ")).model
    assert (model.num_states, model.num_choices) == (61, 301)  # Storm's (storm_counts.json)
    assert {"#0", "#1", "#2", "#3", "#4"} <= set(model.action_names)


def test_a_paynt_sketch_is_a_family_of_models() -> None:
    with pytest.raises(ParseError) as info:
        api.load(MODELS / "pomdp/sketches/avoid-smaller-family/sketch.templ")
    assert "family of models" in info.value.message
    assert info.value.span is not None and info.value.span.line == 51
