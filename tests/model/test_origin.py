"""Recipes of built models (posgmc.model.origin): a model built from text is built again, state
for state, from its recipe (plain data, a fraction of the built model's size); a model derived
from it or handed over built has none."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import numpy as np
import pytest

from posgmc import api
from posgmc.compiler import BuildOptions
from posgmc.model.origin import recipe_of

ROOT = Path(__file__).resolve().parents[2]
ROVER = ROOT / "models" / "rover.posg"


def test_a_model_built_from_text_is_built_again_from_its_recipe() -> None:
    built = api.build(api.load(ROVER), options=BuildOptions(deadline=1e18))
    model = built.model
    assert model.num_states == 60  # the rover as shipped (tests/strategies/test_product.py)
    recipe = recipe_of(model)
    assert recipe is not None
    again = pickle.loads(pickle.dumps(recipe))()  # as a worker elsewhere receives it
    assert again is not model and again.num_states == model.num_states
    assert (again.transitions != model.transitions).nnz == 0
    assert np.array_equal(again.row_groups, model.row_groups)
    assert np.array_equal(again.choice_actions, model.choice_actions)
    assert again.action_names == model.action_names
    assert again.player_names == model.player_names
    for a, b in zip(again.observations, model.observations, strict=True):
        assert np.array_equal(a.state_ids, b.state_ids) and np.array_equal(a.values, b.values)


def test_the_recipe_carries_the_constants_and_is_smaller_than_the_model() -> None:
    text = ROVER.read_text().replace("const int N = 6;", "const int N;")
    model = api.build(api.load(ROVER, text=text, constants={"N": 9})).model
    recipe = recipe_of(model)
    assert recipe is not None and recipe().num_states == model.num_states
    assert model.num_states > 60  # a longer corridor than N=6 has
    assert len(pickle.dumps(recipe)) < len(pickle.dumps(model))


def test_a_derived_or_handed_over_model_has_no_recipe() -> None:
    model = api.build(api.load(ROVER)).model
    derived = dataclasses.replace(model, reward_models=())
    assert recipe_of(derived) is None
    handed = api.build(api.Session.of_model(model)).model
    assert recipe_of(handed) is None or recipe_of(handed) is recipe_of(model)


@pytest.mark.parametrize("exact", [False, True])
def test_build_options_that_change_the_model_are_kept(exact: bool) -> None:
    chain = ("dtmc\nmodule m x : [0..1] init 0; [] x=0 -> 1/3:(x'=1) + 2/3:true;\n"
             "[] x=1 -> true; endmodule\n")
    model = api.build(api.load(text=chain), options=BuildOptions(exact=exact)).model
    recipe = recipe_of(model)
    assert recipe is not None
    again = recipe()
    assert (again.exact_probabilities is None) == (model.exact_probabilities is None) == (not exact)
