"""Build the immutable syntax tree (``ast.py``) while parsing, with a span on every node.

The grammar (``grammar/prism.lark``) decides the shape; this module holds the semantic action of
each grammar rule (:class:`AstBuilder`, bound to the rules by :func:`rule_actions`), which
``parser.py`` runs during the LALR parse, so that no parse tree is built and walked. Besides
converting, it does the few checks that are syntax in PRISM but easier to do on the tree: label
and observable names must be identifiers, function names and arities, one model type and one
``init`` block per file, player items separated by commas, temporal operators only inside
``P[..]``/``R[..]``, and the classification of reward objectives (``F phi`` with a state formula
``phi`` is a reachability reward; any other path formula is a co-safe LTL objective).
"""

from __future__ import annotations

import functools
import operator
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable, Iterable, Sequence

from lark import Token
from lark.grammar import Rule

from posgmc.errors import ParseError, PosgmcError, SourceSpan, UnsupportedError
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


# --- the builder ----------------------------------------------------------------------------------


class AstBuilder:
    """The semantic actions of the LALR parse: grammar rule -> ``ast.py`` node; one instance per
    parse (it knows the file name and collects the first conversion error).

    Each action gets the span of the rule's text and the rule's children as lark would put them in
    a tree node: named tokens and nonterminal values, anonymous tokens (``"("``, ``";"``) left
    out, and the items of ``_``-prefixed rules and repetitions spliced in. :func:`rule_actions`
    binds the actions to the grammar's rules; ``parser.py`` calls them while parsing.

    Errors found here (a label that is not an identifier, a wrong arity, ...) do not stop the
    parse: the first one is kept in :attr:`error` and the action returns a stand-in, so that a
    syntax error further on is reported first, as when the conversion ran on a finished tree.
    """

    # actions that never use their span: it is not computed for them
    SPANLESS = frozenset(
        {
            "properties_file", "single_property", "single_expression", "single_model_expression",
            "const_type", "global_decl", "range_type", "bool_type", "int_type", "updates",
            "all_players", "player_list", "relop", "reward_index", "op_value", "op_min", "op_max",
        }
    )  # fmt: skip

    def __init__(self, *, file: str | None) -> None:
        self.file = file
        self.error: PosgmcError | None = None

    def _fail(self, error: PosgmcError) -> None:
        """Keep the first conversion error; the parse goes on (see the class docstring)."""
        if self.error is None:
            self.error = error

    # --- spans ---------------------------------------------------------------------------------

    def _tspan(self, token: Token) -> SourceSpan:
        line, column = token.line or 0, token.column or 0
        return SourceSpan(line, column, token.end_line, token.end_column, self.file)

    def _quoted_identifier(self, token: Token, what: str) -> str:
        name = str(token.value)[1:-1]
        if not _IDENTIFIER.match(name):
            self._fail(
                ParseError(
                    f"{what} names must be identifiers (letters, digits, '_'), not {token.value}",
                    self._tspan(token),
                )
            )
        return name

    # --- files ---------------------------------------------------------------------------------

    def model_file(self, span: SourceSpan, items: Sequence[Any]) -> ModelFile:
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
                    self._fail(
                        ParseError(
                            "there are multiple model type declarations",
                            item.span,
                            hint=f"the first one is at line {model_type.span.line}; keep only one",
                        )
                    )
                    continue
                model_type = item
            elif isinstance(item, InitItem):
                if init is not None:
                    self._fail(
                        ParseError(
                            "there are multiple init...endinit blocks",
                            item.span,
                            hint=f"the first one is at line {init.span.line}; "
                            "combine them with '|'",
                        )
                    )
                    continue
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
            span=span,
        )

    def properties_file(self, span: None, items: Sequence[Any]) -> list[Any]:
        # parser.py attaches the // RESULT comments, which need the source text
        return list(items)

    def single_property(self, span: None, children: Sequence[Any]) -> PropertyItem:
        return children[0]  # type: ignore[no-any-return]

    def single_expression(self, span: None, children: Sequence[Any]) -> Expr:
        return children[0]  # type: ignore[no-any-return]

    def single_model_expression(self, span: None, children: Sequence[Any]) -> Expr:
        return children[0]  # type: ignore[no-any-return]

    # --- declarations --------------------------------------------------------------------------

    def model_type(self, span: SourceSpan, children: Sequence[Token]) -> ModelTypeItem:
        word = str(children[0].value)
        if word not in _MODEL_TYPES:
            self._fail(
                UnsupportedError(
                    f"model type '{word}' is not supported",
                    span,
                    hint="posgmc handles dtmc, mdp, pomdp, smg and posg models",
                )
            )
            return ModelTypeItem(ModelType.MDP, span)
        return ModelTypeItem(_MODEL_TYPES[word], span)

    def const_decl(self, span: SourceSpan, children: Sequence[Any]) -> ConstantDecl:
        type_ = VarType.INT  # PRISM: a constant without a type is an int
        rest = list(children)
        if isinstance(rest[0], VarType):
            type_ = rest.pop(0)
        name = str(rest[0].value)
        value = rest[1] if len(rest) > 1 else None
        return ConstantDecl(name, type_, value, span=span)

    def const_type(self, span: None, children: Sequence[Token]) -> VarType:
        return VarType(str(children[0].value))

    def formula_decl(self, span: SourceSpan, children: Sequence[Any]) -> FormulaDecl:
        return FormulaDecl(str(children[0].value), children[1], span=span)

    def label_decl(self, span: SourceSpan, children: Sequence[Any]) -> LabelDecl:
        name = self._quoted_identifier(children[0], "label")
        return LabelDecl(name, children[1], span=span)

    def global_decl(self, span: None, children: Sequence[Any]) -> GlobalItem:
        return GlobalItem(children[0])

    def var_decl(self, span: SourceSpan, children: Sequence[Any]) -> VariableDecl:
        name = str(children[0].value)
        kind = children[1]
        init = children[2] if len(children) > 2 else None
        if isinstance(kind, tuple):
            low, high = kind
            return VariableDecl(name, VarType.INT, low, high, init, span=span)
        return VariableDecl(name, kind, None, None, init, span=span)

    def range_type(self, span: None, children: Sequence[Expr]) -> tuple[Expr, Expr]:
        return (children[0], children[1])

    def bool_type(self, span: None, children: Sequence[Any]) -> VarType:
        return VarType.BOOL

    def int_type(self, span: None, children: Sequence[Any]) -> VarType:
        return VarType.INT

    # --- modules -------------------------------------------------------------------------------

    def module(self, span: SourceSpan, children: Sequence[Any]) -> Module:
        name = str(children[0].value)
        variables = tuple(c for c in children[1:] if isinstance(c, VariableDecl))
        commands = tuple(c for c in children[1:] if isinstance(c, Command))
        return Module(name, variables, commands, span=span)

    def action_label(self, span: SourceSpan, children: Sequence[Token]) -> ActionLabel:
        return ActionLabel(str(children[0].value) if children else None, span)

    def command(self, span: SourceSpan, children: Sequence[Any]) -> Command:
        action: ActionLabel = children[0]
        return Command(action.name, children[1], children[2], span=span)

    def updates(self, span: None, children: Sequence[Any]) -> tuple[Update, ...]:
        if len(children) == 1 and isinstance(children[0], RawUpdate):
            raw: RawUpdate = children[0]
            return (Update(None, raw.assignments, span=raw.span),)
        return tuple(children)

    def prob_update(self, span: SourceSpan, children: Sequence[Any]) -> Update:
        raw: RawUpdate = children[1]
        return Update(children[0], raw.assignments, span=span)

    def update(self, span: SourceSpan, children: Sequence[Assignment]) -> RawUpdate:
        return RawUpdate(tuple(children), span)

    def update_true(self, span: SourceSpan, children: Sequence[Any]) -> RawUpdate:
        return RawUpdate((), span)

    def assignment(self, span: SourceSpan, children: Sequence[Any]) -> Assignment:
        primed = str(children[0].value)
        return Assignment(primed[:-1], children[1], span=span)

    def renamed_module(self, span: SourceSpan, children: Sequence[Any]) -> RenamedModule:
        renamings = tuple(children[2:])
        return RenamedModule(str(children[0].value), str(children[1].value), renamings, span=span)

    def renaming(self, span: SourceSpan, children: Sequence[Token]) -> Renaming:
        return Renaming(str(children[0].value), str(children[1].value), span=span)

    # --- rewards, init, observables, players ----------------------------------------------------

    def reward_struct(self, span: SourceSpan, children: Sequence[Any]) -> RewardStructDecl:
        name: str | None = None
        items = list(children)
        if items and isinstance(items[0], Token):
            name = self._quoted_identifier(items.pop(0), "reward structure")
        return RewardStructDecl(name, tuple(items), span=span)

    def reward_item(self, span: SourceSpan, children: Sequence[Any]) -> RewardItem:
        if isinstance(children[0], ActionLabel):
            return RewardItem(True, children[0].name, children[1], children[2], span=span)
        return RewardItem(False, None, children[0], children[1], span=span)

    def init_block(self, span: SourceSpan, children: Sequence[Expr]) -> InitItem:
        return InitItem(children[0], span)

    def observables(self, span: SourceSpan, children: Sequence[Token]) -> ObservableVars:
        names = tuple(Ident(str(t.value), span=self._tspan(t)) for t in children)
        return ObservableVars(names, span=span)

    def observable(self, span: SourceSpan, children: Sequence[Any]) -> NamedObservable:
        name = self._quoted_identifier(children[0], "observable")
        return NamedObservable(name, children[1], span=span)

    def player(self, span: SourceSpan, children: Sequence[Any]) -> PlayerDecl:
        name = str(children[0].value)
        modules: list[ModuleRef] = []
        actions: list[ActionRef] = []
        observables: list[Observable] = []
        previous: object = None
        for part in children[1:]:
            if isinstance(part, PlayerItems):
                if isinstance(previous, PlayerItems):
                    self._fail(
                        ParseError(
                            f"expected ',' between the items of player '{name}'",
                            SourceSpan(part.span.line, part.span.column, file=self.file),
                            hint="list the modules and [actions] of a player separated by commas",
                        )
                    )
                modules.extend(part.modules)
                actions.extend(part.actions)
            else:
                observables.append(part)
            previous = part
        return PlayerDecl(name, tuple(modules), tuple(actions), tuple(observables), span=span)

    def player_items(self, span: SourceSpan, children: Sequence[Any]) -> PlayerItems:
        modules = tuple(c for c in children if isinstance(c, ModuleRef))
        actions = tuple(c for c in children if isinstance(c, ActionRef))
        return PlayerItems(modules, actions, span)

    def player_module(self, span: SourceSpan, children: Sequence[Token]) -> ModuleRef:
        return ModuleRef(str(children[0].value), span=span)

    def player_action(self, span: SourceSpan, children: Sequence[Token]) -> ActionRef:
        return ActionRef(str(children[0].value), span=span)

    # --- properties ------------------------------------------------------------------------------

    def property(self, span: SourceSpan, children: Sequence[Expr]) -> PropertyItem:
        return PropertyItem(children[0], None, span)

    def named_property(self, span: SourceSpan, children: Sequence[Any]) -> PropertyItem:
        return PropertyItem(children[1], str(children[0].value)[1:-1], span)

    # --- expressions -----------------------------------------------------------------------------

    def ite(self, span: SourceSpan, children: Sequence[Expr]) -> Ite:
        return Ite(children[0], children[1], children[2], span=span)

    # The binary operators (implies, iff, or_, and_, eq, ne, lt, le, gt, ge, add, sub, mul, div)
    # have no method: rule_actions builds them directly from _BINARY_OPS, the hottest path.

    def not_(self, span: SourceSpan, children: Sequence[Expr]) -> Unary:
        return Unary(UnaryOp.NOT, children[0], span=span)

    def neg(self, span: SourceSpan, children: Sequence[Expr]) -> Unary:
        return Unary(UnaryOp.NEG, children[0], span=span)

    def int_lit(self, span: SourceSpan, children: Sequence[Token]) -> IntLit:
        return IntLit(int(children[0].value), span=span)

    def double_lit(self, span: SourceSpan, children: Sequence[Token]) -> DoubleLit:
        text = str(children[0].value)
        _, _, exponent = text.lower().partition("e")
        # an exact Fraction of 1e999999999 would be a billion-digit integer
        if exponent and abs(int(exponent)) > _MAX_EXPONENT:
            self._fail(
                ParseError(
                    f"the number {text} is out of range (exponent beyond ±{_MAX_EXPONENT})", span
                )
            )
            return DoubleLit(Fraction(0), span=span)
        return DoubleLit(_fraction(text), span=span)

    def true_lit(self, span: SourceSpan, children: Sequence[Any]) -> BoolLit:
        return BoolLit(True, span=span)

    def false_lit(self, span: SourceSpan, children: Sequence[Any]) -> BoolLit:
        return BoolLit(False, span=span)

    def ident(self, span: SourceSpan, children: Sequence[Token]) -> Ident:
        return Ident(str(children[0].value), span=span)

    def label_ref(self, span: SourceSpan, children: Sequence[Token]) -> LabelRef:
        return LabelRef(self._quoted_identifier(children[0], "label"), span=span)

    def _make_call(self, name_token: Token, args: Sequence[Expr], span: SourceSpan) -> Call:
        name = str(name_token.value)
        try:
            function = Function(name)
        except ValueError:
            self._fail(
                ParseError(
                    f"'{name}' is not a function",
                    self._tspan(name_token),
                    hint="the functions are min, max, floor, ceil, round, pow, mod and log",
                )
            )
            # a stand-in with the same operands, so that the parse can go on
            return Call(Function.MIN, tuple(args), span=span)
        low, high = _ARITY[function]
        if len(args) < low or (high is not None and len(args) > high):
            if low == high:
                wanted = f"{low}"
            else:
                wanted = f"at least {low}" if high is None else f"{low}-{high}"
            self._fail(
                ParseError(
                    f"{name} takes {wanted} argument{'s' if low != 1 or high is None else ''}, "
                    f"not {len(args)}",
                    span,
                )
            )
        return Call(function, tuple(args), span=span)

    def call(self, span: SourceSpan, children: Sequence[Any]) -> Call:
        return self._make_call(children[0], children[1:], span)

    def old_call(self, span: SourceSpan, children: Sequence[Any]) -> Call:
        return self._make_call(children[0], children[1:], span)

    # --- temporal operators ----------------------------------------------------------------------

    def _temporal(self, op: TemporalOp, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        bound = next((c for c in children if isinstance(c, TimeBound)), None)
        operands = tuple(c for c in children if not isinstance(c, TimeBound))
        return Temporal(op, operands, bound, span=span)

    def next(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.NEXT, span, children)

    def eventually(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.EVENTUALLY, span, children)

    def globally(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.GLOBALLY, span, children)

    def until(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.UNTIL, span, children)

    def weak_until(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.WEAK_UNTIL, span, children)

    def release(self, span: SourceSpan, children: Sequence[Any]) -> Temporal:
        return self._temporal(TemporalOp.RELEASE, span, children)

    def bound_le(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], span=span)

    def bound_lt(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(upper=children[0], upper_strict=True, span=span)

    def bound_ge(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], span=span)

    def bound_gt(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], lower_strict=True, span=span)

    def bound_eq(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[0], span=span)

    def bound_interval(self, span: SourceSpan, children: Sequence[Expr]) -> TimeBound:
        return TimeBound(lower=children[0], upper=children[1], span=span)

    # --- queries ---------------------------------------------------------------------------------

    def coalition_angle(self, span: SourceSpan, children: Sequence[Any]) -> Coalition:
        return self._coalition(CoalitionKind.ANGLE, span, children)

    def coalition_bracket(self, span: SourceSpan, children: Sequence[Any]) -> Coalition:
        return self._coalition(CoalitionKind.BRACKET, span, children)

    def _coalition(
        self, kind: CoalitionKind, span: SourceSpan, children: Sequence[Any]
    ) -> Coalition:
        if children and isinstance(children[0], AllPlayers):
            return Coalition((), True, kind, span=span)
        players = tuple(children[0]) if children else ()
        return Coalition(players, False, kind, span=span)

    def all_players(self, span: None, children: Sequence[Any]) -> AllPlayers:
        return AllPlayers()

    def player_list(self, span: None, children: Sequence[Token]) -> tuple[PlayerRef, ...]:
        refs = []
        for tok in children:
            if tok.type == "INT":
                refs.append(PlayerRef(number=int(tok.value), span=self._tspan(tok)))
            else:
                refs.append(PlayerRef(name=str(tok.value), span=self._tspan(tok)))
        return tuple(refs)

    def relop(self, span: None, children: Sequence[Token]) -> ComparisonOp:
        return ComparisonOp(str(children[0].value))

    def reward_index(self, span: None, children: Sequence[Token]) -> str | int:
        tok = children[0]
        if tok.type == "INT":
            return int(tok.value)
        return self._quoted_identifier(tok, "reward structure")

    def _reward_of(self, children: Sequence[Any]) -> str | int | None:
        return next((c for c in children if isinstance(c, (str, int))), None)

    def op_value(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(None, None, self._reward_of(children))

    def op_min(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(Direction.MIN, None, self._reward_of(_no_tokens(children)))

    def op_max(self, span: None, children: Sequence[Any]) -> QueryOp:
        return QueryOp(Direction.MAX, None, self._reward_of(_no_tokens(children)))

    def op_threshold(self, span: SourceSpan, children: Sequence[Any]) -> QueryOp:
        op: ComparisonOp = children[-2]
        value: Expr = children[-1]
        threshold = Threshold(op, value, span=span)
        return QueryOp(None, threshold, self._reward_of(children[:-2]))

    def prob_query(self, span: SourceSpan, children: Sequence[Any]) -> ProbQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return ProbQuery(coalition, op.direction, op.threshold, children[-1], span=span)

    def reward_query(self, span: SourceSpan, children: Sequence[Any]) -> RewardQuery:
        coalition = children[0] if isinstance(children[0], Coalition) else None
        op: QueryOp = children[-2]
        return RewardQuery(
            coalition, op.reward, op.direction, op.threshold, children[-1], span=span
        )

    def rew_cumulative(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.CUMULATIVE, bound=children[0], span=span)

    def rew_total(self, span: SourceSpan, children: Sequence[Any]) -> RewardObjective:
        return RewardObjective(RewardKind.TOTAL, span=span)

    def rew_instantaneous(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.INSTANTANEOUS, bound=children[0], span=span)

    def rew_reach_cumulative(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.REACH_CUMULATIVE, target=children[0], span=span)

    def rew_reach_zero(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.REACH_ZERO, target=children[0], span=span)

    def rew_discounted_total(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(RewardKind.DISCOUNTED_TOTAL, discount=children[0], span=span)

    def rew_discounted_reach(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        return RewardObjective(
            RewardKind.DISCOUNTED_REACH, target=children[1], discount=children[0], span=span
        )

    def rew_path(self, span: SourceSpan, children: Sequence[Expr]) -> RewardObjective:
        path = children[0]
        if (
            isinstance(path, Temporal)
            and path.op is TemporalOp.EVENTUALLY
            and path.bound is None
            and not contains_temporal(path.operands[0])
        ):
            return RewardObjective(RewardKind.REACH, target=path.operands[0], span=span)
        if isinstance(path, Ident) and path.name == "S":
            self._fail(
                UnsupportedError(
                    "long-run average rewards (R[S]) are not supported",
                    path.span,
                    hint="use a reachability (F), cumulative (C<=k) or total (C) reward objective",
                )
            )
        return RewardObjective(RewardKind.LTL, target=path, span=span)


def _no_tokens(children: Sequence[Any]) -> list[Any]:
    return [c for c in children if not isinstance(c, Token)]


@functools.lru_cache(maxsize=4096)
def _fraction(text: str) -> Fraction:
    # Fraction(str) parses with a regular expression; generated models repeat a few literals
    # (0.5, 0.1, ...) thousands of times, and a Fraction is immutable, so one may be shared.
    return Fraction(text)


# --- binding the actions to the grammar's rules ---------------------------------------------------

# (builder, the rule's values as on the parse stack, the first token of its text, the last)
RuleAction = Callable[[AstBuilder, list[Any], Token | None, Token | None], Any]

_BINARY_OPS: dict[str, BinaryOp] = {
    "implies": BinaryOp.IMPLIES,
    "iff": BinaryOp.IFF,
    "or_": BinaryOp.OR,
    "and_": BinaryOp.AND,
    "eq": BinaryOp.EQ,
    "ne": BinaryOp.NE,
    "lt": BinaryOp.LT,
    "le": BinaryOp.LE,
    "gt": BinaryOp.GT,
    "ge": BinaryOp.GE,
    "add": BinaryOp.ADD,
    "sub": BinaryOp.SUB,
    "mul": BinaryOp.MUL,
    "div": BinaryOp.DIV,
}


def rule_actions(rules: Sequence[Rule]) -> list[RuleAction | None]:
    """The semantic action of each grammar rule, in the order of ``rules``.

    Mirrors what lark's tree builder does with ``propagate_positions=True`` followed by a
    ``Transformer``, so that values and spans are the same: anonymous tokens are dropped
    (unless the rule is ``!``-prefixed), the items of ``_``-prefixed rules are spliced into
    their parent, a ``?``-rule with one remaining child is that child, and a node's span runs
    from the start of its first symbol's text to the end of its last one's (parentheses
    included: the span of ``(a) + b`` starts at ``(``, that of ``a`` inside stays ``a``).

    Args:
        rules: lark's compiled rules (``Lark.rules``; the parse table refers to the same objects).

    Returns:
        For each rule ``None`` when the rule has one symbol and passes its value through unchanged
        (the parser then only changes state), else a callable ``(builder, values, first_token,
        last_token) -> value``; for a rule without symbols the two tokens are ``None``.

    Raises:
        TypeError: a rule this module has no action for (the grammar and this module disagree).
    """
    return [_rule_action(rule) for rule in rules]


def _rule_action(rule: Rule) -> RuleAction | None:
    name = rule.alias or rule.options.template_source or rule.origin.name
    keep_all = rule.options.keep_all_tokens
    size = len(rule.expansion)
    # (position in the expansion, whether its value is a list to splice in)
    kept = [
        (i, not sym.is_term and sym.name.startswith("_"))
        for i, sym in enumerate(rule.expansion)
        if keep_all or not (sym.is_term and sym.filter_out)
    ]
    if rule.options.expand1 and not rule.alias:
        if len(kept) != 1 or kept[0][1]:
            raise TypeError(f"grammar rule {rule} would be inlined only sometimes")
        if size == 1:
            return None
        index = kept[0][0]
        return lambda b, c, s, e: c[index]  # the child, with the extent of the whole rule
    if rule.origin.name.startswith("_") and not rule.alias:
        # the value of a rule whose items are spliced into its parent: a list of them
        splice = _selector(kept, size, as_list=True)
        if splice is None:
            return lambda b, c, s, e: c
        return lambda b, c, s, e: splice(c)  # type: ignore[misc]
    select = _selector(kept, size, as_list=False)
    if name in _BINARY_OPS:
        op = _BINARY_OPS[name]
        if [i for i, _ in kept] != [0, 2] or size != 3:
            raise TypeError(f"grammar rule {rule} is not a binary operator")
        return lambda b, c, s, e: Binary(
            op, c[0], c[2], span=SourceSpan(s.line, s.column, e.end_line, e.end_column, b.file)
        )
    method = getattr(AstBuilder, name, None)
    if method is None or name.startswith("_"):
        raise TypeError(f"no action for grammar rule {rule}")
    if size == 0:
        return lambda b, c, s, e: method(b, SourceSpan(0, 0, file=b.file), [])
    spanless = name in AstBuilder.SPANLESS
    if select is None:
        if spanless:
            return lambda b, c, s, e: method(b, None, c)
        return lambda b, c, s, e: method(
            b, SourceSpan(s.line, s.column, e.end_line, e.end_column, b.file), c
        )
    if spanless:
        return lambda b, c, s, e: method(b, None, select(c))  # type: ignore[misc]
    return lambda b, c, s, e: method(
        b,
        SourceSpan(s.line, s.column, e.end_line, e.end_column, b.file),
        select(c),  # type: ignore[misc]
    )


def _selector(
    kept: list[tuple[int, bool]], size: int, *, as_list: bool
) -> Callable[[list[Any]], Sequence[Any]] | None:
    """The function picking a rule's children out of its stack values (``None``: all of them, as
    the list they come in); ``as_list`` asks for a list (to be spliced, or extended in place)."""
    splice = any(expand for _, expand in kept)
    positions = [i for i, _ in kept]
    if not splice:
        if positions == list(range(size)):
            return None
        if as_list:
            return lambda c: [c[i] for i in positions]
        if not positions:
            return lambda c: ()
        if len(positions) == 1:
            only = positions[0]
            return lambda c: (c[only],)
        return operator.itemgetter(*positions)

    def select(c: list[Any]) -> list[Any]:
        out: list[Any] = []
        for i, expand in kept:
            if not expand:
                out.append(c[i])
            elif out:
                out += c[i]
            else:
                # the list of a left-recursive repetition is extended in place, not copied
                # (it is consumed by this reduction), as lark's tree builder does
                out = c[i]
        return out

    return select
