"""Where a built model came from: the recipe that builds the same model again (the model's text,
its constants, the build options), so that a worker on another machine builds it from a few
kilobytes of plain data instead of receiving the built model (:mod:`posgmc.synthesis.ray_pool`).

A recipe is remembered for the very object the build returned (by identity, as long as it lives):
a model derived from it (a reward added, choices renamed) is another object and has none, so a
recipe never stands for a model it does not build. Building is deterministic: the recipe's model
has the same states, choices and numbers in the same order.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable

from posgmc.model.explicit import ExplicitModel

__all__ = ["Recipe", "remember", "recipe_of"]

Recipe = Callable[[], ExplicitModel]
"""A picklable call (a module-level function with plain-data arguments) that builds a model."""

_RECIPES: weakref.WeakKeyDictionary[ExplicitModel, Recipe] = weakref.WeakKeyDictionary()


def remember(model: ExplicitModel, recipe: Recipe) -> None:
    """``recipe()`` builds ``model`` again, state for state."""
    _RECIPES[model] = recipe


def recipe_of(model: ExplicitModel) -> Recipe | None:
    """The recipe that builds ``model`` (None: it was not built from text here, or was changed
    after it was built)."""
    return _RECIPES.get(model)
