"""Immutable syntax trees for models and properties, exactly as written (nothing resolved yet).

One expression hierarchy serves model expressions, state formulas, path formulas and queries, as in
PRISM: ``P``/``R`` operators, temporal operators and label references are expression nodes, so that
``(F "a") | (F "b")`` and ``(1/2) * <<p1>> Rmax=? [F "g"]`` need no special cases. Later passes
(``semantics/``) decide which nodes may appear where.

Every node keeps the :class:`~posgmc.errors.SourceSpan` of its text; spans never take part in
equality or hashing, so two nodes are equal when they mean the same thing.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from fractions import Fraction

from posgmc.errors import SourceSpan

# the compiled game's enums, named here too
from posgmc.model.types import Direction as Direction
from posgmc.model.types import ModelType as ModelType

NO_SPAN = SourceSpan(0, 0)


@dataclass(frozen=True)
class Node:
    """Base class of every syntax node: its source span, keyword-only (so that subclasses declare
    their positional fields freely) and outside equality, hashing and ``repr``."""

    span: SourceSpan = field(default=NO_SPAN, compare=False, repr=False, kw_only=True)


class VarType(enum.Enum):
    INT = "int"
    DOUBLE = "double"
    BOOL = "bool"


# ---------------------------------------------------------------------------------------------
# Expressions
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Expr(Node):
    """Base class of every expression node."""


INT64_MIN = -(2**63)
INT64_MAX = 2**63 - 1
"""The int type of the language is 64-bit signed, as Storm's (docs/language.md)."""


@dataclass(frozen=True)
class IntLit(Expr):
    value: int  # within [INT64_MIN, INT64_MAX]


@dataclass(frozen=True)
class DoubleLit(Expr):
    """A decimal literal, kept exact: ``0.1`` is ``Fraction(1, 10)``."""

    value: Fraction


@dataclass(frozen=True)
class BoolLit(Expr):
    value: bool


@dataclass(frozen=True)
class Ident(Expr):
    """A name: constant, variable, formula, or (in properties) a named observable."""

    name: str


@dataclass(frozen=True)
class LabelRef(Expr):
    """A quoted label in a property, ``"goal"``; ``"init"`` and ``"deadlock"`` are built in."""

    name: str


class UnaryOp(enum.Enum):
    NOT = "!"
    NEG = "-"


class BinaryOp(enum.Enum):
    OR = "|"
    AND = "&"
    IMPLIES = "=>"
    IFF = "<=>"
    EQ = "="
    NE = "!="
    LT = "<"
    LE = "<="
    GT = ">"
    GE = ">="
    ADD = "+"
    SUB = "-"
    MUL = "*"
    DIV = "/"


@dataclass(frozen=True)
class Unary(Expr):
    op: UnaryOp
    operand: Expr


@dataclass(frozen=True)
class Binary(Expr):
    op: BinaryOp
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Ite(Expr):
    """``cond ? then : otherwise``."""

    cond: Expr
    then: Expr
    otherwise: Expr


class Function(enum.Enum):
    MIN = "min"
    MAX = "max"
    FLOOR = "floor"
    CEIL = "ceil"
    ROUND = "round"
    POW = "pow"
    MOD = "mod"
    LOG = "log"


# PRISM's arities (parser/ast/ExpressionFunc.java minArities/maxArities): (minimum, maximum or
# None for n-ary); the parser and the type checker both enforce them.
FUNCTION_ARITY: dict[Function, tuple[int, int | None]] = {
    Function.MIN: (1, None),
    Function.MAX: (1, None),
    Function.FLOOR: (1, 1),
    Function.CEIL: (1, 1),
    Function.ROUND: (1, 1),
    Function.POW: (2, 2),
    Function.MOD: (2, 2),
    Function.LOG: (2, 2),
}


@dataclass(frozen=True)
class Call(Expr):
    """``min(a, b, ...)``, ``pow(x, y)``, ``mod(i, n)``, ``log(x, base)``, ...; also written
    ``func(min, a, b)``."""

    function: Function
    args: tuple[Expr, ...]


class FilterOp(enum.Enum):
    """PRISM's filter operators (``prism/src/parser/ast/ExpressionFilter.java``)."""

    MIN = "min"
    MAX = "max"
    ARGMIN = "argmin"
    ARGMAX = "argmax"
    COUNT = "count"
    SUM = "sum"
    AVG = "avg"
    FIRST = "first"
    RANGE = "range"
    FORALL = "forall"
    EXISTS = "exists"
    PRINT = "print"
    PRINTALL = "printall"
    STATE = "state"


FILTER_ALIASES = {"+": FilterOp.SUM, "&": FilterOp.FORALL, "|": FilterOp.EXISTS}
"""PRISM's symbolic names of filter operators."""


@dataclass(frozen=True)
class Filter(Expr):
    """``filter(op, operand, states)``: ``op`` over the operand's values in the states satisfying
    ``states`` (all states when None). PRISM's old form ``P=? [ ... {states}{min} ]`` is a filter
    too."""

    op: FilterOp
    operand: Expr
    states: Expr | None = None


@dataclass(frozen=True)
class SteadyQuery(Expr):
    """PRISM's steady-state operator ``S=? [ phi ]`` / ``S>=p [ phi ]``: the long-run fraction of
    time spent in states satisfying ``phi`` (dtmcs)."""

    threshold: Threshold | None
    operand: Expr


@dataclass(frozen=True)
class PathQuantifier(Expr):
    """CTL's ``A [ path ]`` (every path satisfies it) and ``E [ path ]`` (some path does), over the
    underlying graph of the model (PRISM: ``ExpressionForAll`` / ``ExpressionExists``)."""

    universal: bool
    path: Expr


# --- temporal operators (only inside P/R operators) ------------------------------------------


class TemporalOp(enum.Enum):
    NEXT = "X"
    EVENTUALLY = "F"
    GLOBALLY = "G"
    UNTIL = "U"
    WEAK_UNTIL = "W"
    RELEASE = "R"


@dataclass(frozen=True)
class TimeBound(Node):
    """A step bound ``<=k``, ``<k``, ``>=k``, ``>k``, ``=k`` or ``[a,b]`` on a temporal operator."""

    lower: Expr | None = None
    lower_strict: bool = False
    upper: Expr | None = None
    upper_strict: bool = False


@dataclass(frozen=True)
class Temporal(Expr):
    """A temporal operator: ``X a``, ``F a``, ``G a`` (one operand) or ``a U b``, ``a W b``,
    ``a R b``."""

    op: TemporalOp
    operands: tuple[Expr, ...]
    bound: TimeBound | None = None


# --- queries ------------------------------------------------------------------------------------


class ComparisonOp(enum.Enum):
    LT = "<"
    LE = "<="
    GT = ">"
    GE = ">="


@dataclass(frozen=True)
class Threshold(Node):
    """The ``>=0.9`` of ``P>=0.9 [...]``."""

    op: ComparisonOp
    value: Expr


class CoalitionKind(enum.Enum):
    ANGLE = "<<>>"  # <<C>>: C optimises against the rest
    BRACKET = "[[]]"  # [[C]]: the dual, C cannot ensure more than the value


@dataclass(frozen=True)
class PlayerRef(Node):
    """A player in a coalition: a name, or a number as written (1-based unless the user said
    0-based)."""

    name: str | None = None
    number: int | None = None


@dataclass(frozen=True)
class Coalition(Node):
    """``<<p1,p2>>``, ``<<1>>``, ``<<*>>`` (``all_players``) or ``[[...]]``."""

    players: tuple[PlayerRef, ...] = ()
    all_players: bool = False
    kind: CoalitionKind = CoalitionKind.ANGLE


@dataclass(frozen=True)
class ProbQuery(Expr):
    """``<<C>> Pmax=? [ path ]`` or ``P>=0.9 [ path ]``: exactly one of direction/threshold may be
    omitted (``P=? [..]`` on a DTMC has neither); ``path`` is a path formula."""

    coalition: Coalition | None
    direction: Direction | None
    threshold: Threshold | None
    path: Expr


class RewardKind(enum.Enum):
    REACH = "F"  # R[F phi]: infinite where phi is not reached almost surely (PRISM's F-infinity)
    REACH_ZERO = "F0"  # R[F0 phi]: paths never reaching phi collect 0
    REACH_CUMULATIVE = "Fc"  # R[Fc phi]: paths never reaching phi collect what they collect
    CUMULATIVE = "C<="  # R[C<=k]
    TOTAL = "C"  # R[C]
    INSTANTANEOUS = "I="  # R[I=k]
    DISCOUNTED_TOTAL = "Cdiscount="  # R[Cdiscount=g]: sum_t g^t r_t (Storm's syntax)
    DISCOUNTED_REACH = "Fdiscount="  # R[Fdiscount=g phi]: discounted cost collected until phi
    STEADY = "S"  # R[S]: long-run average reward (dtmcs)
    LTL = "LTL"  # R[ co-safe LTL ]: reward until the co-safe formula is satisfied


@dataclass(frozen=True)
class RewardObjective(Node):
    """What an ``R`` query accumulates. ``target`` is the state/path formula where one is needed,
    ``bound`` the step count of ``C<=k``/``I=k``, ``discount`` the factor of the discounted
    forms."""

    kind: RewardKind
    target: Expr | None = None
    bound: Expr | None = None
    discount: Expr | None = None


@dataclass(frozen=True)
class RewardQuery(Expr):
    """``<<C>> R{"cost"}min=? [ objective ]``; ``reward`` is a name, a 1-based index, or None
    (first)."""

    coalition: Coalition | None
    reward: str | int | None
    direction: Direction | None
    threshold: Threshold | None
    objective: RewardObjective


@dataclass(frozen=True)
class MultiQuery(Expr):
    """PRISM's multi-objective query ``multi(q1, ..., qn)``; each ``objectives[i]`` is written as a
    :class:`ProbQuery` or :class:`RewardQuery` (the semantics check it): all thresholds is an
    achievability query, one ``=?`` a numerical one, two a Pareto query. PRISM-games' form
    ``<<C>> (q1 & q2)`` (a coalition over a conjunction of queries) has ``coalition`` set."""

    objectives: tuple[Expr, ...]
    coalition: Coalition | None = None


# ---------------------------------------------------------------------------------------------
# Model files
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ConstantDecl(Node):
    name: str
    type: VarType
    value: Expr | None  # None: undefined, supplied by the user (--const)


@dataclass(frozen=True)
class FormulaDecl(Node):
    name: str
    expr: Expr


@dataclass(frozen=True)
class VariableDecl(Node):
    """``x : [lo..hi] init e;`` (``low``/``high`` set) or ``b : bool init e;``."""

    name: str
    type: VarType
    low: Expr | None = None
    high: Expr | None = None
    init: Expr | None = None


@dataclass(frozen=True)
class Assignment(Node):
    """``(x' = e)``."""

    variable: str
    value: Expr


@dataclass(frozen=True)
class Update(Node):
    """``p : (x'=..)&(y'=..)``; ``true`` is an update with no assignments; probability 1 if
    omitted."""

    probability: Expr | None
    assignments: tuple[Assignment, ...]


@dataclass(frozen=True)
class Command(Node):
    """``[action] guard -> updates;`` (``action`` None for ``[]``)."""

    action: str | None
    guard: Expr
    updates: tuple[Update, ...]


@dataclass(frozen=True)
class Module(Node):
    name: str
    variables: tuple[VariableDecl, ...]
    commands: tuple[Command, ...]


@dataclass(frozen=True)
class Renaming(Node):
    old: str
    new: str


@dataclass(frozen=True)
class RenamedModule(Node):
    """``module b = a [x=y, go=stop] endmodule``."""

    name: str
    base: str
    renamings: tuple[Renaming, ...]


@dataclass(frozen=True)
class ObservableVars(Node):
    """``observables x, y endobservables``: each listed variable is observed."""

    variables: tuple[Ident, ...]


@dataclass(frozen=True)
class NamedObservable(Node):
    """``observable "name" = expr;``: the value of ``expr`` is observed (usable as a label)."""

    name: str
    expr: Expr


Observable = ObservableVars | NamedObservable


@dataclass(frozen=True)
class ActionRef(Node):
    name: str


@dataclass(frozen=True)
class ModuleRef(Node):
    name: str


@dataclass(frozen=True)
class PlayerDecl(Node):
    """``player NAME mod, [act], ... endplayer``; POSG extension: observable declarations inside,
    describing what THIS player observes (none: the player observes the whole state)."""

    name: str
    modules: tuple[ModuleRef, ...]
    actions: tuple[ActionRef, ...]
    observables: tuple[Observable, ...] = ()


@dataclass(frozen=True)
class LabelDecl(Node):
    name: str
    expr: Expr


@dataclass(frozen=True)
class RewardItem(Node):
    """``guard : value;`` (state reward, ``action`` is None and ``is_action`` False) or
    ``[a] guard : value;`` (action reward; ``action`` None with ``is_action`` for ``[]``)."""

    is_action: bool
    action: str | None
    guard: Expr
    value: Expr


@dataclass(frozen=True)
class RewardStructDecl(Node):
    name: str | None
    items: tuple[RewardItem, ...]


@dataclass(frozen=True)
class ModelFile(Node):
    """A whole model file, declarations in source order within each kind."""

    model_type: ModelType
    constants: tuple[ConstantDecl, ...] = ()
    formulas: tuple[FormulaDecl, ...] = ()
    globals: tuple[VariableDecl, ...] = ()
    modules: tuple[Module | RenamedModule, ...] = ()
    players: tuple[PlayerDecl, ...] = ()
    observables: tuple[Observable, ...] = ()  # top level (pomdp, or PAYNT-style smg)
    labels: tuple[LabelDecl, ...] = ()
    rewards: tuple[RewardStructDecl, ...] = ()
    init: Expr | None = None  # init ... endinit
    model_type_given: bool = True  # False when the file has no model-type keyword (PRISM: mdp)
    file: str | None = None


# ---------------------------------------------------------------------------------------------
# Property files
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExpectedResult(Node):
    """A ``// RESULT: v`` or ``// RESULT (k=3): v`` comment above a property (PRISM's convention);
    ``text`` is the value as written (``0.85``, ``19/15``, ``true``, ``Infinity``, ``[a,b]``,
    ``Error:co-safe``), ``constants`` the ``k=3`` part (empty for all)."""

    text: str
    constants: tuple[tuple[str, str], ...] = ()
    number: str | None = None  # ``// RESULT (guaranteed): v``: which number of the result


RESULT_NUMBERS = ("guaranteed", "vs_fss_adversary", "upper_bound", "full_observation")
"""The numbers a ``// RESULT (name): v`` line may name (besides the result's value)."""


@dataclass(frozen=True)
class Property(Node):
    expr: Expr
    name: str | None = None
    text: str = ""  # the property as written, for reports
    expected: tuple[ExpectedResult, ...] = ()


@dataclass(frozen=True)
class PropertiesFile:
    constants: tuple[ConstantDecl, ...] = ()
    formulas: tuple[FormulaDecl, ...] = ()
    labels: tuple[LabelDecl, ...] = ()
    properties: tuple[Property, ...] = ()
    file: str | None = None
