"""``PropertyChecker.check`` computes a strategy only when the report keeps it: the engines get
``want_strategy=False`` otherwise (the value and its bounds do not depend on it)."""

from __future__ import annotations

import pytest

from posgmc import api
from posgmc.checking.property_checker import CheckOptions
from posgmc.engines import rewards

# A turn-based game: the walker (player 1) at s=0 steps to the goal with probability 1/2, else to
# s=1, where the wind (player 2) either blows it back (s=0) or keeps it there forever. Hand
# derivation: the wind can keep it away from the goal with positive probability, so
# R{"steps"}min=? [F "goal"] is infinite at the initial state (PRISM's rule) and the wind's
# strategy there is positive Büchi ("stay" at s=1).
GAME = """smg
player walker [go], [done] endplayer
player wind [back], [stay] endplayer
module m
  s : [0..2] init 0;
  [go] s=0 -> 0.5 : (s'=2) + 0.5 : (s'=1);
  [done] s=2 -> true;
  [back] s=1 -> (s'=0);
  [stay] s=1 -> true;
endmodule
label "goal" = s=2;
rewards "steps" [go] true : 1; endrewards
"""
PROP = '<<walker>> Rmin=? [ F "goal" ]'


def test_check_without_kept_strategy_never_computes_one(monkeypatch: pytest.MonkeyPatch) -> None:
    session = api.load(text=GAME)
    built = api.build(session)
    assert built.model.num_states == 3  # s = 0, 1, 2

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a strategy was computed although the report drops it")

    monkeypatch.setattr(rewards, "positive_buchi", refuse)
    rep = api.check(session, properties=[PROP], built=built)
    r = rep.results[0]
    assert r.value == float("inf") and r.lower == r.upper == float("inf") and r.sound
    assert r.strategy is None


def test_check_with_kept_strategy_still_gets_one() -> None:
    session = api.load(text=GAME)
    built = api.build(session)
    rep = api.check(
        session, properties=[PROP], built=built, options=CheckOptions(keep_strategy=True)
    )
    r = rep.results[0]
    assert r.value == float("inf")
    assert r.strategy is not None
    # the wind keeps the walker away: it stays at s=1 (its choice index is that of "stay")
    names = [built.model.action_names[a] for a in built.model.choice_actions]
    assert names[int(r.strategy[1])] == "stay"
