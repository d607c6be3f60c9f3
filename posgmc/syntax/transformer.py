"""Build the immutable syntax tree (``ast.py``) from lark's parse tree, with a span on every node.

The grammar (``grammar/prism.lark``) decides the shape; this module only converts, plus the few
checks that are syntax in PRISM but easier to do on the tree: label and observable names must be
identifiers, function names and arities, one model type and one ``init`` block per file, player
items separated by commas, temporal operators only inside ``P[..]``/``R[..]``, and the
classification of reward objectives (``F phi`` with a state formula ``phi`` is a reachability
reward; any other path formula is a co-safe LTL objective).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Iterable, Sequence

from lark import Token, Transformer, v_args
from lark.tree import Meta

from posgmc.errors import ParseError, SourceSpan, UnsupportedError
from posgmc.syntax.ast import (
    ActionRef,
    Assignment,
    Binary,
    BinaryOp,
    BoolLit,
    Call,
    Coalition,
    CoalitionKind,
    Command,
    ComparisonOp,
    ConstantDecl,
    Direction,
    DoubleLit,
    Expr,
    FormulaDecl,
    Function,
    Ident,
    IntLit,
    Ite,
    LabelDecl,
    LabelRef,
    ModelFile,
    ModelType,
    Module,
    ModuleRef,
    NamedObservable,
    Observable,
    ObservableVars,
    PlayerDecl,
    PlayerRef,
    ProbQuery,
    RenamedModule,
    Renaming,
    RewardItem,
    RewardKind,
    RewardObjective,
    RewardQuery,
    RewardStructDecl,
    Temporal,
    TemporalOp,
    Threshold,
    TimeBound,
    Unary,
    UnaryOp,
    Update,
    VariableDecl,
    VarType,
)

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

_MODEL_TYPES: dict[str, ModelType] = {
    "dtmc": ModelType.DTMC,
    "probabilistic": ModelType.DTMC,
    "mdp": ModelType.MDP,
    "nondeterministic": ModelType.MDP,
    "pomdp": ModelType.POMDP,
    "smg": ModelType.SMG,
    "posg": ModelType.POSG,
}

# Decimal exponents beyond this are rejected: doubles overflow long before (1e308).
_MAX_EXPONENT = 400

# PRISM's arities (parser/ast/ExpressionFunc.java): (minimum, maximum or None for unbounded).
_ARITY: dict[Function, tuple[int, int | None]] = {
    Function.MIN: (1, None),
    Function.MAX: (1, None),
    Function.FLOOR: (1, 1),
    Function.CEIL: (1, 1),
    Function.ROUND: (1, 1),
    Function.POW: (2, 2),
    Function.MOD: (2, 2),
    Function.LOG: (2, 2),
}


# --- intermediate records (never leave this module) -------------------------------------------


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


# --- helpers -------------------------------------------------------------------------------------


def contains_temporal(expr: Expr) -> bool:
    """True if ``expr`` has a temporal operator outside any nested P/R query."""
    if isinstance(expr, Temporal):
        return True
    return any(contains_temporal(child) for child in _state_children(expr))


def _state_children(expr: Expr) -> Iterable[Expr]:
    """The operands of ``expr`` that belong to the same formula (nested queries excluded)."""
    if isinstance(expr, Unary):
        return (expr.operand,)
    if isinstance(expr, Binary):
        return (expr.left, expr.right)
    if isinstance(expr, Ite):
        return (expr.cond, expr.then, expr.otherwise)
    if isinstance(expr, Call):
        return expr.args
    if isinstance(expr, Temporal):
        return expr.operands
    return ()


def check_temporal_placement(expr: Expr, *, allowed: bool) -> None:
    """Reject temporal operators outside ``P[..]``/``R[..]`` (PRISM rejects them while parsing).

    Args:
        expr: a property expression.
        allowed: whether ``expr`` itself stands where a path formula may.

    Raises:
        ParseError: at the first misplaced temporal operator.
    """
    if isinstance(expr, Temporal):
        if not allowed:
            raise ParseError(
                f"the temporal operator {expr.op.value} may only appear inside P[...] or R[...]",
                expr.span,
                hint='write e.g. Pmax=? [ F "goal" ] instead of F "goal"',
            )
        for operand in expr.operands:
            check_temporal_placement(operand, allowed=True)
        if expr.bound is not None:
            for b in (expr.bound.lower, expr.bound.upper):
                if b is not None:
                    check_temporal_placement(b, allowed=False)
        return
    if isinstance(expr, ProbQuery):
        if expr.threshold is not None:
            check_temporal_placement(expr.threshold.value, allowed=False)
        check_temporal_placement(expr.path, allowed=True)
        return
    if isinstance(expr, RewardQuery):
        if expr.threshold is not None:
            check_temporal_placement(expr.threshold.value, allowed=False)
        obj = expr.objective
        for part in (obj.bound, obj.discount):
            if part is not None:
                check_temporal_placement(part, allowed=False)
        if obj.target is not None:
            check_temporal_placement(obj.target, allowed=obj.kind is RewardKind.LTL)
        return
    for child in _state_children(expr):
        check_temporal_placement(child, allowed=allowed)


# --- the transformer ------------------------------------------------------------------------------


@v_args(meta=True)
class AstBuilder(Transformer[Token, Any]):
    """lark tree -> ``ast.py`` nodes; one instance per parse (it knows the file name)."""

    def __init__(self, *, file: str | None) -> None:
        super().__init__(visit_tokens=False)
        self.file = file

    # --- spans ---------------------------------------------------------------------------------

    def _span(self, meta: Meta) -> SourceSpan:
        if getattr(meta, "empty", True):
            return SourceSpan(0, 0, file=self.file)
        return SourceSpan(meta.line, meta.column, meta.end_line, meta.end_column, self.file)

    def _tspan(self, token: Token) -> SourceSpan:
        line, column = token.line or 0, token.column or 0
        return SourceSpan(line, column, token.end_line, token.end_column, self.file)

    def _quoted_identifier(self, token: Token, what: str) -> str:
        name = str(token.value)[1:-1]
        if not _IDENTIFIER.match(name):
            raise ParseError(
                f"{what} names must be identifiers (letters, digits, '_'), not {token.value}",
                self._tspan(token),
            )
        return name

    # --- files ---------------------------------------------------------------------------------

    def model_file(self, meta: Meta, items: list[Any]) -> ModelFile:
        model_type: ModelTypeItem | None = None
        init: InitItem | None = None
        constants: list[ConstantDecl] = []
        formulas: list[FormulaDecl] = []
        globals_: list[VariableDecl] = []
        modules: list[Module | RenamedModule] = []
        players: list[PlayerDecl] = []
        observables: list[Observable] = []
        labels: list[LabelDecl] = []
        rewards: list[RewardStructDecl] = []
        for item in items:
            if isinstance(item, ModelTypeItem):
                if model_type is not None:
                    raise ParseError(
                        "there are multiple model type declarations",
                        item.span,
                        hint=f"the first one is at line {model_type.span.line}; keep only one",
                    )
                model_type = item
            elif isinstance(item, InitItem):
                if init is not None:
                    raise ParseError(
                        "there are multiple init...endinit blocks",
                        item.span,
                        hint=f"the first one is at line {init.span.line}; combine them with '|'",
                    )
                init = item
            elif isinstance(item, ConstantDecl):
                constants.append(item)
            elif isinstance(item, FormulaDecl):
                formulas.append(item)
            elif isinstance(item, GlobalItem):
                globals_.append(item.variable)
            elif isinstance(item, (Module, RenamedModule)):
                modules.append(item)
            elif isinstance(item, PlayerDecl):
                players.append(item)
            elif isinstance(item, (ObservableVars, NamedObservable)):
                observables.append(item)
            elif isinstance(item, LabelDecl):
                labels.append(item)
            elif isinstance(item, RewardStructDecl):
                rewards.append(item)
            else:  # pragma: no cover - the grammar admits nothing else
                raise TypeError(f"unexpected model item {item!r}")
        return ModelFile(
            model_type=model_type.model_type if model_type else ModelType.MDP,
            constants=tuple(constants),
            formulas=tuple(formulas),
            globals=tuple(globals_),
            modules=tuple(modules),
            players=tuple(players),
            observables=tuple(observables),
            labels=tuple(labels),
            rewards=tuple(rewards),
            init=init.expr if init else None,
            model_type_given=model_type is not None,
            file=self.file,
            span=self._span(meta),
        )

    def properties_file(self, meta: Meta, items: list[Any]) -> list[Any]:
        # parser.py attaches the // RESULT comments, which need the source text
        return items

    def single_property(self, meta: Meta, children: list[Any]) -> PropertyItem:
        return children[0]  # type: ignore[no-any-return]

    def single_expression(self, meta: Meta, children: list[Any]) -> Expr:
        return children[0]  # type: ignore[no-any-return]

    def single_model_expression(self, meta: Meta, children: list[Any]) -> Expr:
        return children[0]  # type: ignore[no-any-return]

    # --- declarations --------------------------------------------------------------------------

    def model_type(self, meta: Meta, children: list[Token]) -> ModelTypeItem:
        word = str(children[0].value)
        span = self._span(meta)
        if word not in _MODEL_TYPES:
            raise UnsupportedError(
                f"model type '{word}' is not supported",
                span,
                hint="posgmc handles dtmc, mdp, pomdp, smg and posg models",
            )
        return ModelTypeItem(_MODEL_TYPES[word], span)

    def const_decl(self, meta: Meta, children: list[Any]) -> ConstantDecl:
        type_ = VarType.INT  # PRISM: a constant without a type is an int
        rest = list(children)
        if isinstance(rest[0], VarType):
            type_ = rest.pop(0)
        name = str(rest[0].value)
        value = rest[1] if len(rest) > 1 else None
        return ConstantDecl(name, type_, value, span=self._span(meta))

    def const_type(self, meta: Meta, children: list[Token]) -> VarType:
        return VarType(str(children[0].value))

    def formula_decl(self, meta: Meta, children: list[Any]) -> FormulaDecl:
        return FormulaDecl(str(children[0].value), children[1], span=self._span(meta))

    def label_decl(self, meta: Meta, children: list[Any]) -> LabelDecl:
        name = self._quoted_identifier(children[0], "label")
        return LabelDecl(name, children[1], span=self._span(meta))

    def global_decl(self, meta: Meta, children: list[Any]) -> GlobalItem:
        return GlobalItem(children[0])

    def var_decl(self, meta: Meta, children: list[Any]) -> VariableDecl:
        name = str(children[0].value)
        kind = children[1]
        init = children[2] if len(children) > 2 else None
        span = self._span(meta)
        if isinstance(kind, tuple):
            low, high = kind
            return VariableDecl(name, VarType.INT, low, high, init, span=span)
        return VariableDecl(name, kind, None, None, init, span=span)

    def range_type(self, meta: Meta, children: list[Expr]) -> tuple[Expr, Expr]:
        return (children[0], children[1])

    def bool_type(self, meta: Meta, children: list[Any]) -> VarType:
        return VarType.BOOL

    def int_type(self, meta: Meta, children: list[Any]) -> VarType:
        return VarType.INT

    # --- modules -------------------------------------------------------------------------------

    def module(self, meta: Meta, children: list[Any]) -> Module:
        name = str(children[0].value)
        variables = tuple(c for c in children[1:] if isinstance(c, VariableDecl))
        commands = tuple(c for c in children[1:] if isinstance(c, Command))
        return Module(name, variables, commands, span=self._span(meta))

    def action_label(self, meta: Meta, children: list[Token]) -> ActionLabel:
        return ActionLabel(str(children[0].value) if children else None, self._span(meta))

    def command(self, meta: Meta, children: list[Any]) -> Command:
        action: ActionLabel = children[0]
        return Command(action.name, children[1], children[2], span=self._span(meta))

    def updates(self, meta: Meta, children: list[Any]) -> tuple[Update, ...]:
        if len(children) == 1 and isinstance(children[0], RawUpdate):
            raw: RawUpdate = children[0]
            return (Update(None, raw.assignments, span=raw.span),)
        return tuple(children)

    def prob_update(self, meta: Meta, children: list[Any]) -> Update:
        raw: RawUpdate = children[1]
        return Update(children[0], raw.assignments, span=self._span(meta))

    def update(self, meta: Meta, children: list[Assignment]) -> RawUpdate:
        return RawUpdate(tuple(children), self._span(meta))

    def update_true(self, meta: Meta, children: list[Any]) -> RawUpdate:
        return RawUpdate((), self._span(meta))

    def assignment(self, meta: Meta, children: list[Any]) -> Assignment:
        primed = str(children[0].value)
        return Assignment(primed[:-1], children[1], span=self._span(meta))

    def renamed_module(self, meta: Meta, children: list[Any]) -> RenamedModule:
        renamings = tuple(children[2:])
        return RenamedModule(
            str(children[0].value), str(children[1].value), renamings, span=self._span(meta)
        )

    def renaming(self, meta: Meta, children: list[Token]) -> Renaming:
        return Renaming(str(children[0].value), str(children[1].value), span=self._span(meta))

    # --- rewards, init, observables, players ----------------------------------------------------

    def reward_struct(self, meta: Meta, children: list[Any]) -> RewardStructDecl:
        name: str | None = None
        items = list(children)
        if items and isinstance(items[0], Token):
            name = self._quoted_identifier(items.pop(0), "reward structure")
        return RewardStructDecl(name, tuple(items), span=self._span(meta))

    def reward_item(self, meta: Meta, children: list[Any]) -> RewardItem:
        span = self._span(meta)
        if isinstance(children[0], ActionLabel):
            return RewardItem(True, children[0].name, children[1], children[2], span=span)
        return RewardItem(False, None, children[0], children[1], span=span)

    def init_block(self, meta: Meta, children: list[Expr]) -> InitItem:
        return InitItem(children[0], self._span(meta))

    def observables(self, meta: Meta, children: list[Token]) -> ObservableVars:
        names = tuple(Ident(str(t.value), span=self._tspan(t)) for t in children)
        return ObservableVars(names, span=self._span(meta))

    def observable(self, meta: Meta, children: list[Any]) -> NamedObservable:
        name = self._quoted_identifier(children[0], "observable")
        return NamedObservable(name, children[1], span=self._span(meta))

    def player(self, meta: Meta, children: list[Any]) -> PlayerDecl:
        name = str(children[0].value)
        modules: list[ModuleRef] = []
        actions: list[ActionRef] = []
        observables: list[Observable] = []
        previous: object = None
        for part in children[1:]:
            if isinstance(part, PlayerItems):
                if isinstance(previous, PlayerItems):
                    raise ParseError(
                        f"expected ',' between the items of player '{name}'",
                        SourceSpan(part.span.line, part.span.column, file=self.file),
                        hint="list the modules and [actions] of a player separated by commas",
                    )
                modules.extend(part.modules)
                actions.extend(part.actions)
            else:
                observables.append(part)
            previous = part
        return PlayerDecl(
            name, tuple(modules), tuple(actions), tuple(observables), span=self._span(meta)
        )

    def player_items(self, meta: Meta, children: list[Any]) -> PlayerItems:
        modules = tuple(c for c in children if isinstance(c, ModuleRef))
        actions = tuple(c for c in children if isinstance(c, ActionRef))
        return PlayerItems(modules, actions, self._span(meta))

    def player_module(self, meta: Meta, children: list[Token]) -> ModuleRef:
        return ModuleRef(str(children[0].value), span=self._span(meta))

    def player_action(self, meta: Meta, children: list[Token]) -> ActionRef:
        return ActionRef(str(children[0].value), span=self._span(meta))

    # --- properties ------------------------------------------------------------------------------

    def property(self, meta: Meta, children: list[Expr]) -> PropertyItem:
        return PropertyItem(children[0], None, self._span(meta))

    def named_property(self, meta: Meta, children: list[Any]) -> PropertyItem:
        return PropertyItem(children[1], str(children[0].value)[1:-1], self._span(meta))

    # --- expressions -----------------------------------------------------------------------------

    def ite(self, meta: Meta, children: list[Expr]) -> Ite:
        return Ite(children[0], children[1], children[2], span=self._span(meta))

    def _binary(self, op: BinaryOp, meta: Meta, children: list[Expr]) -> Binary:
        return Binary(op, children[0], children[1], span=self._span(meta))

    def implies(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.IMPLIES, meta, children)

    def iff(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.IFF, meta, children)

    def or_(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.OR, meta, children)

    def and_(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.AND, meta, children)

    def eq(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.EQ, meta, children)

    def ne(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.NE, meta, children)

    def lt(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.LT, meta, children)

    def le(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.LE, meta, children)

    def gt(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.GT, meta, children)

    def ge(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.GE, meta, children)

    def add(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.ADD, meta, children)

    def sub(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.SUB, meta, children)

    def mul(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.MUL, meta, children)

    def div(self, meta: Meta, children: list[Expr]) -> Binary:
        return self._binary(BinaryOp.DIV, meta, children)

    def not_(self, meta: Meta, children: list[Expr]) -> Unary:
        return Unary(UnaryOp.NOT, children[0], span=self._span(meta))

    def neg(self, meta: Meta, children: list[Expr]) -> Unary:
        return Unary(UnaryOp.NEG, children[0], span=self._span(meta))

    def int_lit(self, meta: Meta, children: list[Token]) -> IntLit:
        return IntLit(int(children[0].value), span=self._span(meta))

    def double_lit(self, meta: Meta, children: list[Token]) -> DoubleLit:
        text = str(children[0].value)
        _, _, exponent = text.lower().partition("e")
        # an exact Fraction of 1e999999999 would be a billion-digit integer
        if exponent and abs(int(exponent)) > _MAX_EXPONENT:
            raise ParseError(
                f"the number {text} is out of range (exponent beyond ±{_MAX_EXPONENT})",
                self._span(meta),
            )
        return DoubleLit(Fraction(text), span=self._span(meta))

    def true_lit(self, meta: Meta, children: list[Any]) -> BoolLit:
        return BoolLit(True, span=self._span(meta))

    def false_lit(self, meta: Meta, children: list[Any]) -> BoolLit:
        return BoolLit(False, span=self._span(meta))

    def ident(self, meta: Meta, children: list[Token]) -> Ident:
        return Ident(str(children[0].value), span=self._span(meta))

    def label_ref(self, meta: Meta, children: list[Token]) -> LabelRef:
        return LabelRef(self._quoted_identifier(children[0], "label"), span=self._span(meta))

    def _make_call(self, name_token: Token, args: Sequence[Expr], meta: Meta) -> Call:
        name = str(name_token.value)
        try:
            function = Function(name)
        except ValueError:
            raise ParseError(
                f"'{name}' is not a function",
                self._tspan(name_token),
                hint="the functions are min, max, floor, ceil, round, pow, mod and log",
            ) from None
        low, high = _ARITY[function]
        if len(args) < low or (high is not None and len(args) > high):
            if low == high:
                wanted = f"{low}"
            else:
                wanted = f"at least {low}" if high is None else f"{low}-{high}"
            raise ParseError(
                f"{name} takes {wanted} argument{'s' if low != 1 or high is None else ''}, "
                f"not {len(args)}",
                self._span(meta),
            )
        return Call(function, tuple(args), span=self._span(meta))

    def call(self, meta: Meta, children: list[Any]) -> Call:
        return self._make_call(children[0], children[1:], meta)

    def old_call(self, meta: Meta, children: list[Any]) -> Call:
        return self._make_call(children[0], children[1:], meta)

    # --- temporal operators ----------------------------------------------------------------------

    def _temporal(self, op: TemporalOp, meta: Meta, children: list[Any]) -> Temporal:
        bound = next((c for c in children if isinstance(c, TimeBound)), None)
        operands = tuple(c for c in children if not isinstance(c, TimeBound))
        return Temporal(op, operands, bound, span=self._span(meta))

    def next(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.NEXT, meta, children)

    def eventually(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.EVENTUALLY, meta, children)

    def globally(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.GLOBALLY, meta, children)

    def until(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.UNTIL, meta, children)

    def weak_until(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.WEAK_UNTIL, meta, children)

    def release(self, meta: Meta, children: list[Any]) -> Temporal:
        return self._temporal(TemporalOp.RELEASE, meta, children)

    def bound_le(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], span=self._span(meta))

    def bound_lt(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], upper_strict=True, span=self._span(meta))

    def bound_ge(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], span=self._span(meta))

    def bound_gt(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], lower_strict=True, span=self._span(meta))

    def bound_eq(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[0], span=self._span(meta))

    def bound_interval(self, meta: Meta, children: list[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[1], span=self._span(meta))

    # --- queries ---------------------------------------------------------------------------------

    def coalition_angle(self, meta: Meta, children: list[Any]) -> Coalition:
        return self._coalition(CoalitionKind.ANGLE, meta, children)

    def coalition_bracket(self, meta: Meta, children: list[Any]) -> Coalition:
        return self._coalition(CoalitionKind.BRACKET, meta, children)

    def _coalition(self, kind: CoalitionKind, meta: Meta, children: list[Any]) -> Coalition:
        span = self._span(meta)
        if children and isinstance(children[0], AllPlayers):
            return Coalition((), True, kind, span=span)
        players = tuple(children[0]) if children else ()
        return Coalition(players, False, kind, span=span)

    def all_players(self, meta: Meta, children: list[Any]) -> AllPlayers:
        return AllPlayers()

    def player_list(self, meta: Meta, children: list[Token]) -> tuple[PlayerRef, ...]:
        refs = []
        for tok in children:
            if tok.type == "INT":
                refs.append(PlayerRef(number=int(tok.value), span=self._tspan(tok)))
            else:
                refs.append(PlayerRef(name=str(tok.value), span=self._tspan(tok)))
        return tuple(refs)

    def relop(self, meta: Meta, children: list[Token]) -> ComparisonOp:
        return ComparisonOp(str(children[0].value))

    def reward_index(self, meta: Meta, children: list[Token]) -> str | int:
        tok = children[0]
        if tok.type == "INT":
            return int(tok.value)
        return self._quoted_identifier(tok, "reward structure")

    def _reward_of(self, children: list[Any]) -> str | int | None:
        return next((c for c in children if isinstance(c, (str, int))), None)

    def op_value(self, meta: Meta, children: list[Any]) -> QueryOp:
        return QueryOp(None, None, self._reward_of(children))

    def op_min(self, meta: Meta, children: list[Any]) -> QueryOp:
        return QueryOp(Direction.MIN, None, self._reward_of(_no_tokens(children)))

    def op_max(self, meta: Meta, children: list[Any]) -> QueryOp:
        return QueryOp(Direction.MAX, None, self._reward_of(_no_tokens(children)))

    def op_threshold(self, meta: Meta, children: list[Any]) -> QueryOp:
        op: ComparisonOp = children[-2]
        value: Expr = children[-1]
        threshold = Threshold(op, value, span=self._span(meta))
        return QueryOp(None, threshold, self._reward_of(children[:-2]))

    def prob_query(self, meta: Meta, children: list[Any]) -> ProbQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return ProbQuery(coalition, op.direction, op.threshold, children[-1], span=self._span(meta))

    def reward_query(self, meta: Meta, children: list[Any]) -> RewardQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return RewardQuery(
            coalition, op.reward, op.direction, op.threshold, children[-1], span=self._span(meta)
        )

    def rew_cumulative(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.CUMULATIVE, bound=children[0], span=self._span(meta))

    def rew_total(self, meta: Meta, children: list[Any]) -> RewardObjective:
        return RewardObjective(RewardKind.TOTAL, span=self._span(meta))

    def rew_instantaneous(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.INSTANTANEOUS, bound=children[0], span=self._span(meta))

    def rew_reach_cumulative(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(
            RewardKind.REACH_CUMULATIVE, target=children[0], span=self._span(meta)
        )

    def rew_reach_zero(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.REACH_ZERO, target=children[0], span=self._span(meta))

    def rew_discounted_total(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(
            RewardKind.DISCOUNTED_TOTAL, discount=children[0], span=self._span(meta)
        )

    def rew_discounted_reach(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        return RewardObjective(
            RewardKind.DISCOUNTED_REACH,
            target=children[1],
            discount=children[0],
            span=self._span(meta),
        )

    def rew_path(self, meta: Meta, children: list[Expr]) -> RewardObjective:
        path = children[0]
        span = self._span(meta)
        if (
            isinstance(path, Temporal)
            and path.op is TemporalOp.EVENTUALLY
            and path.bound is None
            and not contains_temporal(path.operands[0])
        ):
            return RewardObjective(RewardKind.REACH, target=path.operands[0], span=span)
        if isinstance(path, Ident) and path.name == "S":
            raise UnsupportedError(
                "long-run average rewards (R[S]) are not supported",
                path.span,
                hint="use a reachability (F), cumulative (C<=k) or total (C) reward objective",
            )
        return RewardObjective(RewardKind.LTL, target=path, span=span)


def _no_tokens(children: list[Any]) -> list[Any]:
    return [c for c in children if not isinstance(c, Token)]
