"""P=? / R=? on a model with nondeterminism needs min or max, as in PRISM and Storm: answering
one of them silently (Pmax) would hide which question was answered."""

from __future__ import annotations

from pathlib import Path

import pytest

from posgmc import api

ROOT = Path(__file__).resolve().parents[2]
MDP = (
    "mdp\nmodule m\n  x : [0..1] init 0;\n"
    "  [a] x=0 -> 0.5:(x'=1) + 0.5:(x'=0);\n  [b] x=0 -> true;\n"
    "endmodule\nrewards true : 1; endrewards\n"
)


@pytest.mark.parametrize(
    ("text", "prop", "words"),
    [
        (MDP, "P=? [ F x=1 ]", "P=? on an MDP needs a direction"),
        (MDP, "R=? [ C<=3 ]", "R=? on an MDP needs a direction"),
        (None, '<<rover>> P=? [ F "goal" ]', "P=? on an SMG needs a direction"),
    ],
)
def test_direction_is_required(text: str | None, prop: str, words: str) -> None:
    session = api.load(text=text) if text else api.load(ROOT / "models" / "rover.smg")
    report = api.check(session, properties=[prop])
    (error,) = [e for _, e in report.errors]
    assert words in error.message and error.hint and "min=?" in error.hint
    assert (error.span.line, error.span.column) == (1, 1)


def test_dtmc_needs_none_and_thresholds_decide_it() -> None:
    dtmc = MDP.replace("mdp", "dtmc").replace("  [b] x=0 -> true;\n", "")
    assert api.check(api.load(text=dtmc), properties=["P=? [ F x=1 ]"]).results[0].value == 1.0
    # P>=p on an MDP: for all schedulers (the minimum): b loops forever, so 0 >= 0.5 is false
    assert api.check(api.load(text=MDP), properties=["P>=0.5 [ F x=1 ]"]).results[0].value is False
