"""The parse actions of model files: the file itself, declarations, modules and commands,
rewards, ``init``, observables and players."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lark import Token

from posgmc.errors import ParseError, SourceSpan, UnsupportedError
from posgmc.syntax.actions_base import ActionBase
from posgmc.syntax.ast import (
    ActionRef,
    Assignment,
    Command,
    ConstantDecl,
    Expr,
    FormulaDecl,
    Ident,
    LabelDecl,
    ModelFile,
    ModelType,
    Module,
    ModuleRef,
    NamedObservable,
    Observable,
    ObservableVars,
    PlayerDecl,
    RenamedModule,
    Renaming,
    RewardItem,
    RewardStructDecl,
    Update,
    VariableDecl,
    VarType,
)
from posgmc.syntax.items import (
    ActionLabel,
    GlobalItem,
    InitItem,
    ModelTypeItem,
    PlayerItems,
    PropertyItem,
    RawUpdate,
)

_MODEL_TYPES: dict[str, ModelType] = {
    "dtmc": ModelType.DTMC,
    "probabilistic": ModelType.DTMC,
    "mdp": ModelType.MDP,
    "nondeterministic": ModelType.MDP,
    "pomdp": ModelType.POMDP,
    "smg": ModelType.SMG,
    "posg": ModelType.POSG,
}


class ModelActions(ActionBase):
    """Actions for the model-file rules of the grammar (see :class:`ActionBase`)."""

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
        item: PropertyItem = children[0]
        return item

    def single_expression(self, span: None, children: Sequence[Any]) -> Expr:
        expr: Expr = children[0]
        return expr

    def single_model_expression(self, span: None, children: Sequence[Any]) -> Expr:
        expr: Expr = children[0]
        return expr

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
