"""Binding a strategy to a model: linear in the rules, and rules for observations the model never
shows are summarised as warnings (the first few by name, then a count)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from posgmc import api
from posgmc.strategies.binding import bind
from posgmc.strategies.files import strategy_from_json

ROOT = Path(__file__).resolve().parents[2]
ROVER = ROOT / "models" / "rover.posg"
FORWARD = ROOT / "models" / "rover" / "forward.fss.json"


def test_twenty_thousand_unseen_rules_give_four_warnings() -> None:
    doc = json.loads(FORWARD.read_text())
    doc["rules"] += [{"memory": 0, "observation": {"x": 100 + i}, "action": {"fwd": 1.0}}
                     for i in range(20_000)]
    model = api.build(api.load(ROVER)).model
    assert model.num_states == 60  # the rover as shipped
    b = bind(model, strategy_from_json(doc, file="s.json"))
    assert b.warnings == (
        "s.json: rules[7]: the model never shows player 'rover' the observation {x=100}",
        "s.json: rules[8]: the model never shows player 'rover' the observation {x=101}",
        "s.json: rules[9]: the model never shows player 'rover' the observation {x=102}",
        "s.json: 19997 more rules (20000 in all) are for observations the model never shows "
        "player 'rover'",
    )
    # the seven rules the model does show are bound: forward plays fwd in x=1..5
    owned = np.flatnonzero(b.owned)
    choices = model.row_groups[owned]
    p = b.action_probability(model, np.zeros(owned.size, dtype=np.int64), choices)
    assert set(p.tolist()) <= {0.0, 1.0} and p.sum() > 0
