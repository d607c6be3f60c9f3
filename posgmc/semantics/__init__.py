"""Front end, second stage: one pass per semantic question (constants, names, types, players,
observations), ending in the instantiated :class:`~posgmc.semantics.flat.FlatModel`.

Entry points (``checker.py``): :func:`check_model` / :func:`check_properties` list every error;
:func:`instantiate` / :func:`instantiate_properties` build what the compiler and the engines
consume. ``constants.py`` reads the command line's ``--const`` settings.
"""

from posgmc.semantics.constants import (
    ConstRange,
    ConstSetting,
    expand_sweep,
    parse_const_assignments,
)
from posgmc.semantics.queries import QueryResolver, ResolvedQuery
from posgmc.semantics.stages import (
    CheckedProperty,
    check_model,
    check_properties,
    instantiate,
    instantiate_properties,
)

__all__ = [
    "CheckedProperty",
    "ConstRange",
    "ConstSetting",
    "QueryResolver",
    "ResolvedQuery",
    "check_model",
    "check_properties",
    "expand_sweep",
    "instantiate",
    "instantiate_properties",
    "parse_const_assignments",
]
