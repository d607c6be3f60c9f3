"""Intermediate records of the parse: values that actions hand to the actions above them (a
model type, a global variable, an action label, ...), never part of the finished syntax tree
(except :class:`PropertyItem`, which :mod:`posgmc.syntax.parser` unpacks into properties)."""

from __future__ import annotations

from dataclasses import dataclass

from posgmc.errors import SourceSpan
from posgmc.syntax.ast import (
    ActionRef,
    Assignment,
    Direction,
    Expr,
    ModelType,
    ModuleRef,
    Threshold,
    VariableDecl,
)


@dataclass(frozen=True)
class ModelTypeItem:
    model_type: ModelType
    span: SourceSpan


@dataclass(frozen=True)
class GlobalItem:
    variable: VariableDecl


@dataclass(frozen=True)
class InitItem:
    expr: Expr
    span: SourceSpan


@dataclass(frozen=True)
class ActionLabel:
    name: str | None
    span: SourceSpan


@dataclass(frozen=True)
class RawUpdate:
    assignments: tuple[Assignment, ...]
    span: SourceSpan


@dataclass(frozen=True)
class PlayerItems:
    modules: tuple[ModuleRef, ...]
    actions: tuple[ActionRef, ...]
    span: SourceSpan


@dataclass(frozen=True)
class PropertyItem:
    """A property before its ``// RESULT`` comments are attached (``parser.py`` does that)."""

    expr: Expr
    name: str | None
    span: SourceSpan


@dataclass(frozen=True)
class QueryOp:
    direction: Direction | None
    threshold: Threshold | None
    reward: str | int | None


@dataclass(frozen=True)
class AllPlayers:
    pass
