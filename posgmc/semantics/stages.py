"""The semantic stage's entry points, used by ``api.py`` and the CLI: lint a model, instantiate it
into a :class:`~posgmc.semantics.flat.FlatModel`, and the same for properties.

``check_model``/``check_properties`` report *every* error found, in source order; constants the
user left undefined are not errors there, and whatever depends on their values is simply not
checked. ``instantiate``/``instantiate_properties`` need every constant and raise instead of
listing. Errors carry spans whose file is the parsed file's name; callers attach a
:class:`~posgmc.errors.SourceText` for rendering.
"""

from __future__ import annotations

from collections.abc import Mapping

from posgmc.errors import PosgmcError
from posgmc.semantics.analysis import (
    analyse_model,
    build_flat_model,
    raise_errors,
    sort_errors,
    undefined_constants_error,
)
from posgmc.semantics.flat import FlatModel
from posgmc.semantics.properties import (
    CheckedProperty,
    check_properties,
    instantiate_properties,
)
from posgmc.syntax.ast import ModelFile

__all__ = [
    "CheckedProperty",
    "check_model",
    "check_properties",
    "instantiate",
    "instantiate_properties",
]


def check_model(
    model: ModelFile,
    *,
    constants: Mapping[str, object] | None = None,
    allow_extra_constants: bool = False,
) -> list[PosgmcError]:
    """Lint a model: every error found, in source order (duplicates removed).

    Constants left undefined are not errors here: everything that does not depend on their
    values is checked; with values given, everything is.

    Args:
        model: the parsed model file.
        constants: values for undefined constants, by name: text as on the command line
            (``"4"``, ``"0.9"``, ``"true"``), Python values, or :class:`ConstSetting` (text with
            the span where it was given, from :func:`parse_const_assignments`).
        allow_extra_constants: accept names the model does not declare (set when the same mapping
            also holds properties-file constants; ``check_properties`` reports names unknown to
            both files).

    Returns:
        The errors (empty: the model is valid). Spans carry the model's file name when the parser
        recorded it; attach a SourceText for rendering.
    """
    analysis = analyse_model(
        model, constants=constants, allow_extra_constants=allow_extra_constants
    )
    return sort_errors(analysis.errors)


def instantiate(
    model: ModelFile,
    *,
    constants: Mapping[str, object] | None = None,
    allow_extra_constants: bool = False,
) -> FlatModel:
    """Check a model and build its :class:`FlatModel` (constants substituted, formulas inlined,
    renamed modules expanded, expressions folded).

    Args:
        model: the parsed model file.
        constants: values for the undefined constants (see :func:`check_model`).
        allow_extra_constants: see :func:`check_model`.

    Returns:
        The instantiated model.

    Raises:
        PosgmcError: the first error, or MultipleErrors if there are several.
        ConstantError: constants still undefined (naming all of them).
    """
    analysis = analyse_model(
        model, constants=constants, allow_extra_constants=allow_extra_constants
    )
    raise_errors(analysis.errors)
    if analysis.constants.undefined:
        raise undefined_constants_error(analysis.constants.undefined)
    return build_flat_model(analysis)
