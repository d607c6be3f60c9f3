"""The FlatModel compiled once for exploration: numpy expressions, choice generators, packing.

A *choice generator* produces the choices of one kind in every state of a batch. Their order is
Storm's order of choices within a state (``PrismNextStateGenerator::expand``):

1. every command that cannot synchronise (unlabelled, or labelled with an action that only one
   module has in its alphabet), module by module, command by command;
2. then each action that several modules share, in order of first appearance in the model
   (Storm: action index order), one choice per combination of enabled commands, one command per
   module in module order, combinations in lexicographic order of command positions (the last
   module varies fastest);
3. a self-loop for a state without any choice (deadlock), when deadlocks are fixed.

Counts do not depend on this order; state numbers, strategies and exports do.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from fractions import Fraction

from posgmc.compiler.compile_expr import CompiledExpr, ExprType, Scalar, compile_expr
from posgmc.compiler.state_space import StateEncoding
from posgmc.errors import BuildError, SourceSpan
from posgmc.semantics.flat import FlatCommand, FlatModel
from posgmc.syntax.ast import NO_SPAN, Expr, VarType

__all__ = [
    "Assignment",
    "Command",
    "Generator",
    "GeneratorKind",
    "Program",
    "Update",
    "compile_program",
]

UNOWNED = -1


@dataclass(frozen=True, eq=False)
class Assignment:
    variable: int
    value: CompiledExpr
    span: SourceSpan


@dataclass(frozen=True, eq=False)
class Update:
    probability: CompiledExpr
    assignments: tuple[Assignment, ...]
    span: SourceSpan


@dataclass(frozen=True, eq=False)
class Command:
    """A command ready to run; ``static_sum`` is the sum of its probabilities when all are constant
    (exact when they are exact), else None."""

    module: int
    action: int  # 0: unlabelled
    guard: CompiledExpr
    updates: tuple[Update, ...]
    static_sum: Fraction | float | None
    assigned: frozenset[int]
    span: SourceSpan
    text: str  # short description for messages: "[a] in module m" or "in module m"
    source: FlatCommand | None = None  # the command before compilation (exact exploration reads it)


class GeneratorKind(enum.Enum):
    ASYNC = "async"  # one command on its own
    SYNC = "sync"  # an action shared by several modules
    DEADLOCK = "deadlock"  # the self-loop of a deadlock state


@dataclass(frozen=True, eq=False)
class Generator:
    """One source of choices; ``index`` is its position in Storm's choice order."""

    index: int
    kind: GeneratorKind
    action: int
    owner: int  # player index, or UNOWNED
    span: SourceSpan
    command: Command | None = None  # ASYNC
    parts: tuple[tuple[Command, ...], ...] = ()  # SYNC: per participating module, its commands
    module_names: tuple[str, ...] = ()  # SYNC: the participating modules
    conflicts: tuple[tuple[int, int, int, int, int], ...] = field(default=())
    """SYNC: ``(i, ci, j, cj, var)``: command ci of part i and cj of part j both assign var."""


@dataclass(frozen=True, eq=False)
class Program:
    """Everything exploration needs, compiled once."""

    flat: FlatModel
    variable_names: tuple[str, ...]
    variable_types: tuple[ExprType, ...]
    slots: dict[str, tuple[int, ExprType]]
    ranges: dict[str, tuple[int, int]]  # declared range of each int variable
    encoding: StateEncoding
    action_names: tuple[str, ...]  # [0] == ""
    generators: tuple[Generator, ...]
    deadlock_generator: Generator
    module_names: tuple[str, ...]

    def compile(self, expr: Expr) -> CompiledExpr:
        return compile_expr(expr, self.slots, self.ranges)

    def describe(self, values: list[int]) -> str:
        """A valuation as PRISM prints it: ``(x=1, b=true)``."""
        parts = []
        for name, t, v in zip(self.variable_names, self.variable_types, values):
            parts.append(
                f"{name}={'true' if v else 'false'}" if t is ExprType.BOOL else f"{name}={int(v)}"
            )
        return "(" + ", ".join(parts) + ")"


def _exact(value: Scalar) -> bool:
    return isinstance(value, (int, Fraction))


def _compile_command(
    flat_cmd: FlatCommand,
    module: int,
    action: int,
    slots: dict[str, tuple[int, ExprType]],
    ranges: dict[str, tuple[int, int]],
) -> Command:
    guard = compile_expr(flat_cmd.guard, slots, ranges)
    updates = []
    assigned: set[int] = set()
    consts: list[Scalar | None] = []
    for up in flat_cmd.updates:
        prob = compile_expr(up.probability, slots, ranges)
        consts.append(prob.constant)
        assigns = []
        for a in up.assignments:
            index, _ = slots[a.variable]
            assigned.add(index)
            assigns.append(
                Assignment(
                    index,
                    compile_expr(a.value, slots, ranges),
                    a.span if a.span != NO_SPAN else up.span,
                )
            )
        updates.append(
            Update(prob, tuple(assigns), up.span if up.span != NO_SPAN else flat_cmd.span)
        )
    static_sum: Fraction | float | None = None
    values = [c for c in consts if c is not None]
    if len(values) == len(consts):
        if all(_exact(c) for c in values):
            static_sum = sum((Fraction(c) for c in values), Fraction(0))
        else:
            static_sum = sum(float(c) for c in values)
    label = f"[{flat_cmd.action}] " if flat_cmd.action is not None else "[] "
    return Command(
        module=module,
        action=action,
        guard=guard,
        updates=tuple(updates),
        static_sum=static_sum,
        assigned=frozenset(assigned),
        span=flat_cmd.span,
        text=f"command {label}of module {flat_cmd.module}",
        source=flat_cmd,
    )


def compile_program(flat: FlatModel) -> Program:
    """Compile every expression of ``flat`` and lay out the choice generators in Storm's order.

    Args:
        flat: the instantiated model.

    Returns:
        The compiled program.

    Raises:
        BuildError: a variable whose initial value lies outside its range.
    """
    names = tuple(v.name for v in flat.variables)
    types = tuple(ExprType.BOOL if v.type is VarType.BOOL else ExprType.INT for v in flat.variables)
    slots = {n: (i, t) for i, (n, t) in enumerate(zip(names, types))}
    ranges = {v.name: (v.low, v.high) for v in flat.variables if v.type is not VarType.BOOL}
    for v in flat.variables:
        if v.low > v.high:
            raise BuildError(f"variable '{v.name}' has an empty range [{v.low}..{v.high}]", v.span)
    encoding = StateEncoding([(v.low, v.high, v.type is VarType.BOOL) for v in flat.variables])
    action_list = flat.actions
    action_names = ("",) + tuple(action_list)
    action_id = {a: i + 1 for i, a in enumerate(action_list)}
    module_names = tuple(m.name for m in flat.modules)
    module_index = {n: i for i, n in enumerate(module_names)}

    # ownership (games): a module's unlabelled commands, an action's choices
    module_owner = [UNOWNED] * len(module_names)
    action_owner = [UNOWNED] * len(action_names)
    for p, player in enumerate(flat.players):
        for module_name in player.modules:
            if module_name in module_index:
                module_owner[module_index[module_name]] = p
        for action_name in player.actions:
            if action_name in action_id:
                action_owner[action_id[action_name]] = p

    # which modules have each action in their alphabet (and commands for it)
    alphabet_modules: dict[int, list[int]] = {}
    for mi, m in enumerate(flat.modules):
        acts = set(m.actions) | {c.action for c in m.commands if c.action is not None}
        for name in acts:
            if name in action_id:
                alphabet_modules.setdefault(action_id[name], []).append(mi)

    compiled: list[list[Command]] = []
    for mi, m in enumerate(flat.modules):
        compiled.append(
            [
                _compile_command(
                    c, mi, action_id[c.action] if c.action is not None else 0, slots, ranges
                )
                for c in m.commands
            ]
        )

    generators: list[Generator] = []
    for mi, cmds in enumerate(compiled):
        for cmd in cmds:
            if cmd.action == 0 or len(alphabet_modules.get(cmd.action, ())) <= 1:
                owner = module_owner[mi] if cmd.action == 0 else action_owner[cmd.action]
                generators.append(
                    Generator(
                        len(generators),
                        GeneratorKind.ASYNC,
                        cmd.action,
                        owner,
                        cmd.span,
                        command=cmd,
                    )
                )
    for a in range(1, len(action_names)):
        mods = alphabet_modules.get(a, [])
        if len(mods) <= 1:
            continue
        parts = tuple(tuple(c for c in compiled[mi] if c.action == a) for mi in mods)
        if any(not p for p in parts):
            continue  # a module with the action in its alphabet but no command: never enabled
        conflicts = []
        for i in range(len(parts)):
            for j in range(i + 1, len(parts)):
                for ci, c1 in enumerate(parts[i]):
                    for cj, c2 in enumerate(parts[j]):
                        for var in sorted(c1.assigned & c2.assigned):
                            conflicts.append((i, ci, j, cj, var))
        generators.append(
            Generator(
                len(generators),
                GeneratorKind.SYNC,
                a,
                action_owner[a],
                parts[0][0].span,
                parts=parts,
                module_names=tuple(module_names[mi] for mi in mods),
                conflicts=tuple(conflicts),
            )
        )
    deadlock = Generator(len(generators), GeneratorKind.DEADLOCK, 0, UNOWNED, NO_SPAN)
    return Program(
        flat=flat,
        variable_names=names,
        variable_types=types,
        slots=slots,
        ranges=ranges,
        encoding=encoding,
        action_names=action_names,
        generators=tuple(generators),
        deadlock_generator=deadlock,
        module_names=module_names,
    )
