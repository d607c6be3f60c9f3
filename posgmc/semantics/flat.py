"""The checked, instantiated model: what the semantic passes hand to the compiler (``compiler/``).

Everything is resolved: constants have values and are replaced by literals in every expression,
formulas are inlined, renamed modules are expanded, each identifier left in an expression is a
state variable, and every expression has been type-checked. Nothing here refers to the source
except through spans (for build-time errors that point into the model text).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from posgmc.errors import SourceSpan
from posgmc.syntax.ast import NO_SPAN, Expr, ModelType, VarType

ConstValue = int | Fraction | float | bool
"""A constant's value: int for int constants, Fraction (exact) or float for doubles, bool for
bools."""


@dataclass(frozen=True)
class Variable:
    """A state variable; bools have ``low=0``, ``high=1``. ``init`` None means "any value" is only
    allowed with an ``init ... endinit`` block; otherwise the default init is ``low`` (PRISM)."""

    name: str
    type: VarType  # INT or BOOL
    low: int
    high: int
    init: int
    module: str | None  # None: global
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatAssignment:
    variable: str
    value: Expr
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatUpdate:
    probability: Expr  # a literal 1 when omitted in the text
    assignments: tuple[FlatAssignment, ...]
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatCommand:
    module: str
    action: str | None  # None: unlabelled, not synchronised
    guard: Expr
    updates: tuple[FlatUpdate, ...]
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatModule:
    name: str
    variables: tuple[str, ...]
    commands: tuple[FlatCommand, ...]
    actions: frozenset[str]  # the labels this module synchronises on (its alphabet)
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatObservable:
    """One observed quantity: a variable (``expr`` is the Ident) or a named expression."""

    name: str
    expr: Expr
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatPlayer:
    """A player: the modules whose unlabelled commands it owns, the action labels it owns, and what
    it observes (``observables`` None: it observes the whole state)."""

    name: str
    modules: tuple[str, ...]
    actions: tuple[str, ...]
    observables: tuple[FlatObservable, ...] | None
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatRewardItem:
    is_action: bool
    action: str | None
    guard: Expr
    value: Expr
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatRewardStruct:
    name: str | None
    items: tuple[FlatRewardItem, ...]
    span: SourceSpan = NO_SPAN


@dataclass(frozen=True)
class FlatModel:
    """A model ready to explore.

    ``variables``: globals first, then each module's variables in module order (Storm's order).
    ``observables``: for a pomdp, the agent's observation; for an smg with top-level observables
    (PAYNT's POSMG files) they are kept here and given meaning by the property's coalition.
    ``init``: the ``init ... endinit`` predicate, or None (then every variable's ``init`` holds).
    ``labels``: user labels plus named observables that do not clash with a label (PRISM lets
    properties use them as labels).
    """

    model_type: ModelType
    variables: tuple[Variable, ...]
    modules: tuple[FlatModule, ...]
    players: tuple[FlatPlayer, ...]
    observables: tuple[FlatObservable, ...] | None
    labels: tuple[tuple[str, Expr], ...]
    rewards: tuple[FlatRewardStruct, ...]
    init: Expr | None
    constants: tuple[tuple[str, ConstValue], ...]
    file: str | None = None

    @property
    def actions(self) -> tuple[str, ...]:
        """All action labels, in order of first appearance."""
        seen: dict[str, None] = {}
        for m in self.modules:
            for c in m.commands:
                if c.action is not None:
                    seen.setdefault(c.action, None)
        return tuple(seen)

    def variable(self, name: str) -> Variable:
        for v in self.variables:
            if v.name == name:
                return v
        raise KeyError(name)
