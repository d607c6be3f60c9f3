"""The enums of the compiled game and its engines, defined here so that :mod:`posgmc.model` and
:mod:`posgmc.engines` need nothing but numpy and scipy (the syntax tree names the same model types
and directions and imports them from here)."""

from __future__ import annotations

import enum

__all__ = ["Direction", "ModelType"]


class ModelType(enum.Enum):
    """The model types of the language; ``posg`` is posgmc's extension."""

    DTMC = "dtmc"
    MDP = "mdp"
    POMDP = "pomdp"
    SMG = "smg"
    POSG = "posg"

    @property
    def is_game(self) -> bool:
        return self in (ModelType.SMG, ModelType.POSG)

    @property
    def is_partially_observable(self) -> bool:
        return self in (ModelType.POMDP, ModelType.POSG)

    @property
    def is_nondeterministic(self) -> bool:
        return self is not ModelType.DTMC


class Direction(enum.Enum):
    """Which optimum a query asks for (``Pmin``/``Pmax``, ``Rmin``/``Rmax``)."""

    MIN = "min"
    MAX = "max"
