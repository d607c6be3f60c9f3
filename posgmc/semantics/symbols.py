"""The small records shared by the semantic passes: what an identifier names, and the types of
expressions.

PRISM has three namespaces that matter here: *identifiers* (constants, formulas and variables share
one namespace), *quoted names* (labels and observables share one), and the separate namespaces of
modules, actions, players and reward structures.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from posgmc.errors import PosgmcError, SemanticError, SourceSpan
from posgmc.syntax.ast import NO_SPAN, ModelType, VarType


class Type(enum.Enum):
    """The type of an expression. ``PATH`` is a path formula (``F a``, ``a U b``): only allowed
    inside ``P``/``R`` operators."""

    BOOL = "bool"
    INT = "int"
    DOUBLE = "double"
    PATH = "path formula"

    @property
    def is_numeric(self) -> bool:
        return self in (Type.INT, Type.DOUBLE)

    @property
    def is_boolean(self) -> bool:
        """Bool-valued: a state formula or a path formula."""
        return self in (Type.BOOL, Type.PATH)

    @staticmethod
    def of(var_type: VarType) -> Type:
        table = {VarType.BOOL: Type.BOOL, VarType.INT: Type.INT, VarType.DOUBLE: Type.DOUBLE}
        return table[var_type]

    def accepts(self, other: Type) -> bool:
        """May a value of type ``other`` be stored where ``self`` is expected (PRISM's
        ``canCastTypeTo``: only int -> double widens)?"""
        return self is other or (self is Type.DOUBLE and other is Type.INT)


class SymbolKind(enum.Enum):
    CONSTANT = "constant"
    FORMULA = "formula"
    VARIABLE = "variable"


@dataclass(frozen=True)
class Symbol:
    """A declared identifier. ``type`` is None for formulas (typed where they are used) and
    ``module`` is the owning module of a local variable (None: global, or not a variable)."""

    name: str
    kind: SymbolKind
    type: Type | None
    span: SourceSpan = NO_SPAN
    module: str | None = None


def model_type_phrase(t: ModelType) -> str:
    """``"an mdp"``, ``"a pomdp"``, ... for messages."""
    return ("an " if t.value[0] in "ms" else "a ") + t.value


def span_or_none(span: SourceSpan) -> SourceSpan | None:
    """Hand-built trees carry ``NO_SPAN`` (line 0); errors then carry no position at all."""
    return None if span.line == 0 else span


def report(
    errors: list[PosgmcError], message: str, span: SourceSpan, hint: str | None = None
) -> None:
    """Append a :class:`SemanticError` at ``span`` (the passes collect errors, never raise)."""
    errors.append(SemanticError(message, span_or_none(span), hint=hint))


def line_of(span: SourceSpan) -> str:
    """`` (line L)`` for messages naming an earlier definition; empty without a position."""
    return f" (line {span.line})" if span.line else ""
