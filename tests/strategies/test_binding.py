"""Binding strategies to models. A model whose choices carry no labels (a DRN POMDP as Storm
writes it, like Cassandra's hallway in PAYNT's SAYNT set): choices are named by their local index,
``#0``, ``#1``, in the built model, in strategies and in strategy files. Many rules for
observations the model never shows: binding is linear and the warnings are summarised."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from posgmc import api
from posgmc.errors import InputError
from posgmc.io.drn import parse_drn
from posgmc.strategies.binding import bind
from posgmc.strategies.files import read_strategy, strategy_from_json
from posgmc.strategies.fss import StrategyError

DATA = Path(__file__).resolve().parents[1] / "data" / "compat"
MODEL = DATA / "unlabelled_pomdp.drn"
GOAL = 'Pmax=? [ F "goal" ]'


def _strategy(tmp_path: Path, at_obs1: str, at_obs0: str = "#0") -> str:
    path = tmp_path / "agent.json"
    path.write_text(json.dumps({
        "format": "posgmc-fss/1", "player": "", "memory_size": 1, "initial_memory": 0,
        "observables": [],
        "rules": [
            {"memory": 0, "observation": 0, "action": {at_obs0: 1.0}},
            {"memory": 0, "observation": 1, "action": {at_obs1: 1.0}},
            {"memory": 0, "observation": 2, "action": {"": 1.0}},
        ],
    }))
    return str(path)


def test_unlabelled_choices_are_named_by_local_index() -> None:
    model = api.build(api.load(MODEL)).model
    # Storm 2.0 (stormpy.build_model_from_drn): 4 states, 7 choices, 8 transitions, 3 observations
    assert (model.num_states, model.num_choices, model.num_transitions) == (4, 7, 8)
    names = [model.action_names[a] for a in model.choice_actions.tolist()]
    # states 0-2 offer two unlabelled choices each; state 3's single one keeps the empty label
    assert names == ["#0", "#1", "#0", "#1", "#0", "#1", ""]


@pytest.mark.parametrize(("action", "value"), [("#1", 1.0), ("#0", 0.5)])
def test_a_strategy_file_names_choices_by_index(tmp_path: Path, action: str, value: float) -> None:
    # by hand: observation 1 covers states 1 and 2. #1 everywhere: 0 -#0-> 1 -#1-> 2 -#1-> 3,
    # goal with probability 1. #0 there: state 1 reaches 3 or 2 with 0.5 each, and state 2
    # then loops on itself: 0.5
    report = api.check(
        api.load(MODEL), properties=[GOAL], strategies={"": _strategy(tmp_path, action)}
    )
    (result,) = report.results
    g = result.guaranteed
    assert g is not None and g.lower <= value <= g.upper and g.upper - g.lower < 1e-5


def test_an_index_the_states_do_not_offer_is_a_strategy_error(tmp_path: Path) -> None:
    with pytest.raises(StrategyError) as info:
        api.check(api.load(MODEL), properties=[GOAL], strategies={"": _strategy(tmp_path, "#2")})
    assert "the model has no action labelled '#2'" in info.value.message


def test_the_raw_model_error_names_the_agent_and_the_state_once(tmp_path: Path) -> None:
    # a model not built through api.build keeps the DRN's unlabelled choices
    raw = parse_drn(MODEL.read_text(), file=str(MODEL))
    fss = read_strategy(_strategy(tmp_path, "", at_obs0=""))
    with pytest.raises(InputError) as info:
        bind(raw, fss)
    assert info.value.message.startswith("state 0 of the agent offers two choices labelled ''")


def test_the_raw_model_error_is_raised_on_every_bind(tmp_path: Path) -> None:
    # binding remembers a model's facts only once they are checked: a second bind of an unfit
    # model fails as the first did
    raw = parse_drn(MODEL.read_text(), file=str(MODEL))
    fss = read_strategy(_strategy(tmp_path, "", at_obs0=""))
    for _ in range(2):
        with pytest.raises(InputError):
            bind(raw, fss)


def test_remembered_observation_matchings_follow_each_strategy_order(tmp_path: Path) -> None:
    # the matching of a strategy's observation list is remembered per list: a strategy whose
    # list names observations 0 and 1 the other way round binds the other way round
    model = api.build(api.load(MODEL)).model
    fss = read_strategy(_strategy(tmp_path, "#1"))
    swapped = dataclasses.replace(
        fss, observation_values=fss.observation_values[[1, 0, 2]].copy())
    for _ in range(2):
        a, b = bind(model, fss), bind(model, swapped)
        assert a.obs_map.tolist() == [0, 1, 2]  # the file's rules are for observations 0, 1, 2
        assert b.obs_map.tolist() == [1, 0, 2]


def test_an_exported_strategy_reads_back(tmp_path: Path) -> None:
    from posgmc.strategies.files import write_strategy

    path = tmp_path / "agent.json"
    fss = read_strategy(_strategy(tmp_path, "#1"))
    write_strategy(fss, path)
    again = read_strategy(str(path))
    assert again.actions == fss.actions and "#1" in again.actions
    assert np.array_equal(again.action, fss.action)


# -- many rules for observations the model never shows: linear, summarised ---------------------

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
