"""Which observables of a strategy are Boolean, read off the model it was made for: a strategy
file writes them as ``true``/``false`` (docs/strategies.md), as a person wrote them in the model."""

from __future__ import annotations

import dataclasses

from posgmc.model.explicit import ExplicitModel
from posgmc.strategies.fss import FiniteStateStrategy

__all__ = ["with_boolean_observables"]


def with_boolean_observables(fss: FiniteStateStrategy, model: ExplicitModel) -> FiniteStateStrategy:
    """``fss`` with ``boolean`` set for its observables that are Boolean variables of ``model``
    (a strategy that says already, or has none, is returned as it is)."""
    if fss.boolean or not model.boolean_variables:
        return fss
    flags = tuple(name in model.boolean_variables for name in fss.observables)
    return dataclasses.replace(fss, boolean=flags) if any(flags) else fss
