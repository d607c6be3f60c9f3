"""One resolution of coalitions and reward structures (semantics/queries.py): the semantic stage,
the checkers and input without a semantic stage (DRN, hand-built models) read a reference the same
way and reject it with the same message. Expected sets are read off the player lists by hand."""

from __future__ import annotations

import numpy as np
import pytest

from posgmc import api
from posgmc.errors import PosgmcError
from posgmc.model.explicit import ExplicitModel, RewardModel, make_model
from posgmc.semantics.queries import QueryResolver, reward_structure
from posgmc.syntax.ast import Coalition, ModelType, PlayerRef, RewardQuery
from posgmc.syntax.parser import parse_expression
from tests.io.helpers import tiny_smg

GAME = QueryResolver(ModelType.SMG, ("p1", "p2"), ("cost", None))


def _coalition(*refs: str | int) -> Coalition:
    return Coalition(
        tuple(PlayerRef(name=r) if isinstance(r, str) else PlayerRef(number=r) for r in refs)
    )


def test_players_by_name_and_by_number() -> None:
    assert GAME.coalition_of(_coalition("p2")) == frozenset({1})
    assert GAME.coalition_of(_coalition(1, "p2")) == frozenset({0, 1})
    zero_based = QueryResolver(ModelType.SMG, ("p1", "p2"), (), zero_based=True)
    assert zero_based.coalition_of(_coalition(0)) == frozenset({0})
    assert GAME.coalition_of(Coalition(all_players=True)) == frozenset({0, 1})
    assert GAME.coalition_of(None) is None


def test_bad_players_are_reported_with_both_numberings() -> None:
    with pytest.raises(PosgmcError) as err:
        GAME.coalition_of(_coalition(0))
    assert "PRISM-games numbers players from 1" in err.value.message
    assert err.value.hint is not None
    assert '"p1" = <<1>> (<<0>> with --zero-based-players)' in err.value.hint
    with pytest.raises(PosgmcError, match="appears twice"):
        GAME.coalition_of(_coalition("p1", 1))
    with pytest.raises(PosgmcError, match='unknown player "p3"'):
        GAME.coalition_of(_coalition("p3"))
    mdp = QueryResolver(ModelType.MDP, (), ())
    with pytest.raises(PosgmcError, match="a coalition only applies to games"):
        mdp.coalition_of(_coalition(1))


def _reward_query(text: str) -> RewardQuery:
    q = parse_expression(text)
    assert isinstance(q, RewardQuery)
    return q


def test_reward_structures_by_name_index_or_first() -> None:
    errors: list[PosgmcError] = []
    assert GAME.reward_index(_reward_query('R{"cost"}max=? [ F "g" ]'), errors) == 0
    assert GAME.reward_index(_reward_query('R{2}max=? [ F "g" ]'), errors) == 1
    assert GAME.reward_index(_reward_query('Rmax=? [ F "g" ]'), errors) == 0
    assert errors == []
    assert GAME.reward_index(_reward_query('R{"time"}max=? [ F "g" ]'), errors) is None
    assert GAME.reward_index(_reward_query('R{3}max=? [ F "g" ]'), errors) is None
    assert [e.message for e in errors] == [
        'unknown reward structure "time"',
        "reward structure number 3 does not exist: the model has 2 (numbered from 1)",
    ]


def _rewarded_smg() -> ExplicitModel:
    base = tiny_smg()
    return make_model(
        ModelType.SMG,
        base.row_groups,
        base.transitions,
        choice_actions=base.choice_actions,
        action_names=base.action_names,
        state_players=base.state_players,
        player_names=base.player_names,
        labels={"goal": [False, False, True]},
        reward_models=(RewardModel("steps", state=np.array([1.0, 1.0, 0.0])),),
    )


def test_reward_structure_of_a_model() -> None:
    model = _rewarded_smg()
    rm = reward_structure(model, _reward_query('R{"steps"}max=? [ F "goal" ]'))
    assert rm is model.reward_models[0]
    with pytest.raises(PosgmcError, match='unknown reward structure "time"'):
        reward_structure(model, _reward_query('R{"time"}max=? [ F "goal" ]'))


def test_a_model_without_semantic_stage_gets_the_same_messages() -> None:
    # a hand-built model is checked as it is: its references are resolved before any engine
    # runs, by the resolver the semantic stage uses, so the message and its position (the query)
    # are the same
    report = api.check(
        _rewarded_smg(),
        properties=['<<p1>> R{"time"}max=? [ F "goal" ]', '<<0>> Pmax=? [ F "goal" ]'],
    )
    assert [e.error.message for e in report.errors][0] == 'unknown reward structure "time"'
    span = report.errors[0].error.span
    assert span is not None and (span.file, span.line, span.column) == ("<--prop 1>", 1, 1)
    assert "PRISM-games numbers players from 1" in report.errors[1].error.message
    good = api.check(_rewarded_smg(), properties=['<<p1>> R{"steps"}min=? [ F "goal" ]'])
    assert not good.errors
