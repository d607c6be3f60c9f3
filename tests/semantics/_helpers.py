"""Small helpers for the semantic tests: parse text, lint it, and reduce errors to comparable
tuples (class name, message, line, column)."""

from __future__ import annotations

from collections.abc import Mapping

from posgmc.errors import PosgmcError
from posgmc.semantics.stages import check_model, check_properties
from posgmc.syntax.ast import ModelFile
from posgmc.syntax.parser import parse_model, parse_properties

Diag = tuple[str, str, int | None, int | None]


def diag(e: PosgmcError) -> Diag:
    span = e.span
    return (type(e).__name__, e.message, span.line if span else None, span.column if span else None)


def model(text: str) -> ModelFile:
    return parse_model(text, file="m.prism")


def lint(text: str, *, constants: Mapping[str, object] | None = None) -> list[Diag]:
    """The errors of a model text, in the order check_model reports them."""
    return [diag(e) for e in check_model(model(text), constants=constants)]


def lint_props(
    model_text: str,
    props_text: str,
    *,
    constants: Mapping[str, object] | None = None,
    zero_based_players: bool = False,
) -> list[Diag]:
    """The errors of a properties text checked against a model text."""
    props = parse_properties(props_text, file="p.props")
    return [
        diag(e)
        for e in check_properties(
            props, model(model_text), constants=constants, zero_based_players=zero_based_players
        )
    ]


def messages(diags: list[Diag]) -> list[str]:
    return [d[1] for d in diags]
